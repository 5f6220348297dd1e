#' Check a validation problem before fitting anything
#'
#' Runs, in a second or two, the checks whose failure would otherwise show
#' only after every emulator is fitted: the time grid, how well the wavelet
#' basis reconstructs the curves, how the field noise will be set, and the
#' inputs of the design against the I/U map. [validate()] runs it first and
#' stops at its first error (or warns) before registering or fitting
#' anything; run it alone to see every check at once.
#'
#' The checks, each with its figure:
#' * **grid**: the runs and the field share one grid of a power of two of
#'   equally spaced, increasing, finite times, and the curves are complete.
#'   [model_runs()] and [field_runs()] interpolate other grids to a dyadic
#'   one; objects built otherwise are refused (class
#'   `wavevalid_error_grid`).
#' * **basis**: the basis of [wavelet_basis()] with `basis_args` (the field
#'   as given, before any registration) and the relative L2 reconstruction
#'   error of the runs and of the field against `tolerance`. An error (class
#'   `wavevalid_error_basis`) when the median run misses its tolerance more
#'   than five times over, since the emulators would then model other curves
#'   than the runs; a warning (class `wavevalid_warning_basis`) when the
#'   median run, or a field curve beyond its noise level, misses its
#'   tolerance.
#' * **noise**: the field replicates by site and how the field variances will
#'   be set: from the replicates (two or more, the method's estimate), from
#'   `sigma2` as given, from the finest wavelet level (`sigma2 =
#'   "finest"`), or learned in the posterior ([noise_prior()], the default
#'   with one replicate). One replicate with the noise learned is a warning
#'   (class `wavevalid_warning_noise`): one curve tells noise from bias only
#'   weakly. When the replicates' spread changes more than tenfold along the
#'   record (the root mean square of their pointwise sd over blocks of a
#'   32nd of it), the figure says where: replicates that are different units
#'   rather than repeats do this, and so does timing jitter at sharp events
#'   before registration. One variance per wavelet coefficient mixes such a
#'   spread along the record; [misfit_check()] reads each point with its
#'   own.
#' * **inputs**: the design of the runs and the I/U map have the same inputs
#'   (else an error of class `wavevalid_error_inputs`, before any emulator is
#'   fitted): an input of the map that the runs do not vary could only follow
#'   its prior, and an input of the runs without a range has no prior. Add
#'   the input to the runs or to the map ([iu_add()]), or drop it from the
#'   map (`iu[iu$name != "u2", ]`). Each I/U range lies within the design's
#'   range (else a warning of class `wavevalid_warning_inputs`: the emulators
#'   would extrapolate; a range counts when it reaches beyond the design by
#'   more than 5% of its width or 1.5 / K of it, K runs, about one and a half
#'   spacings of a space-filling design).
#' * **windows** (when given): the event windows of the registration.
#'
#' @inheritParams validate
#' @inheritParams registration_control
#' @inheritParams emulation_control
#' @inheritParams bias_control
#' @param tolerance The relative L2 reconstruction errors checked, as in
#'   [wavelet_basis()]: `c(runs = 0.01, field = 0.02)` unless `basis_args`
#'   sets one.
#' @return A `wv_preflight` object: a data frame with one row per check and
#'   columns `check`, `status` (`"ok"`, `"warning"`, `"error"` or
#'   `"skipped"`), `figure` (what was measured) and `fix` (what to do when it
#'   is not ok); attributes `basis` (the basis built, or `NULL`) and
#'   `seconds` (the time taken).
#' @export
#' @examples
#' fl <- load_flyer()
#' preflight(fl$runs, fl$field, fl$iu)
#' # the report's basis rule alone, and no field variances for one curve
#' preflight(fl$runs, fl$field, fl$iu, basis_args = list(retain = "report"))
preflight <- function(runs, field, iu, sigma2 = NULL, windows = NULL, basis_args = list(),
                      tolerance = NULL) {
  check_class(runs, "wv_runs")
  check_class(field, "wv_field")
  check_class(iu, "wv_iu")
  if (!is.list(basis_args))
    wv_abort("{.arg basis_args} must be a list of arguments to {.fn wavelet_basis}.")
  start <- proc.time()[["elapsed"]]
  tolerance <- check_tolerance(tolerance %||% basis_args$tolerance %||%
                               c(runs = 0.01, field = 0.02))
  rows <- list(grid = preflight_grid(runs, field))
  basis <- NULL
  if (rows$grid$status == "error") {
    rows$basis <- preflight_row("skipped", "not built: the grid must be fixed first", "")
  } else {
    args <- utils::modifyList(basis_args, list(tolerance = tolerance))
    basis <- do.call(wavelet_basis, c(list(runs, field), args))
    rows$basis <- preflight_basis(basis, field, tolerance)
  }
  rows$noise <- preflight_noise(field, sigma2)
  sp <- spread_text(spread_along_record(field))
  if (!is.null(sp) && rows$noise$status == "ok") {
    rows$noise$figure <- paste0(rows$noise$figure, "; ", sp,
                                " (replicates that are different units, or timing jitter at the events before",
                                " registration): one variance per wavelet coefficient mixes it, misfit_check()",
                                " reads each point with its own")
  }
  rows$inputs <- preflight_inputs(runs, iu)
  if (!is.null(windows)) {
    rows$windows <- tryCatch({
      w <- check_windows(windows, field$t)
      preflight_row("ok", sprintf("%d window%s: %s", length(w), if (length(w) == 1L) "" else "s",
                                  paste(vapply(w, function(x) sprintf("[%s, %s]",
                                                                      format(signif(x[1], 4)),
                                                                      format(signif(x[2], 4))), ""),
                                        collapse = ", ")), "")
    }, wavevalid_error = function(e) preflight_row("error", cli::ansi_strip(conditionMessage(e)),
                                                    "Give windows inside the grid, increasing and not overlapping.",
                                                    class = "windows"))
  }
  out <- data.frame(check = names(rows), status = vapply(rows, `[[`, "", "status"),
                    figure = vapply(rows, `[[`, "", "figure"), fix = vapply(rows, `[[`, "", "fix"),
                    stringsAsFactors = FALSE, row.names = NULL)
  structure(out, condition = lapply(rows, `[[`, "class"), basis = basis,
            seconds = proc.time()[["elapsed"]] - start, class = c("wv_preflight", "data.frame"))
}

