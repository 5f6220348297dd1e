#' Computer model runs
#'
#' Holds the design of a computer experiment and the output curve of every run
#' at one or several sites. Runs that failed (a curve that is all `NA` or has
#' any non-finite value at any site) are dropped with a warning naming them, as
#' the method drops runs that did not converge.
#'
#' A grid that is not dyadic (a power of two of equally spaced points) is
#' linearly interpolated to the next dyadic grid on the same interval, with a
#' message.
#'
#' Runs may come each on their own times (a simulator with adaptive time
#' steps): `t` a list by site, each a vector (every run on it) or a list with
#' one vector of increasing times per run, and `curves` a list by site of
#' lists of vectors (one per run, in the design's order) or matrices. Each
#' run is then linearly interpolated onto `grid` (the field's `field$t`, say)
#' or, without it, onto 2^k equally spaced points on the range that every
#' run covers, 2^k the next power of two of the most times of any run. When
#' every run has the same times the result is that of the one-`t` form.
#'
#' Runs in a long data frame (one row per output value, one file per run read
#' and stacked): `model_runs(design = design, data, t = "time", y = "load",
#' site = "channel", run = "run")`. The design has one row per run; its rows
#' are matched to the runs by its column named as `run` (then dropped from
#' the inputs) or, without such a column, by position when the runs are
#' numbered 1 to K. A run of the design without rows in the data is a failed
#' run (dropped with a warning); a run of the data missing from the design, a
#' misspelt column or a design that cannot be matched is an error of class
#' `wavevalid_error_column`.
#'
#' @param design A data frame (or matrix with column names) with one row per
#'   run and one numeric column per input (in the long form, also the column
#'   of runs, or rows in the order of runs numbered 1 to K).
#' @param curves A K x T matrix of outputs (one site) or a named list of such
#'   matrices, one per site; with `t` a list, a list by site of runs on their
#'   own times; or a long data frame (with `t` a column name).
#' @param t The time grid, T increasing values; or a list by site of each
#'   run's times; or, with a data frame as `curves`, the name of its column of
#'   times.
#' @param site Site name(s) when `curves` is a matrix or an unnamed list; with
#'   a data frame as `curves`, the name of its column of sites (optional).
#' @param grid Optional dyadic grid to interpolate the runs onto; it must lie
#'   within every run's times up to one step at either end.
#' @param y,run With a data frame as `curves`: the names of its column of
#'   output values and of runs.
#' @return A `wv_runs` object: a list with `design` (data frame, K rows),
#'   `t` (grid) and `curves` (named list of K x T matrices, one per site).
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' design <- data.frame(a = runif(5), b = runif(5))
#' curves <- t(sapply(design$a, function(a) sin(2 * pi * t * (1 + a))))
#' runs <- model_runs(design, curves, t)
#' runs
#'
#' # the same runs in long form, the design matched by its column `run`
#' long <- data.frame(run = rep(1:5, each = 64), time = rep(t, 5), y = as.vector(t(curves)))
#' model_runs(design = cbind(run = 1:5, design), long, t = "time", y = "y", run = "run")
#'
#' # each run on its own times, onto a 64-point grid
#' own <- lapply(design$a, function(a) sort(c(0, 1, runif(40))))
#' out <- lapply(seq_along(own), function(k) sin(2 * pi * own[[k]] * (1 + design$a[k])))
#' model_runs(design, list(out), list(own), grid = t)
model_runs <- function(design, curves, t, site = NULL, grid = NULL, y = NULL, run = NULL) {
  if (is_long_form(curves, t)) {
    long <- long_curves(curves, list(t = t, y = y, site = site, run = run), "run", strict = TRUE)
    by_run <- design_by_run(design, long$ids, run)
    design <- by_run$design
    t <- curves <- list()
    for (s in names(long$t)) {
      k <- by_run$index[[s]]
      t[[s]] <- lapply(k, function(i) long$t[[s]][[if (is.na(i)) k[!is.na(k)][1] else i]])
      curves[[s]] <- lapply(seq_along(k), function(j) if (is.na(k[j]))
                              rep(NA_real_, length(t[[s]][[j]])) else long$curves[[s]][[k[j]]])
    }
    site <- NULL
  } else if (!is.null(y) || !is.null(run)) {
    wv_abort(c("{.arg y} and {.arg run} name columns of a long data frame.",
               "i" = "Give the data frame as {.arg curves} and the column of the times as {.arg t}, e.g. {.code model_runs(design, data, t = \"time\", y = \"load\", run = \"run\")}."),
             class = c("column", "input"))
  }
  if (is.matrix(design)) {
    if (is.null(colnames(design))) {
      wv_abort("{.arg design} must have column names, one per input.")
    }
    design <- as.data.frame(design)
  }
  if (!is.data.frame(design)) {
    wv_abort("{.arg design} must be a data frame with one column per input, not {.obj_type_friendly {design}}.")
  }
  if (nrow(design) == 0L || ncol(design) == 0L) {
    wv_abort("{.arg design} is empty; it needs at least one run and one input.")
  }
  nonnum <- !vapply(design, is.numeric, logical(1))
  if (any(nonnum)) {
    wv_abort("Every column of {.arg design} must be numeric; {.val {names(design)[nonnum]}} {?is/are} not.")
  }
  if (any(!vapply(design, function(v) all(is.finite(v)), logical(1)))) {
    wv_abort("{.arg design} must not contain NA or infinite values.")
  }
  check_names(names(design), "design")
  if (is.list(t)) {
    pts <- own_points(curves, t, site, strict = TRUE, what = "runs")
    for (s in names(pts)) {
      if (length(pts[[s]]) != nrow(design)) {
        wv_abort(c("{.arg curves} must hold one curve per run of {.arg design}.",
                   "x" = "Site {.val {s}} has {length(pts[[s]])} and {.arg design} has {nrow(design)} rows."))
      }
    }
    t <- common_times(pts)
    if (is.null(t)) {
      t <- own_points_grid(pts, grid)
      curves <- lapply(pts, function(p) do.call(rbind, lapply(p, function(cv) {
        if (any(!is.finite(cv$y))) rep(NA_real_, length(t)) else stats::approx(cv$t, cv$y, xout = t,
                                                                               rule = 2)$y
      })))
      grid <- NULL
    } else {
      curves <- lapply(pts, function(p) do.call(rbind, lapply(p, function(cv) cv$y)))
    }
    site <- NULL
  }
  t <- check_grid(t)
  curves <- as_site_list(curves, site, nrow(design), length(t), what = "runs")
  if (!is.null(grid)) {
    grid <- check_field_grid(grid, t)
    curves <- interpolate_curves(t, curves, grid, rule = 2)
    t <- grid
  }
  rownames(design) <- NULL

  failed <- Reduce(`|`, lapply(curves, function(m) apply(m, 1L, function(r) any(!is.finite(r)))))
  if (any(failed)) {
    wv_warn(c(
      "Dropped {sum(failed)} failed run{?s} (curve with NA or non-finite values): run{?s} {which(failed)}.",
      "i" = "{sum(!failed)} run{?s} remain."
    ), class = "failed_runs")
    design <- design[!failed, , drop = FALSE]
    curves <- lapply(curves, function(m) m[!failed, , drop = FALSE])
    rownames(design) <- NULL
  }
  if (nrow(design) < 2L) {
    wv_abort(
      "Fewer than two usable runs remain; a computer experiment needs more runs than inputs.")
  }
  regridded <- to_dyadic(t, curves)
  validate_wv_runs(new_wv_runs(design, regridded$t, regridded$curves))
}

