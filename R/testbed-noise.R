#' The test bed's field noise, and its field without time warps
#'
#' `testbed_noise()` draws the measurement noise of the suspension test
#' bed's field replicates ([testbed_suspension()]): a stationary AR(1)
#' series with standard deviation `sd` and lag-one correlation `phi` per grid
#' step. The dosing test bed's ([testbed_dosing()]) is `sd = 0.04, phi =
#' 0.9`. It draws from R's random number generator: seed it for the same
#' noise.
#'
#' `testbed_unwarped_field()` gives condition A's field data of a suspension
#' test bed as a perfect registration would leave them: reality without
#' noise plus new noise of the replicates' kind, one curve for each
#' replicate, no time warps. With `warp`, reality is first warped by it (the
#' same warp for every replicate). It measures what the registration costs.
#'
#' @param n The length of the series.
#' @param sd,phi The noise's standard deviation and lag-one correlation.
#' @param tb A `wv_testbed` ([testbed_suspension()]).
#' @param seed A whole number fixing the noise; the caller's random number
#'   stream is left as it was.
#' @param warp `NULL` or a time warp as a data frame of knots `t` (time) and
#'   `w` (the course time seen at `t`), increasing, as `tb$truth$warps` holds
#'   them; a monotone spline through the knots.
#' @return `testbed_noise()`: a numeric vector of length `n`.
#'   `testbed_unwarped_field()`: a `wv_field` shaped as `tb$A$field`.
#' @export
#' @examples
#' e <- testbed_noise(4096)
#' c(sd = sd(e), lag1 = cor(e[-1], e[-4096]))
#' tb <- testbed_suspension(seed = 1)
#' f <- testbed_unwarped_field(tb, seed = 3)
#' # the noise of the first replicate at the front
#' sd(f$curves$site1[1, ] - tb$truth$reality$site1)
testbed_noise <- function(n, sd = 0.03, phi = 0.95) {
  check_number(n, "n", min = 1, integer = TRUE)
  check_number(sd, "sd", min = 0)
  check_number(phi, "phi", min = -1, max = 1)
  ar1_noise(n, sd = sd, phi = phi)
}

#' @rdname testbed_noise
#' @export
testbed_unwarped_field <- function(tb, seed, warp = NULL) {
  check_class(tb, "wv_testbed")
  check_number(seed, "seed", integer = TRUE)
  if (!is.null(warp) && !(is.data.frame(warp) && all(c("t", "w") %in% names(warp)))) {
    wv_abort("{.arg warp} must be NULL or a data frame of knots {.field t} and {.field w}.")
  }
  unwarped_field(tb, seed, warp = warp[c("t", "w")])
}