preflight_row <- function(status, figure, fix, class = NULL) {
  list(status = status, figure = figure, fix = fix, class = class)
}

preflight_grid <- function(runs, field) {
  t <- runs$t
  n <- length(t)
  bad <- function(figure, fix) preflight_row("error", figure, fix, class = "grid")
  rebuild <- "Build the runs with model_runs() and the field with field_runs(), which put the curves on a dyadic grid."
  if (!is.numeric(t) || any(!is.finite(t))) return(bad("the grid holds missing or infinite times",
                                                       rebuild))
  if (n < 8L || any(diff(t) <= 0)) {
    return(bad(sprintf("the grid of %d points is not strictly increasing or has fewer than 8 points", n), rebuild))
  }
  if (!is_dyadic_grid(t)) {
    h <- diff(t)
    return(bad(sprintf("%d points%s, steps from %s to %s: not a power of two of equally spaced points", n,
                       if (bitwAnd(n, n - 1L) == 0L) "" else " (not a power of two)",
                       format(signif(min(h), 3)), format(signif(max(h), 3))),
               paste(rebuild, "Interpolation to", 2L^ceiling(log2(n)),
                     "equally spaced points is done there.")))
  }
  if (length(field$t) != n || max(abs(field$t - t)) > 1e-8 * max(1, abs(t))) {
    return(bad(sprintf("the field has %d points on [%s, %s], the runs %d on [%s, %s]",
                       length(field$t),
                       format(signif(min(field$t), 4)), format(signif(max(field$t), 4)), n,
                       format(signif(t[1], 4)), format(signif(t[n], 4))),
               "Interpolate the field to the runs' grid (stats::approx onto runs$t) and build it with field_runs()."))
  }
  holes <- c(vapply(runs$curves, function(m) sum(!is.finite(m)), numeric(1)),
             vapply(field$curves, function(m) sum(!is.finite(m)), numeric(1)))
  if (any(holes > 0)) {
    return(bad(sprintf("%d missing or non-finite curve values", sum(holes)),
               "Drop failed runs with model_runs() and fill or drop incomplete field replicates."))
  }
  preflight_row("ok", sprintf("%d equally spaced points on [%s, %s], runs and field alike", n,
                              format(signif(t[1], 4)), format(signif(t[n], 4))), "")
}

