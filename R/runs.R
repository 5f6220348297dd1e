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
#' @param design A data frame (or matrix with column names) with one row per
#'   run and one numeric column per input.
#' @param curves A K x T matrix of outputs (one site) or a named list of such
#'   matrices, one per site.
#' @param t The time grid, T increasing values.
#' @param site Site name(s) when `curves` is a matrix or an unnamed list.
#' @return A `wv_runs` object: a list with `design` (data frame, K rows),
#'   `t` (grid) and `curves` (named list of K x T matrices, one per site).
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' design <- data.frame(a = runif(5), b = runif(5))
#' curves <- t(sapply(design$a, function(a) sin(2 * pi * t * (1 + a))))
#' runs <- model_runs(design, curves, t)
#' runs
model_runs <- function(design, curves, t, site = NULL) {
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
  t <- check_grid(t)
  curves <- as_site_list(curves, site, nrow(design), length(t), what = "runs")
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
    wv_abort("Fewer than two usable runs remain; a computer experiment needs more runs than inputs.")
  }
  regridded <- to_dyadic(t, curves)
  validate_wv_runs(new_wv_runs(design, regridded$t, regridded$curves))
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
      wv_abort("Site {.val {s}}: curves are {d[1]} x {d[2]}, expected {k} x {length(x$t)}.", call = call)
    }
  }
  x
}