# The design of runs given in long form: the rows of `design` matched to the
# runs' ids (by site) through its column `run` when it has one (then dropped),
# else by position when the ids are 1, ..., K. Returns the design and, by
# site, the index of each design row among the site's runs (NA: no curve, a
# failed run).
design_by_run <- function(design, ids, run, call = rlang::caller_env()) {
  if (is.matrix(design)) design <- as.data.frame(design)
  if (!is.data.frame(design)) {
    wv_abort("{.arg design} must be a data frame with one row per run, not {.obj_type_friendly {design}}.", call = call)
  }
  all_ids <- unique(unlist(ids, use.names = FALSE))
  if (!is.null(run) && run %in% names(design)) {
    key <- as.character(design[[run]])
    if (anyNA(key) || anyDuplicated(key)) {
      wv_abort("Column {.val {run}} of {.arg design} must name each run once.",
               class = c("column", "input"), call = call)
    }
    design <- design[setdiff(names(design), run)]
  } else if (setequal(all_ids, as.character(seq_len(nrow(design))))) {
    key <- as.character(seq_len(nrow(design)))
  } else {
    wv_abort(c("{.arg design} must tell which row is which run.",
               "x" = "It has no column {.val {run %||% 'run'}}, and the runs are not numbered 1 to {nrow(design)}.",
               "i" = "Add the run of each row to {.arg design} as a column named as in {.arg data}{if (is.null(run)) ', and name it with `run`' else ''}."),
             class = c("column", "input"), call = call)
  }
  extra <- setdiff(all_ids, key)
  if (length(extra)) {
    wv_abort(c("The data hold run{?s} {.val {extra}} that {.arg design} does not.",
               "i" = "Give every run its inputs in {.arg design}."), class = c("column", "input"),
             call = call)
  }
  list(design = design, index = lapply(ids, function(v) match(key, v)))
}