preflight_basis <- function(basis, field, tolerance) {
  e <- basis$error
  run <- e$rel_l2[e$source == "run"]
  fig <- sprintf("%d of %d coefficients (%s, %s); relative L2 error %s", length(basis$index),
                 basis$settings$n_t,
                 basis$settings$retain, basis$settings$boundary, basis_error_text(e))
  fld <- e[e$source == "field", , drop = FALSE]
  # a field curve meets its tolerance within its noise level too
  field_miss <- vapply(seq_len(nrow(fld)), function(i) {
    y <- field$curves[[fld$site[i]]][fld$id[i], ]
    lost <- sqrt(mean(basis_remainder(basis, y)^2))
    fld$rel_l2[i] > tolerance[["field"]] && lost > finest_level_sd(y, basis$settings)
  }, logical(1))
  fix <- sprintf("Use wavelet_basis(retain = \"error\") (the default), which meets the tolerance (runs %s, field %s), or keep more coefficients (a larger fraction).",
                 percent_text(tolerance[["runs"]]), percent_text(tolerance[["field"]]))
  if (stats::median(run) > 5 * tolerance[["runs"]]) {
    return(preflight_row("error", paste0(fig, sprintf("; the median run misses its tolerance of %s more than five times over",
                                                      percent_text(tolerance[["runs"]]))), fix,
                         class = "basis"))
  }
  if (stats::median(run) > tolerance[["runs"]] || any(field_miss)) {
    what <- c(if (stats::median(run) > tolerance[["runs"]])
                sprintf("the median run misses %s", percent_text(tolerance[["runs"]])),
              if (any(field_miss)) sprintf("%d field curve%s miss%s %s beyond its noise level",
                                           sum(field_miss),
                                           if (sum(field_miss) == 1L) "" else "s",
                                           if (sum(field_miss) == 1L) "es" else "",
                                           percent_text(tolerance[["field"]])))
    return(preflight_row("warning", paste0(fig, "; ", paste(what, collapse = ", ")), fix,
                         class = "basis"))
  }
  preflight_row("ok", fig, "")
}

preflight_noise <- function(field, sigma2) {
  reps <- vapply(field$curves, nrow, integer(1))
  setting <- describe_noise(sigma2, reps, field$noise)
  fig <- paste(sprintf("%s: %d replicate%s, %s", names(reps), reps, ifelse(reps == 1L, "", "s"),
                       setting$how),
               collapse = "; ")
  if (any(!setting$ok)) {
    return(preflight_row("error", fig, setting$fix, class = c("noise", "input")))
  }
  if (any(setting$weak)) return(preflight_row("warning", fig, setting$fix, class = "noise"))
  preflight_row("ok", fig, "")
}

# How the field variances of each site will be set, from the `sigma2`
# argument of calibrate() and the number of replicates by site: `how` (text
# by site), `ok` (by site: can they be set?) and `fix`. Every way of setting
# the noise is described here, so a new one needs only a branch here.
describe_noise <- function(sigma2, reps, evidence = NULL) {
  sites <- names(reps)
  kept <- vapply(sites, function(s) !is.null(evidence[[s]]), logical(1))
  repeated <- vapply(sites, function(s) as.numeric(evidence[[s]]$df %||% 0), numeric(1))
  prior <- if (inherits(sigma2, "wv_noise_prior")) sigma2
  if (!is.null(prior)) sigma2 <- NULL
  given <- if (is.list(sigma2)) sites %in% names(sigma2) else rep(!is.null(sigma2), length(sites))
  prior_text <- function(p) {
    sc <- if (is.null(p$scale)) "scale the finest-level estimate" else
      paste("scale", paste(signif(p$scale, 3), collapse = ", "))
    sprintf("one noise variance learned in the posterior (%s prior on its sd, %s)", p$family, sc)
  }
  learn <- !given & (reps < 2L | !is.null(prior))
  how <- ifelse(reps >= 2L,
                sprintf("variances estimated from the %d replicates (the method's estimate)", reps),
                "")
  how[learn] <- prior_text(prior %||% noise_prior())
  from_curve <- learn & kept & is.null((prior %||% noise_prior())$scale)
  how[from_curve] <- sub("scale the finest-level estimate",
                         "scale from the measured curve on its own time stamps",
                         how[from_curve], fixed = TRUE)
  how[learn & repeated > 0] <- paste0(how[learn & repeated > 0],
                                      sprintf(", with the scatter of repeated measurements at one time stamp (%g df)",
                                              repeated[learn & repeated > 0]))
  if (identical(sigma2, "finest")) {
    how <- rep("variances from the finest wavelet level of the field curves (sigma2 = \"finest\", assumes near-white noise; on a smoothed or interpolated curve it is too small)",
               length(sites))
  } else if (is.numeric(sigma2) || is.list(sigma2)) {
    vals <- if (is.list(sigma2)) sigma2[sites] else rep(list(sigma2), length(sites))
    how[given] <- vapply(vals[given], function(v) {
      v <- as.numeric(v)
      if (length(v) == 1L || length(unique(v)) == 1L) sprintf("variances fixed by sigma2 = %s",
                                                              format(signif(v[1], 3)))
      else sprintf("variances fixed by sigma2 (%s to %s)", format(signif(min(v), 3)),
                   format(signif(max(v), 3)))
    }, "")
  }
  # a curve read as interpolated whose measured points cannot tell its noise,
  # learned with the default scale: calibrate() refuses it
  blind <- learn & kept & is.null((prior %||% noise_prior())$scale) &
    vapply(sites, function(s) identical(evidence[[s]]$detail_sd, 0), logical(1))
  if (any(blind)) {
    how[blind] <-
      "read as interpolated before it came in, too few measured points to tell its noise"
    return(list(how = stats::setNames(how, sites), ok = stats::setNames(!blind, sites),
                weak = stats::setNames(rep(FALSE, length(sites)), sites),
                fix = sprintf("Give the noise of site%s %s: noise_prior(scale = ) with the instrument's noise sd, or sigma2; or the measured points themselves (field_runs() with the curves on their own times).",
                              if (sum(blind) == 1L) "" else "s",
                              paste(sites[blind], collapse = ", "))))
  }
  # one replicate and the noise learned: weakly identified against the bias
  weak <- reps < 2L & learn & repeated == 0
  list(how = stats::setNames(how, sites), ok = stats::setNames(rep(TRUE, length(sites)), sites),
       weak = stats::setNames(weak, sites),
       fix = sprintf("Site%s %s ha%s one field replicate: its noise is learned with the bias and is weakly identified. Give sigma2 (one value or one per coefficient) if the measurement noise is known, or noise_prior(scale = ) with a scale you can defend.",
                     if (sum(weak) == 1L) "" else "s", paste(sites[weak], collapse = ", "),
                     if (sum(weak) == 1L) "s" else "ve"))
}

