#' Rescale the emulators' predictive variances from held-out runs
#'
#' The plug-in GASP predictive variance (report eq. 11) takes the fitted
#' correlation parameters as known. Away from the design points its errors can
#' be larger than it says, most at the fine wavelet levels, whose coefficients
#' follow the timing of sharp events and are rough functions of the inputs.
#' Leave-one-out residuals at the design points do not show it (see
#' [summary.wv_emulators()]); runs the emulators were not fitted to do.
#' Overconfident emulators make the posterior of the inputs too narrow and
#' the coefficients' misfit look like bias.
#'
#' For each site and resolution level, the mean square of the studentised
#' errors `(w - m(z)) / sqrt(V(z))` of the emulators at the held-out runs is
#' an estimate of the factor by which the predictive variances are too small.
#' The variance `1 / lambda` of every emulator of that level is multiplied by
#' it, where it exceeds 1; variances are never narrowed. Predictive means and
#' correlation parameters are unchanged; every later use of the emulators
#' (calibration, bands, new vehicles) sees the wider variances. This goes
#' beyond the method's report.
#'
#' Use runs spread over the region where the posterior of the inputs may lie:
#' a [design_maximin()] on the I/U ranges, or draws from a first posterior.
#' The studentised errors of a level are pooled over its coefficients and the
#' runs; a level needs `min_errors` of them (otherwise its variances are left
#' as they are, with a warning).
#'
#' @inheritParams calibrate
#' @param new_runs Held-out model runs (`wv_runs`) on the basis grid, with
#'   every input of the emulators and every emulated site, not among the runs
#'   the emulators were fitted to.
#' @param min_errors Smallest number of studentised errors a level needs for
#'   its factor to be estimated.
#' @return The `wv_emulators` object with the variances rescaled: the bank's
#'   and `params`' `lambda` divided by the factor, a column `variance_scale`
#'   in `params` (1 where unchanged), and `variance_check`, a data frame by
#'   site and level with `n_errors`, `rms_before` (root mean square of the
#'   studentised errors at `new_runs`) and `scale`.
#' @seealso [summary.wv_emulators()] for the studentised errors by level.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' f <- function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t
#' design <- data.frame(a = seq(0, 1, length.out = 8), b = c(3, 7, 1, 5, 8, 2, 6, 4) / 8)
#' runs <- model_runs(design, t(apply(design, 1, f)), t)
#' em <- fit_emulators(runs, wavelet_basis(runs))
#' check_design <- data.frame(a = c(0.1, 0.35, 0.6, 0.85, 0.2, 0.7),
#'                            b = c(0.5, 0.9, 0.2, 0.6, 0.1, 0.4))
#' check <- model_runs(check_design, t(apply(check_design, 1, f)), t)
#' em2 <- rescale_emulators(em, check)
#' em2$variance_check
#' em2
rescale_emulators <- function(emulators, new_runs, min_errors = 10L) {
  check_class(emulators, "wv_emulators")
  check_number(min_errors, min = 1, integer = TRUE)
  if (!is.null(emulators$variance_check)) {
    wv_abort(c(
      "{.arg emulators} have been rescaled already.",
      "i" = "Rescale the emulators returned by {.fn fit_emulators}, with all the held-out runs at once."
    ))
  }
  held <- heldout_residuals(emulators, new_runs)
  seen <- heldout_at_design(emulators, new_runs$design)
  if (any(seen)) {
    wv_abort(c(
      "{.arg new_runs} must be runs the emulators were not fitted to.",
      "x" = "{sum(seen)} of its {length(seen)} run{?s} {?is/are} at design points of the emulators.",
      "i" = "At a design point the emulator interpolates and its error is zero; drop those runs."
    ))
  }
  p <- emulators$params
  hs <- residual_stats_by_level(p, held)
  ms <- hs$mean_square
  check <- data.frame(site = hs$site, level = hs$level, n_errors = hs$n,
                      rms_before = sqrt(ms), scale = ifelse(hs$n >= min_errors, pmax(1, ms), 1),
                      stringsAsFactors = FALSE)
  short <- check$n_errors < min_errors & check$n_errors > 0
  if (any(short)) {
    wv_warn(c(
      "Too few held-out errors to rescale {sum(short)} site and level group{?s}; {?its/their} variances are unchanged.",
      "i" = "Each needs {min_errors}; add held-out runs or lower {.arg min_errors}."
    ), class = "rescale")
  }
  # the groups come in the order of their first appearance in params
  key <- paste(p$site, p$level, sep = "\r")
  scale <- check$scale[match(key, unique(key))]
  emulators$params$lambda <- p$lambda / scale
  emulators$params$variance_scale <- scale
  for (s in names(emulators$banks)) {
    emulators$banks[[s]]$lambda <- emulators$banks[[s]]$lambda / scale[p$site == s]
  }
  rownames(check) <- NULL
  emulators$variance_check <- check
  emulators$variance_runs <- nrow(new_runs$design)
  emulators
}

# Which rows of a design of new runs coincide with design points of the
# emulators (in the emulators' scaled input space).
heldout_at_design <- function(emulators, design) {
  Z <- emulator_newdata(emulators, design, arg = "new_runs$design")
  X <- emulators$design
  width <- apply(X, 2, function(x) diff(range(x)))
  width[!(width > 0)] <- 1
  vapply(seq_len(nrow(Z)), function(k) {
    d <- abs(sweep(X, 2, Z[k, ])) / rep(width, each = nrow(X))
    any(apply(d, 1, max) < 1e-9)
  }, logical(1))
}
