#' wavevalid: Bayesian validation of computer models with functional output
#'
#' The package follows the wavelet-based validation method of Bayarri, Berger,
#' Cafeo et al. (2007): field curves are registered, model and field curves are
#' decomposed on a wavelet basis, each retained coefficient of the model gets a
#' Gaussian process emulator, and a modular Metropolis-Hastings sampler draws
#' the calibration parameters, manufacturing variations, bias and field
#' variances. Tolerance bands, predictions in new settings and diagnosis of
#' where the model fails follow from the draws.
#'
#' The pipeline, verb by verb: [iu_map()], [model_runs()], [field_runs()],
#' [register_curves()], [wavelet_basis()], [fit_emulators()] (checked and, if need
#' be, widened with [rescale_emulators()] at held-out runs), [calibrate()]
#' (or [validate()] for all of it in one call), then [bias()], [reality()],
#' [predict.wv_fit()], [where_fails()], [explain_bias()] and
#' [compare_validations()].
#'
#' @keywords internal
#' @useDynLib wavevalid, .registration = TRUE
#' @importFrom Rcpp sourceCpp
#' @importFrom ggplot2 autoplot
#' @importFrom rlang .data
"_PACKAGE"

#' @export
ggplot2::autoplot
