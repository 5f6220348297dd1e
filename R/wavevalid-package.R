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
#' @section Where the work runs:
#' The chains of [calibrate()], the emulators' fits in [fit_emulators()]
#' (chunks of coefficients) and the strata of [hold_inputs()] are futures:
#' [future::plan()] decides where they run, and the results are the same
#' under every plan (sequential, `future::multisession`,
#' `future.callr::callr`, `future.batchtools`). Each future carries only what
#' its worker needs; a chain's payload grows with coefficients x runs^2 (tens
#' of MiB on the test beds). Within a chain the sampler uses
#' `sampler_control(threads = )` threads. On a cluster with Slurm:
#' ```
#' future::plan(future.batchtools::batchtools_slurm, template = "slurm-simple",
#'              resources = list(walltime = 3600, memory = 4000, ncpus = 2))
#' fit <- validate(runs, field, iu, windows = windows, chains = 4)
#' ```
#' submits each chain and each batch of emulator fits as a job, with the
#' Slurm template that `batchtools` ships (or a path to one's own). With no
#' plan set, [validate()] (and [calibrate()] with two or more chains) runs
#' on the free cores through a multisession plan for the call, and says so;
#' `options(wavevalid.workers = 1)` keeps the work in one process. The curve
#' summaries behind the bands and the findings run on a thread per core R may
#' use (`future::availableCores()`), one with `options(wavevalid.workers = 1)`;
#' the numbers do not depend on the threads.
#'
#' @keywords internal
#' @useDynLib wavevalid, .registration = TRUE
#' @importFrom Rcpp sourceCpp
#' @importFrom ggplot2 autoplot
#' @importFrom rlang .data
"_PACKAGE"

#' @export
ggplot2::autoplot
