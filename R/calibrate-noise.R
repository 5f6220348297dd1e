# Field noise variances when the replicates cannot give them.

#' Field noise from the finest wavelet level
#'
#' With a single measured curve the replicate variances of the method are not
#' available. As in wavelet denoising, the noise standard deviation is then
#' estimated from the finest detail level of the curve, where the signal is
#' negligible: `sigma = MAD / 0.6745` of those coefficients (the average over
#' replicates when there are several). The orthonormal transform keeps white
#' noise white, so every retained coefficient gets `sigma^2`. This is a
#' departure from the report's modular estimate: bands then rest on this
#' estimate and on the noise being close to white. On a curve that was
#' smoothed, filtered or interpolated (for instance onto the grid of the
#' model runs) the finest level holds less than the noise, and this estimate
#' is too small; [noise_prior()] learns the noise in the posterior instead,
#' with this estimate only as the scale of its prior.
#'
#' @inheritParams calibrate
#' @inheritParams wavelet_coef
#' @return A named list by site of variance vectors, one value per retained
#'   coefficient, with attribute `sd` (the estimated standard deviation by site).
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 256)
#' y <- sin(2 * pi * t) + rnorm(256, sd = 0.1)
#' field <- field_runs(rbind(y), t)
#' runs <- model_runs(data.frame(a = 1:3), t(sapply(1:3, function(k) sin(2 * pi * t * k))), t)
#' basis <- wavelet_basis(runs, field)
#' attr(field_noise(field, basis), "sd")
field_noise <- function(field, basis) {
  check_class(field, "wv_field")
  check_class(basis, "wv_basis")
  if (length(field$t) != length(basis$t) || !isTRUE(all.equal(field$t, basis$t))) {
    wv_abort("{.arg field} and {.arg basis} must be on the same time grid.")
  }
  n_t <- length(basis$t)
  finest <- seq(n_t / 2 + 1, n_t)
  sds <- vapply(names(field$curves), function(s) {
    mean(apply(field$curves[[s]], 1L, function(y) {
      stats::mad(full_coef(y, basis$settings)[finest], center = 0)
    }))
  }, numeric(1))
  if (any(sds <= 0)) {
    wv_abort(c(
      "The finest wavelet level of the field curves is exactly zero at site{?s} {.val {names(sds)[sds <= 0]}}.",
      "i" = "Supply the field variances with {.arg sigma2}, or the scale of the noise with {.code noise_prior(scale = )}."
    ), class = "numeric")
  }
  out <- lapply(sds, function(s) rep(s^2, length(basis$index)))
  structure(out, sd = sds)
}

