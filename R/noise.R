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
#' estimate and on the noise being close to white.
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
      "i" = "Supply the field variances with {.arg sigma2}."
    ), class = "numeric")
  }
  out <- lapply(sds, function(s) rep(s^2, length(basis$index)))
  structure(out, sd = sds)
}