#' Field measurements
#'
#' Holds the replicate field curves of one physical system at one or several
#' sites. Missing values inside a field curve are refused: field data are not
#' dropped silently.
#'
#' The curves are put on a dyadic grid for the wavelet basis: `t` itself when
#' it is one, else `grid` (the model runs' grid, say) or 2^k equally spaced
#' points on the range of `t`, by linear interpolation (with a message).
#'
#' @section Noise evidence kept from the measurements:
#' A measured curve on its own grid holds evidence of the measurement noise
#' that the interpolated curve loses, and `field_runs()` keeps it for the
#' noise learned with one replicate ([noise_prior()], the default in
#' [calibrate()] with one replicate):
#' * **Repeated time stamps.** `t` may repeat a time stamp (a velocimeter
#'   that records some times twice). The values at one time stamp are
#'   averaged; their scatter about their mean, a sum of squares `ss` with
#'   `df` degrees of freedom (the number of values less the number of
#'   distinct stamps, summed over replicates), is independent of the averaged
#'   curve and enters the likelihood of the noise variance `sigma2` of one
#'   measurement as `ss / sigma2 ~ chi^2_df`.
#' * **The detail of the measured curve.** The noise standard deviation is
#'   estimated on the distinct time stamps before interpolation, from each
#'   point's deviation from the straight line through its two neighbours
#'   (the difference-based estimate of Gasser, Sroka and Jennen-Steinmetz,
#'   1986, made robust by the median absolute deviation). It is the default
#'   scale of [noise_prior()] for the site.
#' * **The resampling.** Averaging and interpolation turn white measurement
#'   noise of variance `sigma2` into noise of known covariance on the grid:
#'   [calibrate()] gives each retained wavelet coefficient its own noise
#'   variance, `sigma2` times the diagonal of that covariance carried through
#'   the basis (an interpolated curve's finest coefficients hold little of
#'   the noise; its coarse ones hold more than `sigma2`). Correlations between
#'   coefficients are left out, and so is the resampling of a later
#'   registration ([register_curves()]).
#'
#' On a dyadic `t` without repeated stamps there is nothing to keep: the
#' noise is then learned from the curve on its own grid, as in the method.
#'
#' @param curves An R x T matrix of replicate curves (one site) or a named list
#'   of such matrices, one column per element of `t`.
#' @param t The time of each column of `curves`, non-decreasing; a time stamp
#'   may repeat (repeated measurements, see the section on noise evidence).
#' @param site Optional site names (one per matrix of `curves`).
#' @param x_nom Optional named numeric vector of nominal input values of the
#'   tested system (defaults to the nominals of the I/U map at calibration).
#' @param grid Optional dyadic time grid to put the curves on (the model runs'
#'   `runs$t`); it must lie within the range of `t` up to one step of `t` at
#'   either end, where the curves are held at their first and last values.
#'   `NULL`: `t` when it is dyadic without repeats, else 2^k equally spaced
#'   points on the range of `t`.
#' @return A `wv_field` object: a list with `t`, `curves` (named list of R x T
#'   matrices), `x_nom`, and `noise` (by site, the noise evidence kept from
#'   the measurements, `NULL` when the curves are on their own dyadic grid).
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' reps <- t(replicate(3, sin(2 * pi * t) + rnorm(64, sd = 0.1)))
#' field_runs(reps, t)
#'
#' # one curve with every fourth time stamp measured twice, onto 128 points
#' t_obs <- sort(c(seq(0, 1, length.out = 100), seq(0, 1, length.out = 100)[c(TRUE, FALSE, FALSE, FALSE)]))
#' y <- sin(2 * pi * t_obs) + rnorm(length(t_obs), sd = 0.05)
#' f <- field_runs(rbind(y), t_obs, grid = seq(0, 1, length.out = 128))
#' f
#' f$noise$site1$detail_sd
field_runs <- function(curves, t, x_nom = NULL, site = NULL, grid = NULL) {
  t <- check_stamps(t)
  curves <- as_site_list(curves, site, NULL, length(t), what = "field")
  for (s in names(curves)) {
    bad <- which(!is.finite(curves[[s]]), arr.ind = TRUE)
    if (nrow(bad)) {
      reps <- unique(bad[, 1])
      wv_abort(c(
        "Field curves must be complete: site {.val {s}} has {nrow(bad)} missing or non-finite value{?s}.",
        "x" = "{cli::qty(length(reps))}Replicate{?s} {reps}; the first gap is at t = {signif(t[bad[1, 2]], 5)}.",
        "i" = "Fill the gap (e.g. by interpolation) or remove the replicate."
      ), class = "input")
    }
  }
  if (!is.null(x_nom)) {
    if (!is.numeric(x_nom) || is.null(names(x_nom)) || any(!is.finite(x_nom))) {
      wv_abort("{.arg x_nom} must be a named numeric vector of finite nominal input values.")
    }
  }
  stamps <- unique(t)
  if (length(stamps) < 8L) {
    wv_abort("{.arg t} must have at least 8 distinct time points; it has {length(stamps)}.", class = "input")
  }
  repeats <- length(stamps) < length(t)
  if (!is.null(grid)) grid <- check_field_grid(grid, stamps)
  if (!repeats && is.null(grid)) {
    regridded <- to_dyadic(t, curves)
    noise <- if (identical(regridded$t, t)) NULL else
      lapply(curves, function(m) measurement_noise(m, t, stamps, regridded$t))
    return(validate_wv_field(new_wv_field(regridded$t, regridded$curves, x_nom, noise = noise)))
  }
  noise <- lapply(curves, function(m) measurement_noise(m, t, stamps, grid %||% dyadic_grid(stamps)))
  averaged <- lapply(noise, function(nz) nz$averaged)
  if (is.null(grid)) {
    regridded <- to_dyadic(stamps, averaged)
  } else {
    wv_inform(c("i" = "The curves were linearly interpolated from {length(stamps)} distinct time stamp{?s} to the {length(grid)} points of {.arg grid}."))
    regridded <- list(t = grid, curves = interpolate_curves(stamps, averaged, grid, rule = 2))
  }
  noise <- lapply(noise, function(nz) {
    nz$averaged <- NULL
    nz
  })
  validate_wv_field(new_wv_field(regridded$t, regridded$curves, x_nom, noise = noise))
}

# The time stamps of field data: finite, non-decreasing (a stamp may repeat).
check_stamps <- function(t, call = rlang::caller_env()) {
  if (!is.numeric(t) || !is.null(dim(t))) {
    wv_abort("{.arg t} must be a numeric vector of time points, not {.obj_type_friendly {t}}.", call = call)
  }
  if (length(t) < 8L) wv_abort("{.arg t} must have at least 8 time points; it has {length(t)}.", call = call)
  if (any(!is.finite(t))) wv_abort("{.arg t} must not contain NA or infinite values.", call = call)
  if (any(diff(t) < 0)) {
    i <- which(diff(t) < 0)[1]
    wv_abort(c(
      "{.arg t} must be non-decreasing (a time stamp may repeat).",
      "x" = "t[{i + 1}] = {t[i + 1]} is below t[{i}] = {t[i]}.",
      "i" = "Sort the columns of {.arg curves} by time."
    ), call = call)
  }
  as.numeric(t)
}