#' A prior for field noise learned in the posterior
#'
#' With one measured curve per site the replicate variances of the method are
#' not available. `sigma2 = noise_prior()` in [calibrate()] (the default for a
#' site with one replicate) instead gives the field noise of each site **one
#' variance `sigma2` shared by all retained coefficients**, learned with the
#' inputs and the bias variances. This assumes the measurement noise is white
#' (independent, of one variance, over time): an orthonormal wavelet
#' transform then keeps it white with the same variance at every coefficient.
#' Noise correlated in time would have other variances at other levels, and
#' its coarse-level part would be read as bias.
#'
#' The prior is on the noise standard deviation `sigma`: half-Cauchy (default)
#' or half-normal with scale `scale`. The half-Cauchy has its median at
#' `scale` and a heavy tail, so the data can move `sigma` well above it. By
#' default `scale` is, by site, the finest-level estimate of [field_noise()]
#' (the median absolute finest detail coefficient of the field curves / 0.6745,
#' averaged over replicates): where the signal is negligible at the finest
#' level this is the noise standard deviation. On a smoothed or interpolated
#' curve the finest level is too quiet and this scale too small; the heavy
#' tail then lets the posterior move up. Where [field_runs()] interpolated
#' the measurements onto the grid, the default scale is instead the noise of
#' the measured curve on its own time stamps. Give `scale` yourself when you
#' know the instrument's noise.
#'
#' With one curve the data tell the noise from the bias only because the
#' noise variance is shared by every retained coefficient while each level
#' has its own bias variance `tau2_j`; and the basis keeps few coefficients of
#' the fine levels, where the noise shows best. The noise is then weakly
#' identified and tends to be learned too small, the bias variances taking
#' the rest. Evidence of the noise that the curve on the grid loses is kept by
#' [field_runs()] from the measurements as recorded, and used here: the
#' scatter of repeated measurements at one time stamp, the noise of the curve
#' on its own time stamps (the default `scale`), and each coefficient's noise
#' variance after the measurements were averaged and interpolated onto the
#' grid (`sigma2` is then the variance of one measurement). **The curve's own
#' points enter as data on `sigma2`**, not only as the prior's scale: each
#' inner point's deviation from the line through its neighbours, scaled to
#' variance `sigma2` under white noise, gives `ss / sigma2 ~ chi^2_df` (the
#' squared residuals capped at 3 MAD-based sds, `df` Satterthwaite's for
#' their correlation, about (points - 2) / 1.94, times 0.95 for the cap).
#' Where the true curve bends between the stamps the residuals hold that too,
#' so this evidence bounds the noise from above rather than estimates it: a
#' misfit of the model cannot make the noise grow far beyond what the points
#' show, and goes to the bias. Noise correlated in time (a filtered record)
#' has smaller difference residuals than its variance.
#'
#' In the sampler `log(sigma2)` moves by a Gaussian random walk (its step
#' tuned during the burn-in, then frozen) in every cycle; its target is the
#' likelihood of the field mean, `N(wbar_i; m_i, V_i + c_i sigma2 / R +
#' tau2_j(i))` (`c_i` the coefficient's noise multiplier, 1 for a curve on its
#' own dyadic grid), with, for two or more replicates, the replicates' scatter
#' about their mean (`s2_i / (c_i sigma2) ~ chi^2_(R-1)`), with repeated
#' measurements their scatter and with a curve on its own stamps its
#' difference residuals (`ss / sigma2 ~ chi^2_df`, the two summed), and this
#' prior.
#' The bias variances' prior `1 / (tau2_j + mean(sigma2_j) / R)` takes the
#' learned noise at its prior's scale (`c_i scale^2`), so that it sets the
#' scale of `tau2_j` without acting as a prior on `sigma2`: with the learned
#' `sigma2` in it, each level whose bias is small would add a factor
#' `1 / sigma2` and pull the noise towards zero.
#'
#' @param scale `NULL` (by site, the noise sd of the measured curve on its own
#'   time stamps where [field_runs()] kept it, else the finest-level estimate), one positive
#'   number (the scale of the noise standard deviation, in the units of the
#'   curves, for every site), or a vector named by site.
#' @param family `"half-cauchy"` (default) or `"half-normal"`.
#' @return A `wv_noise_prior` object to pass as `sigma2` to [calibrate()] or
#'   [validate()].
#' @seealso [field_noise()] for the finest-level estimate; [calibrate()].
#' @export
#' @examples
#' noise_prior()
#' noise_prior(scale = 0.05, family = "half-normal")
#' ex <- example_problem()
#' one <- ex$field
#' one$curves$site1 <- one$curves$site1[1, , drop = FALSE]
#' fit <- calibrate(ex$emulators, one, ex$iu, chains = 1, seed = 1,
#'                  bias = bias_control(sigma2 = noise_prior()),
#'                  sampler = sampler_control(n_draws = 50, n_inner = 10, quiet = TRUE))
#' fit$noise_setting
noise_prior <- function(scale = NULL, family = c("half-cauchy", "half-normal")) {
  family <- check_choice(family)
  if (!is.null(scale) && (!is.numeric(scale) || !length(scale) || any(!is.finite(scale)) ||
                          any(scale <= 0) ||
                          (length(scale) > 1L &&
                           (is.null(names(scale)) || anyDuplicated(names(scale)))))) {
    wv_abort(c("{.arg scale} must be NULL, one positive number, or positive numbers named by site.",
               "x" = "It is {.code {deparse(scale)}}."), class = "input")
  }
  structure(list(scale = scale, family = family), class = "wv_noise_prior")
}

#' @export
print.wv_noise_prior <- function(x, ...) {
  sc <- if (is.null(x$scale)) "the finest-level estimate of each site" else
    paste(if (is.null(names(x$scale))) signif(x$scale, 4) else paste(names(x$scale),
                                                                     signif(x$scale, 4), sep = " "),
          collapse = ", ")
  cli::cat_line("<wv_noise_prior> one field noise variance per site, learned; ", x$family,
                " prior on its sd with scale ", sc)
  invisible(x)
}

# The form of `sigma2` in calibrate() and validate(), checked before anything
# is computed.
check_sigma2 <- function(sigma2, sites = NULL, call = rlang::caller_env()) {
  if (is.null(sigma2) || identical(sigma2, "finest")) return(invisible(sigma2))
  if (inherits(sigma2, "wv_noise_prior")) {
    sc <- sigma2$scale
    if (!is.null(sites) && length(sc) > 1L && !setequal(names(sc), sites)) {
      wv_abort("The noise prior's {.arg scale} must be named by every site: {.val {sites}}.",
               call = call)
    }
    return(invisible(sigma2))
  }
  msg <- c("{.arg sigma2} must be {.code NULL}, {.val finest}, a {.fn noise_prior}, positive numbers, or a list of them named by site.",
           "i" = if (!is.null(sites)) "The sites are {.val {sites}}.")
  if (is.character(sigma2)) wv_abort(c(msg, "x" = "It is {.val {sigma2}}."), call = call)
  vals <- if (is.list(sigma2)) sigma2 else list(sigma2)
  if (is.list(sigma2) &&
      (is.null(names(sigma2)) || (!is.null(sites) && !all(names(sigma2) %in% sites)))) {
    wv_abort(msg, call = call)
  }
  for (v in vals) {
    if (!is.numeric(v) || !length(v) || any(!is.finite(v)) || any(v <= 0)) {
      wv_abort(c(msg, "x" = "It holds {.code {deparse(v)}}."), call = call)
    }
  }
  if (!is.list(sigma2) && length(sites) > 1L) wv_abort(msg, call = call)
  invisible(sigma2)
}