new_wv_runs <- function(design, t, curves) {
  structure(list(design = design, t = t, curves = curves), class = "wv_runs")
}

validate_wv_runs <- function(x, call = rlang::caller_env()) {
  if (!is.data.frame(x$design)) wv_abort("{.field design} must be a data frame.", call = call)
  k <- nrow(x$design)
  for (s in names(x$curves)) {
    d <- dim(x$curves[[s]])
    if (d[1] != k || d[2] != length(x$t)) {
      wv_abort("Site {.val {s}}: curves are {d[1]} x {d[2]}, expected {k} x {length(x$t)}.",
               call = call)
    }
  }
  x
}

# --- helpers ---------------------------------------------------------------

check_names <- function(nm, arg, call = rlang::caller_env()) {
  if (is.null(nm) || anyNA(nm) || any(!nzchar(nm))) {
    wv_abort("Every column of {.arg {arg}} needs a name.", call = call)
  }
  dup <- unique(nm[duplicated(nm)])
  if (length(dup))
    wv_abort("Column names of {.arg {arg}} must be unique; {.val {dup}} repeat{?s/}.", call = call)
  invisible(nm)
}

# Long data frame of a K x T matrix of curves.
curves_long <- function(m, t, site, id_name = "run") {
  out <- data.frame(
    site = site,
    id = rep(seq_len(nrow(m)), times = ncol(m)),
    t = rep(t, each = nrow(m)),
    y = as.vector(m)
  )
  names(out)[2] <- id_name
  out
}

#' Combine model runs
#'
#' Puts together sets of runs of the same model: a first space-filling wave
#' and runs added later, for instance at [design_posterior()]. The emulators
#' are then fitted again to all of them.
#'
#' @param ... `wv_runs` objects on the same time grid, with the same sites
#'   and the same inputs (columns of the design, in any order).
#' @return A `wv_runs` object with the runs of every argument, in order.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' first <- model_runs(data.frame(a = c(0.1, 0.5, 0.9)),
#'                     t(sapply(c(0.1, 0.5, 0.9), function(a) sin(a * t))), t)
#' more <- model_runs(data.frame(a = c(0.3, 0.7)),
#'                    t(sapply(c(0.3, 0.7), function(a) sin(a * t))), t)
#' c(first, more)
c.wv_runs <- function(...) {
  runs <- list(...)
  ok <- vapply(runs, inherits, logical(1), "wv_runs")
  if (!all(ok)) {
    wv_abort(c("Only {.cls wv_runs} objects can be combined with model runs.",
               "x" = "Argument{?s} {which(!ok)} {?is/are} not."))
  }
  registered <- vapply(runs, function(r) !is.null(r$warps), logical(1))
  if (any(registered)) {
    wv_abort(c("Registered runs cannot be combined.",
               "x" = "Argument{?s} {which(registered)} {?was/were} registered with {.fn register_curves}.",
               "i" = "Combine the runs as simulated, then register the combined runs to one reference."))
  }
  first <- runs[[1]]
  inputs <- names(first$design)
  sites <- names(first$curves)
  for (i in seq_along(runs)[-1]) {
    r <- runs[[i]]
    check_same_grid(r$t, first$t, paste("argument", i), "argument 1")
    if (!setequal(names(r$curves), sites)) {
      wv_abort(c("Runs to combine must have the same sites.",
                 "x" = "Argument {i} has {.val {names(r$curves)}}; the first has {.val {sites}}."))
    }
    if (!setequal(names(r$design), inputs)) {
      wv_abort(c("Runs to combine must have the same inputs.",
                 "x" = "Argument {i} has {.val {names(r$design)}}; the first has {.val {inputs}}.",
                 "i" = "Give every run a value of every input (fixed inputs at their fixed value)."))
    }
  }
  design <- do.call(rbind, lapply(runs, function(r) r$design[inputs]))
  rownames(design) <- NULL
  check_distinct_runs(design)
  curves <- stats::setNames(lapply(sites,
                                   function(s) do.call(rbind,
                                                       lapply(runs, function(r) r$curves[[s]]))),
                            sites)
  validate_wv_runs(new_wv_runs(design, first$t, curves))
}

