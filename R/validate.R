#' Validate a computer model in one call
#'
#' The whole path from curves to posterior: checks the problem with
#' [preflight()] (grid, basis accuracy, field noise, inputs: an error stops
#' here, in a second or two, before anything is fitted), registers the field
#' curves on the model's event landmarks when `windows` is given
#' ([register_curves()]),
#' builds the wavelet basis ([wavelet_basis()]), fits one emulator per retained
#' coefficient ([fit_emulators()]) and calibrates ([calibrate()]).
#'
#' The emulators default to the `"gasp_level"` engine, whose predictive
#' variances hold at runs away from the design (see [fit_emulators()]); give
#' `engine = "gasp"` for the method's report's per-coefficient fit. The print
#' of the fit states the engine and how well the emulators' variances match
#' their leave-one-out errors.
#'
#' @inheritParams fit_emulators
#' @inheritParams calibrate
#' @param windows Optional list of `c(from, to)` event windows; when given,
#'   the field curves are registered first.
#' @param reference Reference curves for the registration (passed to
#'   [register_curves()]; default: the mean of the model runs).
#' @param knots_every Spacing of the further warp knots fitted between the
#'   windows (passed to [register_curves()]): `"auto"` (default) a knot
#'   every 1/32 of the record, a number (in time units), or `NULL` for the
#'   method's report's landmark warp (landmarks only).
#' @param features The landmarks located in each window (passed to
#'   [register_curves()]): `c("min", "max")` (default), or any of `"min"`,
#'   `"max"`, `"rise"`, `"fall"`, `"cross"` that the physics of the events
#'   makes sharp.
#' @param basis_args A list of further arguments to [wavelet_basis()].
#' @param sigma2 How the field noise is set (passed to [calibrate()]):
#'   `NULL` (default; from the replicates, or with one replicate learned in
#'   the posterior under [noise_prior()]), fixed variances, `"finest"`, or a
#'   [noise_prior()].
#' @param ... Passed to [calibrate()] (`n_draws`, `n_inner`, `chains`, `seed`,
#'   ...).
#' @return A `wv_fit` object (see [calibrate()]).
#' @export
#' @examples
#' \donttest{
#' tb <- load_testbed()
#' fit <- validate(tb$A$runs, tb$A$field, tb$iu, windows = list(c(6, 11), c(37, 41)),
#'                 n_draws = 200, n_inner = 50, seed = 1)
#' fit
#' }
validate <- function(runs, field, iu, windows = NULL, reference = NULL, knots_every = "auto",
                     features = c("min", "max"), basis_args = list(), engine = "gasp_level", sigma2 = NULL,
                     ...) {
  check_class(runs, "wv_runs")
  check_class(field, "wv_field")
  check_class(iu, "wv_iu")
  if (!is.list(basis_args)) wv_abort("{.arg basis_args} must be a list of arguments to {.fn wavelet_basis}.")
  check_sigma2(sigma2, names(field$curves))
  enforce_preflight(preflight(runs, field, iu, sigma2 = sigma2, windows = windows, basis_args = basis_args))
  if (identical(knots_every, "auto")) knots_every <- diff(range(field$t)) / 32
  if (!is.null(windows)) {
    field <- register_curves(field, reference %||% runs, windows, features = features, knots_every = knots_every)
  }
  basis <- do.call(wavelet_basis, c(list(runs, field), basis_args))
  emulators <- fit_emulators(runs, basis, engine)
  calibrate(emulators, field, iu, sigma2 = sigma2, ...)
}