# `grid` for field_runs(): dyadic, within the stamps' range up to one step at
# either end.
check_field_grid <- function(grid, stamps, call = rlang::caller_env()) {
  grid <- check_grid(grid, call = call)
  if (!is_dyadic_grid(grid)) {
    wv_abort(c("{.arg grid} must be dyadic: 2^k equally spaced points.",
               "x" = "It has {length(grid)} points{if (bitwAnd(length(grid), length(grid) - 1L) == 0L) ', unequally spaced' else ''}.",
               "i" = "Give the model runs' grid ({.code runs$t}), which {.fn model_runs} makes dyadic."),
             class = "grid", call = call)
  }
  h <- max(diff(stamps))
  if (grid[1] < stamps[1] - h || grid[length(grid)] > stamps[length(stamps)] + h) {
    wv_abort(c("{.arg grid} reaches beyond the measured times by more than one step.",
               "x" = "{.arg grid} spans [{signif(grid[1], 5)}, {signif(grid[length(grid)], 5)}]; the measurements [{signif(stamps[1], 5)}, {signif(stamps[length(stamps)], 5)}].",
               "i" = "Give a grid inside the measured times (cut the model runs to them)."),
             class = "grid", call = call)
  }
  grid
}

# The noise evidence of one site's curves (rows) measured at `t` (stamps may
# repeat) and put on `grid`: the values averaged by stamp, their scatter (ss,
# df), the difference-based noise sd of the averaged curves on the stamps, and
# the linear map from the stamps to `grid` (interpolation, held at the ends) with
# the variance factor 1 / (number of values) of each stamp.
measurement_noise <- function(m, t, stamps, grid) {
  k <- match(t, stamps)
  n_at <- tabulate(k, length(stamps))
  averaged <- t(apply(m, 1L, function(y) as.vector(rowsum(y, k, reorder = TRUE)) / n_at))
  if (nrow(m) == 1L) averaged <- matrix(averaged, nrow = 1L)
  ss <- sum((m - averaged[, k, drop = FALSE])^2)
  df <- as.numeric(nrow(m) * (length(t) - length(stamps)))
  lo <- findInterval(grid, stamps, all.inside = TRUE)
  w <- (grid - stamps[lo]) / (stamps[lo + 1L] - stamps[lo])
  w <- pmin(pmax(w, 0), 1)
  list(averaged = averaged, ss = ss, df = df, n_stamps = length(stamps), n_repeated = sum(n_at > 1L),
       detail_sd = detail_noise_sd(averaged, stamps, 1 / n_at),
       map = list(lo = lo, w = w, var = 1 / n_at))
}

# The noise sd of curves (rows) at unequally spaced times, from each inner
# point's deviation from the line through its neighbours, scaled by its
# variance under white noise (`var`: each point's variance in units of
# sigma2), robustly: MAD / 0.6745, the mean over rows.
detail_noise_sd <- function(Y, t, var) {
  n <- length(t)
  i <- seq(2L, n - 1L)
  a <- (t[i + 1L] - t[i]) / (t[i + 1L] - t[i - 1L])
  b <- 1 - a
  f <- var[i] + a^2 * var[i - 1L] + b^2 * var[i + 1L]
  mean(apply(Y, 1L, function(y) {
    e <- (y[i] - a * y[i - 1L] - b * y[i + 1L]) / sqrt(f)
    stats::mad(e, center = 0)
  }))
}

# The noise variance of each retained coefficient of a curve resampled by
# `map` (measurement_noise()), in units of the variance of one measurement:
# diag(Psi' A D A' Psi), A the interpolation, D the stamps' variance factors.
resampled_noise_multipliers <- function(map, Psi) {
  n_s <- length(map$var)
  B <- rowsum(Psi * (1 - map$w), map$lo, reorder = TRUE)
  hi <- rowsum(Psi * map$w, map$lo + 1L, reorder = TRUE)
  A_t_Psi <- matrix(0, n_s, ncol(Psi))
  A_t_Psi[as.integer(rownames(B)), ] <- B
  A_t_Psi[as.integer(rownames(hi)), ] <- A_t_Psi[as.integer(rownames(hi)), ] + hi
  colSums(A_t_Psi^2 * map$var)
}