preflight_inputs <- function(runs, iu) {
  inputs <- names(runs$design)
  mismatch <- iu_inputs_mismatch(inputs, iu, "runs")
  if (!is.null(mismatch)) {
    return(preflight_row("error", mismatch$figure, mismatch$fix, class = c("inputs", "input")))
  }
  k <- match(inputs, iu$name)
  lo <- vapply(runs$design, min, numeric(1))
  hi <- vapply(runs$design, max, numeric(1))
  width <- pmax(iu$upper[k] - iu$lower[k], .Machine$double.eps)
  out_lo <- (lo - iu$lower[k]) / width
  out_hi <- (iu$upper[k] - hi) / width
  slack <- max(0.05, 1.5 / nrow(runs$design))
  beyond <- pmax(out_lo, out_hi) > slack
  fig <- sprintf("%d inputs (%d calibration, %d variation) in the I/U map", length(inputs),
                 sum(iu$type[k] == "calibration"), sum(iu$type[k] == "variation"))
  if (any(beyond)) {
    detail <- sprintf("%s: I/U [%s, %s], design [%s, %s]", inputs[beyond],
                      format_range(iu$lower[k][beyond]),
                      format_range(iu$upper[k][beyond]), format_range(lo[beyond]),
                      format_range(hi[beyond]))
    return(preflight_row("warning", paste0(fig, "; the I/U range reaches beyond the design for ",
                                           paste(detail, collapse = "; ")),
                         "Narrow the I/U ranges to the design's, or add runs that cover them (the emulators would extrapolate).",
                         class = "inputs"))
  }
  preflight_row("ok", paste0(fig, "; every I/U range lies within the design's"), "")
}

format_range <- function(x) trimws(formatC(x, digits = 3, format = "g"))

#' @export
print.wv_preflight <- function(x, ...) {
  cli::cat_line(sprintf("<wv_preflight> %d checks in %.1f s: %s", nrow(x), attr(x, "seconds"),
                        paste(sprintf("%d %s",
                                      as.integer(table(factor(x$status,
                                                              c("ok", "warning", "error",
                                                                "skipped")))),
                                      c("ok", "warning", "error", "skipped")), collapse = ", ")))
  mark <- c(ok = "v", warning = "!", error = "x", skipped = "-")
  for (i in seq_len(nrow(x))) {
    cli::cat_line(sprintf("%s %-7s %s", mark[[x$status[i]]], x$check[i], x$figure[i]))
    if (nzchar(x$fix[i]) && x$status[i] %in% c("warning", "error"))
      cli::cat_line("          fix: ", x$fix[i])
  }
  invisible(x)
}

# validate(): stop at the first error of a preflight, warn for its warnings.
enforce_preflight <- function(pf, call = rlang::caller_env()) {
  cond <- attr(pf, "condition")
  for (i in which(pf$status == "error")) {
    wv_abort(c("The pre-flight check {.val {pf$check[i]}} failed: {pf$figure[i]}.",
               "i" = "{pf$fix[i]}"),
             class = cond[[i]] %||% "input", call = call)
  }
  for (i in which(pf$status == "warning")) {
    wv_warn(c("Pre-flight check {.val {pf$check[i]}}: {pf$figure[i]}.", "i" = "{pf$fix[i]}"),
            class = cond[[i]] %||% "warning")
  }
  invisible(pf)
}
