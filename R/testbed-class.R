# The wv_testbed class: print, summary and plots shared by the test beds
# (wv_testbed_suspension, wv_testbed_dosing, wv_testbed_units), worded by
# their specifications.

validate_wv_testbed <- function(x, call = rlang::caller_env()) {
  spec <- testbed_spec_of(x)
  conds <- c("A", "B", names(spec$shifted))
  need <- c(list("iu"), lapply(conds, c, "runs"), lapply(conds, c, "field"),
            list(c("truth", "u"), c("truth", "delta"), c("truth", "reality"),
                 c("truth", "reality_B")))
  if (!is.null(spec$units)) {
    need <- c(need, list(c("truth", "units_delta"), c("truth", "reality_units"),
                         c("A", "field", "units"), c("B", "field", "units")))
  }
  for (p in need) {
    if (is.null(x[[p]])) wv_abort("The test bed lacks {.field {paste(p, collapse = '$')}}.",
                                  call = call)
  }
  check_class(x$iu, "wv_iu", "iu", call = call)
  for (cond in conds) {
    check_class(x[[cond]]$runs, "wv_runs", paste0(cond, "$runs"), call = call)
    check_class(x[[cond]]$field, "wv_field", paste0(cond, "$field"), call = call)
  }
  x
}

#' @export
print.wv_testbed <- function(x, ...) {
  spec <- testbed_spec_of(x)
  sites <- names(x$A$runs$curves)
  cli::cat_line(sprintf("%s (seed %s, hidden mechanism: %s)", spec$text$header, x$truth$seed,
                        paste(x$truth$hidden, collapse = ", ")))
  cli::cat_line(sprintf("  %d inputs: %s; %s %s; %d time points in %s", nrow(x$iu),
                        paste(x$iu$name, collapse = ", "),
                        if (length(sites) > 1L) "sites" else "site",
                        paste(sites, collapse = ", "), length(x$A$runs$t), spec$text$span))
  n_field <- function(cd) nrow(x[[cd]]$field$curves[[1]])
  n_runs <- function(cd) nrow(x[[cd]]$runs$design)
  of_units <- function(cd) {
    u <- x[[cd]]$field$units[[1]]
    if (is.null(u)) "" else sprintf(" of %d units", length(unique(u)))
  }
  cli::cat_line(sprintf("  A: %d model runs, %d field replicates%s", n_runs("A"), n_field("A"),
                        of_units("A")))
  cli::cat_line(sprintf("  B: %d model runs, %d held-out field replicates%s (%s)", n_runs("B"),
                        n_field("B"), of_units("B"),
                        spec$text$B))
  for (cd in intersect(names(spec$shifted), names(x))) {
    cli::cat_line(sprintf("  %s: %d model runs, %d field replicate%s", spec$shifted[[cd]]$label,
                          n_runs(cd),
                          n_field(cd), if (n_field(cd) == 1L) "" else "s"))
  }
  if (!is.null(x$doses)) {
    cli::cat_line(sprintf("  doses: %d model runs over the inputs and the dose (%g to %g mg); field replicates at %s mg and A's 400",
                          nrow(x$doses$runs$design), min(x$doses$runs$design$dose),
                          max(x$doses$runs$design$dose),
                          paste(x$doses$amounts, collapse = ", ")))
  }
  if (is.null(x$windows)) {
    cli::cat_line("  no event windows (the field is used unregistered)")
  } else {
    cli::cat_line(sprintf("  %s: ", spec$text$windows),
                  paste(vapply(x$windows, function(w) sprintf("%s < t < %s", w[1], w[2]),
                               character(1)),
                        collapse = ", "))
  }
  invisible(x)
}

#' @export
summary.wv_testbed <- function(object, ...) {
  spec <- testbed_spec_of(object)
  conds <- stats::setNames(nm = testbed_conditions(object))
  structure(list(
    title = spec$text$title,
    range_label = spec$text$range,
    seed = object$truth$seed,
    hidden = object$truth$hidden,
    truth = c(object$truth$u, object$truth$delta),
    delta_B = object$truth$delta_B,
    x_nom_B = object$truth$x_nom_B,
    runs = vapply(conds, function(cd) nrow(object[[cd]]$runs$design), integer(1)),
    replicates = vapply(conds, function(cd) nrow(object[[cd]]$field$curves[[1]]), integer(1)),
    units = if (!is.null(object$A$field$units)) {
      vapply(conds, function(cd) length(unique(object[[cd]]$field$units[[1]])), integer(1))
    },
    range_A = vapply(object$A$runs$curves, function(m) c(min = min(m), max = max(m)), numeric(2))
  ), class = "summary_wv_testbed")
}

#' @export
print.summary_wv_testbed <- function(x, ...) {
  cli::cat_line(sprintf("%s, seed %s, hidden mechanism: %s", x$title, x$seed,
                        paste(x$hidden, collapse = ", ")))
  tab <- data.frame(condition = names(x$runs), model_runs = x$runs,
                    field_replicates = x$replicates, row.names = NULL)
  if (!is.null(x$units)) tab$units <- unname(x$units)
  print(tab, row.names = FALSE)
  cli::cat_line("True u* and delta* (condition A):")
  print(signif(x$truth, 3))
  cli::cat_line("Nominal x and delta* of condition B:")
  print(signif(rbind(x_nom_B = x$x_nom_B, delta_B = x$delta_B), 3))
  cli::cat_line(x$range_label)
  print(signif(x$range_A, 4))
  invisible(x)
}

#' Plot a test bed
#'
#' @param object A `wv_testbed` ([testbed_suspension()], [testbed_dosing()],
#'   [testbed_units()], [load_testbed()]).
#' @param condition `"A"`, `"B"` or, for the suspension test bed,
#'   `"added_mass"`.
#' @param windows Time windows to zoom into (default the test bed's event
#'   windows, `NULL` for the cooling bed of [testbed_units()]; `NULL` for
#'   the whole record).
#' @param ... Unused.
#' @return A ggplot of the model runs (grey) and field replicates of that
#'   condition.
#' @export
#' @examples
#' tb <- testbed_suspension(seed = 2, hidden = "digressive_damper")
#' autoplot(tb, "B")
#' tb <- testbed_dosing(seed = 2, hidden = "absorption_lag")
#' autoplot(tb, "B")
autoplot.wv_testbed <- function(object, condition = testbed_conditions(object),
                                windows = object$windows, ...) {
  condition <- check_choice(condition)
  autoplot(object[[condition]]$runs, field = object[[condition]]$field, windows = windows)
}

#' @export
plot.wv_testbed <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}