new_wv_field <- function(t, curves, x_nom = NULL, warps = NULL, noise = NULL) {
  structure(list(t = t, curves = curves, x_nom = x_nom, warps = warps, noise = noise), class = "wv_field")
}

validate_wv_field <- function(x, call = rlang::caller_env()) {
  n <- vapply(x$curves, nrow, integer(1))
  for (s in names(x$curves)) {
    if (ncol(x$curves[[s]]) != length(x$t)) {
      wv_abort("Site {.val {s}}: {ncol(x$curves[[s]])} columns but {length(x$t)} time points.", call = call)
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
  if (length(dup)) wv_abort("Column names of {.arg {arg}} must be unique; {.val {dup}} repeat{?s/}.", call = call)
  invisible(nm)
}

check_grid <- function(t, call = rlang::caller_env()) {
  if (!is.numeric(t) || !is.null(dim(t))) {
    wv_abort("{.arg t} must be a numeric vector of time points, not {.obj_type_friendly {t}}.", call = call)
  }
  if (length(t) < 8L) {
    wv_abort("{.arg t} must have at least 8 time points; it has {length(t)}.", call = call)
  }
  if (any(!is.finite(t))) {
    wv_abort("{.arg t} must not contain NA or infinite values.", call = call)
  }
  if (any(diff(t) <= 0)) {
    i <- which(diff(t) <= 0)[1]
    wv_abort(c(
      "{.arg t} must be strictly increasing.",
      "x" = "t[{i + 1}] = {t[i + 1]} does not exceed t[{i}] = {t[i]}."
    ), call = call)
  }
  as.numeric(t)
}

# Turns a matrix or list of matrices into a named list of numeric matrices,
# checking dimensions.
as_site_list <- function(curves, site, n_rows, n_t, what, call = rlang::caller_env()) {
  if (is.data.frame(curves)) curves <- as.matrix(curves)
  if (is.matrix(curves)) curves <- list(curves)
  if (!is.list(curves) || length(curves) == 0L) {
    wv_abort("{.arg curves} must be a matrix (one site) or a list of matrices (one per site).", call = call)
  }
  nm <- names(curves)
  if (!is.null(site)) {
    if (!is.character(site) || length(site) != length(curves)) {
      wv_abort("{.arg site} must give one name per site ({length(curves)}).", call = call)
    }
    nm <- site
  }
  if (is.null(nm)) nm <- if (length(curves) == 1L) "site1" else paste0("site", seq_along(curves))
  if (anyNA(nm) || any(!nzchar(nm)) || anyDuplicated(nm)) {
    wv_abort("Site names must be unique and non-empty.", call = call)
  }
  names(curves) <- nm
  for (s in nm) {
    m <- curves[[s]]
    if (is.data.frame(m)) m <- as.matrix(m)
    if (is.numeric(m) && is.null(dim(m))) m <- matrix(m, nrow = 1L)
    if (!is.matrix(m) || !is.numeric(m)) {
      wv_abort("Curves of site {.val {s}} must be a numeric matrix, one row per {if (what == 'runs') 'run' else 'replicate'}.",
               call = call)
    }
    if (ncol(m) != n_t) {
      wv_abort(c(
        "{.arg curves} must have one column per time point.",
        "x" = "Site {.val {s}} has {ncol(m)} column{?s} and {.arg t} has {n_t} value{?s}."
      ), call = call)
    }
    if (!is.null(n_rows) && nrow(m) != n_rows) {
      wv_abort(c(
        "{.arg curves} must have one row per run of {.arg design}.",
        "x" = "Site {.val {s}} has {nrow(m)} row{?s} and {.arg design} has {n_rows}."
      ), call = call)
    }
    if (nrow(m) == 0L) wv_abort("Site {.val {s}} has no curves.", call = call)
    storage.mode(m) <- "double"
    dimnames(m) <- NULL
    curves[[s]] <- m
  }
  curves
}

is_dyadic_grid <- function(t) {
  n <- length(t)
  h <- diff(t)
  bitwAnd(n, n - 1L) == 0L && max(abs(h - mean(h))) <= 1e-8 * max(1, abs(mean(h)))
}

# Linear interpolation of every curve to 2^ceiling(log2(T)) equally spaced
# points on [min(t), max(t)], unless the grid is dyadic already.
to_dyadic <- function(t, curves) {
  if (is_dyadic_grid(t)) return(list(t = t, curves = curves))
  t_new <- dyadic_grid(t)
  wv_inform(c(
    "i" = "The grid of {length(t)} point{?s} is not dyadic; curves were linearly interpolated to {length(t_new)} equally spaced points on [{signif(t[1], 4)}, {signif(t[length(t)], 4)}]."
  ))
  list(t = t_new, curves = interpolate_curves(t, curves, t_new))
}

# 2^ceiling(log2(T)) equally spaced points on [min(t), max(t)].
dyadic_grid <- function(t) seq(t[1], t[length(t)], length.out = 2L^ceiling(log2(length(t))))

# Every curve (rows of each matrix of the list `curves`, at times `t`)
# linearly interpolated to `t_new`; `rule` as in stats::approx() (2: held at
# the end values beyond `t`).
interpolate_curves <- function(t, curves, t_new, rule = 1) {
  lapply(curves, function(m) {
    out <- t(apply(m, 1L, function(y) stats::approx(t, y, xout = t_new, rule = rule)$y))
    if (nrow(m) == 1L) out <- matrix(out, nrow = 1L)
    out
  })
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
#' first <- model_runs(data.frame(a = c(0.1, 0.5, 0.9)), t(sapply(c(0.1, 0.5, 0.9), function(a) sin(a * t))), t)
#' more <- model_runs(data.frame(a = c(0.3, 0.7)), t(sapply(c(0.3, 0.7), function(a) sin(a * t))), t)
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
  curves <- stats::setNames(lapply(sites, function(s) do.call(rbind, lapply(runs, function(r) r$curves[[s]]))), sites)
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
                        k, if (k == 1) "" else "s", ncol(x$design), if (ncol(x$design) == 1) "" else "s",
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
    output = vapply(object$curves, function(m) c(min = min(m), max = max(m), sd_between = mean(apply(m, 2, stats::sd))), numeric(3))
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

#' @export
print.wv_field <- function(x, ...) {
  n <- vapply(x$curves, nrow, integer(1))
  cli::cat_line(sprintf("<wv_field> field data on %d time points in [%s, %s]%s", length(x$t),
                        format(signif(min(x$t), 4)), format(signif(max(x$t), 4)),
                        if (!is.null(x$warps)) ", registered" else ""))
  for (s in names(n)) cli::cat_line(sprintf("  %s: %d replicate%s", s, n[[s]], if (n[[s]] == 1) "" else "s"))
  if (!is.null(x$x_nom)) {
    cli::cat_line("  nominal inputs: ", paste(sprintf("%s = %s", names(x$x_nom), format(signif(x$x_nom, 4))),
                                                collapse = ", "))
  }
  invisible(x)
}

#' @export
summary.wv_field <- function(object, ...) {
  structure(list(
    n_t = length(object$t),
    range_t = range(object$t),
    replicates = vapply(object$curves, nrow, integer(1)),
    spread = vapply(object$curves, function(m) if (nrow(m) > 1) mean(apply(m, 2, stats::sd)) else NA_real_, numeric(1)),
    registered = !is.null(object$warps),
    x_nom = object$x_nom
  ), class = "summary_wv_field")
}

#' @export
print.summary_wv_field <- function(x, ...) {
  cli::cat_line(sprintf("Field data on %d time points in [%s, %s]%s", x$n_t, format(signif(x$range_t[1], 4)),
                        format(signif(x$range_t[2], 4)), if (x$registered) " (registered)" else ""))
  print(data.frame(site = names(x$replicates), replicates = x$replicates,
                   mean_pointwise_sd = signif(x$spread, 4), row.names = NULL), row.names = FALSE)
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
#' runs <- model_runs(data.frame(a = 1:4 / 5), t(sapply(1:4, function(k) sin(2 * pi * t * k / 4))), t)
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
    d <- do.call(rbind, lapply(names(runs$curves), function(s) curves_long(runs$curves[[s]], runs$t, s, "run")))
    d <- add_window(d)
    p <- p + ggplot2::geom_line(data = d, ggplot2::aes(.data$t, .data$y, group = .data$run),
                                colour = "grey60", linewidth = 0.25, alpha = 0.6)
  }
  if (!is.null(field)) {
    d <- do.call(rbind, lapply(names(field$curves), function(s) curves_long(field$curves[[s]], field$t, s, "replicate")))
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