# Refuses a design (matrix or data frame of runs) that repeats a point: the
# emulators interpolate, so two runs at one input make their correlation
# matrix singular.
check_distinct_runs <- function(design, call = rlang::caller_env()) {
  dup <- which(duplicated(design) | duplicated(design, fromLast = TRUE))
  if (length(dup)) {
    wv_abort(c(
      "The design repeats a point: runs {dup} are at the same inputs.",
      "i" = "A deterministic model gives the same curve twice and the emulators' correlation matrix is singular; keep one run of each."
    ), call = call)
  }
  invisible(design)
}

#' @export
print.wv_runs <- function(x, ...) {
  k <- nrow(x$design)
  cli::cat_line(sprintf("<wv_runs> %d model run%s of %d input%s on %d time points in [%s, %s]%s",
                        k, if (k == 1) "" else "s", ncol(x$design),
                        if (ncol(x$design) == 1) "" else "s",
                        length(x$t), format(signif(min(x$t), 4)), format(signif(max(x$t), 4)),
                        if (!is.null(x$warps)) ", registered" else ""))
  cli::cat_line("  inputs: ", paste(names(x$design), collapse = ", "))
  cli::cat_line("  sites:  ", paste(names(x$curves), collapse = ", "))
  invisible(x)
}

#' @export
summary.wv_runs <- function(object, ...) {
  structure(list(
    n_runs = nrow(object$design),
    n_t = length(object$t),
    range_t = range(object$t),
    inputs = vapply(object$design, range, numeric(2)),
    output = vapply(object$curves,
                    function(m) c(min = min(m), max = max(m),
                                  sd_between = mean(apply(m, 2, stats::sd))), numeric(3))
  ), class = "summary_wv_runs")
}

#' @export
print.summary_wv_runs <- function(x, ...) {
  cli::cat_line(sprintf("%d model runs on %d time points in [%s, %s]", x$n_runs, x$n_t,
                        format(signif(x$range_t[1], 4)), format(signif(x$range_t[2], 4))))
  cli::cat_line("Input ranges in the design:")
  r <- t(x$inputs)
  colnames(r) <- c("min", "max")
  print(signif(r, 4))
  cli::cat_line("Output by site (min, max, mean sd across runs):")
  print(signif(t(x$output), 4))
  invisible(x)
}

#' Plot model runs and field data
#'
#' Draws the model runs in grey and the field replicates in colour, one panel
#' per site (and per event window when `windows` is given), with the window
#' limits as dashed lines: the look of Figure 1 of the method's report.
#'
#' @inheritParams autoplot.wv_fit
#' @param object A `wv_runs` or `wv_field` object.
#' @param field Optional `wv_field` to overlay on model runs.
#' @param ... Unused.
#' @return A ggplot object.
#' @name autoplot-curves
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' runs <- model_runs(data.frame(a = 1:4 / 5),
#'                    t(sapply(1:4, function(k) sin(2 * pi * t * k / 4))), t)
#' autoplot(runs, windows = list(c(0.1, 0.4), c(0.6, 0.9)))
NULL

#' @rdname autoplot-curves
#' @export
autoplot.wv_runs <- function(object, field = NULL, windows = NULL, ...) {
  if (!is.null(field)) check_class(field, "wv_field")
  plot_curves(object, field, windows)
}

#' @rdname autoplot-curves
#' @export
autoplot.wv_field <- function(object, windows = NULL, ...) {
  plot_curves(NULL, object, windows)
}

#' @export
plot.wv_runs <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}

#' @export
plot.wv_field <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}

plot_curves <- function(runs, field, windows) {
  add_window <- function(df) with_windows(df, windows, whole = "whole record")
  p <- ggplot2::ggplot()
  if (!is.null(runs)) {
    d <- do.call(rbind,
                 lapply(names(runs$curves),
                        function(s) curves_long(runs$curves[[s]], runs$t, s, "run")))
    d <- add_window(d)
    p <- p + ggplot2::geom_line(data = d, ggplot2::aes(.data$t, .data$y, group = .data$run),
                                colour = "grey60", linewidth = 0.25, alpha = 0.6)
  }
  if (!is.null(field)) {
    d <- do.call(rbind,
                 lapply(names(field$curves),
                        function(s) curves_long(field$curves[[s]], field$t, s, "replicate")))
    d <- add_window(d)
    d$replicate <- factor(d$replicate)
    p <- p + ggplot2::geom_line(data = d, ggplot2::aes(.data$t, .data$y, group = .data$replicate,
                                                       colour = .data$replicate), linewidth = 0.35)
  }
  p <- p + ggplot2::facet_grid(site ~ window, scales = "free") +
    ggplot2::labs(x = "time", y = "output", colour = "field\nreplicate",
                  title = if (!is.null(runs) && !is.null(field)) "Model runs (grey) and field replicates" else NULL) +
    ggplot2::theme_bw()
  p
}
