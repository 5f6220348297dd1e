#' Validate a computer model in one call
#'
#' The whole path from curves to posterior: checks the problem with
#' [preflight()] (grid, basis accuracy, field noise, inputs: an error stops
#' here, in a second or two, before anything is fitted), registers the field
#' curves on the model's event landmarks when `windows` is given
#' ([register_curves()]), builds the wavelet basis ([wavelet_basis()]), fits
#' one emulator per retained coefficient ([fit_emulators()]) and calibrates
#' ([calibrate()]).
#'
#' The choices are grouped in four control objects, each with its own help
#' page: [registration_control()] (the event windows, the reference, the
#' warp's knots, the landmarks), [emulation_control()] (the basis and the
#' emulators' engine), [bias_control()] (the field noise, the bias variances,
#' the inputs' likelihood) and [sampler_control()] (chains, draws, thinning,
#' proposal). Any of their arguments can also be given directly, by name:
#' `validate(runs, field, iu, windows = w, chains = 1)` is
#' `validate(runs, field, iu, registration = registration_control(windows = w),
#' sampler = sampler_control(chains = 1))`.
#'
#' @section The default protocol:
#' The defaults are one protocol for the whole diagnosis, from the
#' registration to which effect is missing: the field curves registered on
#' landmarks in the event windows, of every site at once, with a further warp
#' knot every 1/32 of the record between them; the basis that reconstructs
#' the runs to 1% and each field curve to 2% or its noise; the `"gasp_level"`
#' emulators, whose predictive variances hold at runs away from the design;
#' the bias prior by level with the coarsest levels pooled; [where_fails()]
#' reading the bias by scale and [explain_bias()] weighing the model
#' re-validated with each candidate mechanism. With these defaults on the
#' package's two test beds, the re-validated models name most hidden
#' mechanisms first and seldom claim one with nothing hidden; without the
#' further knots the reality band covers the registered truth less well.
#' The calibrated inputs can take up a mechanism they mimic where it acts
#' (see the inputs in conflict that [where_fails()] reports): after a change,
#' compare the localised part of the bias (`bias_rms_local` of
#' [compare_validations()]). The figures are in the package's source
#' repository (`studies/README.md`: "diagnosis_defaults.R",
#' "band_coverage.R", "registration.R").
#'
#' @param runs A `wv_runs` object ([model_runs()]): the model runs.
#' @inheritParams calibrate
#' @param experiments `NULL` or a named list of further experiments of the
#'   same unit ([experiment()]), calibrated jointly with `field` (see
#'   [calibrate()]). The whole data set of several conditions,
#'   [experiments_at()] with `base`, may be given as `field` instead: its
#'   base field is `field`, its experiments come before those given here.
#'   With `windows`, their field data are registered like `field`, after the basis (built from
#'   `runs` and `field` alone) and the
#'   emulators are fitted: to the mean of the experiment's `reference` runs
#'   when it has them, else to the model in the experiment's own condition
#'   (for an experiment with `change`, the runs with their retained
#'   coefficients replaced by the emulators' means at the runs' inputs plus
#'   the change; for one with its own `emulators`, their means at their
#'   design), never to the base condition's reference. A message says which
#'   reference each experiment was registered to. On the suspension test bed
#'   this put the true inputs inside their intervals at least as often as
#'   condition A alone (`studies/README.md`, "experiment_reference.R").
#' @param registration A [registration_control()] object: how the field
#'   curves are registered (nothing is registered without `windows`).
#' @param emulation An [emulation_control()] object: the basis's arguments
#'   and the emulators' engine.
#' @param bias A [bias_control()] object: the field noise, the bias
#'   variances, the inputs' likelihood.
#' @param sampler A [sampler_control()] object: chains, draws, thinning,
#'   proposal; its `quiet` also silences the messages on the registration.
#'   With no [future::plan()] set, the emulators' fits and the chains run
#'   on the free cores ([wavevalid-package], "Where the work runs").
#' @param ... Arguments of the four controls given directly, by name
#'   (`windows = list(c(6, 11))`, `engine = "gasp"`, `n_draws = 200`,
#'   `chains = 1`): each replaces that setting of its control. A name no
#'   control takes is an error of class `wavevalid_error_input`.
#' @return A `wv_fit` object (see [calibrate()]). Besides the calibration it
#'   keeps `control`, the four control objects it was made with (by kind:
#'   `registration`, `emulation`, `bias`, `sampler`; the seed is `seed`);
#'   `pipeline`, the data it was given: `runs`, the `field` and
#'   `experiments` as given (before their registration) and `registered_to`
#'   (the reference runs the field data were registered to, and the
#'   experiments' by name), so that [update()][update.wv_fit] validates
#'   again with the same settings against the same registered field and
#'   [compare_validations()] registers held-out data as the fit registered
#'   its own; and `timing`, the time each phase took: a data frame of
#'   `phase` (`"preflight"`, `"registration"`, `"basis"`, `"emulators"`,
#'   `"experiments"` (their field data's registration), `"calibration"`,
#'   those that ran), `elapsed` and `cpu` seconds (user and system).
#' @seealso [update.wv_fit()] to validate again with new runs.
#' @export
#' @examples
#' \donttest{
#' tb <- load_testbed()
#' fit <- validate(tb$A$runs, tb$A$field, tb$iu,
#'                 registration = registration_control(windows = list(c(6, 11), c(37, 41))),
#'                 sampler = sampler_control(n_draws = 200, n_inner = 50), seed = 1)
#' fit
#'
#' # with the added-mass experiment of the same vehicle, its field data
#' # registered to the model with the mass added; the controls' arguments
#' # given directly
#' exps <- list(added_mass = experiment(tb$added_mass$field, change = tb$added_mass$delta))
#' fit2 <- validate(tb$A$runs, tb$A$field, tb$iu, experiments = exps,
#'                  windows = list(c(6, 11), c(37, 41)), n_draws = 200, n_inner = 50, seed = 1)
#' }
validate <- function(runs, field, iu, experiments = NULL, registration = registration_control(),
                     emulation = emulation_control(), bias = bias_control(),
                     sampler = sampler_control(),
                     seed = NULL, ...) {
  ctl <- resolve_controls(list(registration = registration, emulation = emulation, bias = bias,
                               sampler = sampler),
                          list(...), "validate")
  reg <- ctl$registration
  windows <- reg$windows
  reference <- reg$reference
  features <- reg$features
  basis_args <- ctl$emulation$basis_args
  bias <- ctl$bias
  quiet <- ctl$sampler$quiet
  check_class(runs, "wv_runs")
  given <- split_field_set(field, experiments)
  field <- given$field
  experiments <- given$experiments
  check_class(field, "wv_field")
  check_class(iu, "wv_iu")
  sigma2 <- bias$sigma2
  check_sigma2(sigma2, names(field$curves))
  clock <- phase_clock()
  enforce_preflight(clock("preflight", preflight(runs, field, iu, sigma2 = sigma2,
                                                 windows = windows,
                                                 basis_args = basis_args)))
  raw_field <- field
  raw_experiments <- experiments
  knots_every <- registration_knots(reg$knots_every, field$t)
  if (!is.null(experiments)) {
    check_experiment_list(experiments)
    check_not_base_data(experiments, field)
  }
  use_cores(Inf, quiet)
  check_runs <- if (isTRUE(bias$registration_variance %in% c("auto", "check"))) 5L else 0L
  registered_to <- NULL
  if (!is.null(windows)) {
    registered_to <- list(field = reference %||% runs)
    field <- clock("registration", register_curves(field, registered_to$field, windows,
                                                   features = features,
                                                   knots_every = knots_every,
                                                   check_runs = check_runs,
                                                   landmark_site = "all"))
  }
  basis <- clock("basis", do.call(wavelet_basis, c(list(runs, field), basis_args)))
  emulators <- clock("emulators", fit_emulators(runs, basis, ctl$emulation$engine))
  cond <- iu_conditions(iu)
  if (!is.null(windows) && is.null(reference) && length(cond)) {
    # with test conditions the runs span them all: the base field goes to the
    # model at its own condition, as the experiments at theirs
    base <- list(field = raw_field, change = stats::setNames(numeric(length(cond)), cond),
                 condition = condition_base(iu))
    registered_to$field <- experiment_reference(base, emulators, runs)
    field <- clock("registration", register_curves(raw_field, registered_to$field, windows,
                                                   features = features, knots_every = knots_every,
                                                   check_runs = check_runs, landmark_site = "all"))
    if (!quiet) {
      at <- paste(sprintf("%s = %g", cond, base$condition), collapse = ", ")
      wv_inform(c("i" = "The field data were registered to the model at the base condition {at} (the emulators at the runs' inputs)."))
    }
  }
  if (!is.null(experiments)) {
    experiments <- check_experiments(experiments, emulators, field, iu = iu)
    if (!is.null(windows)) {
      experiments <- clock("experiments", register_experiments(experiments, emulators, runs,
                                                               windows,
                                                               features = features,
                                                               knots_every = knots_every,
                                                               landmark_site = "all",
                                                               quiet = quiet))
      registered_to$experiments <- attr(experiments, "references")
      attr(experiments, "references") <- NULL
    }
  }
  fit <- clock("calibration", calibrate(emulators, field, iu, experiments = experiments,
                                        bias = bias,
                                        sampler = ctl$sampler, seed = seed))
  fit_set(fit, control = ctl, timing = clock(),
          pipeline = list(runs = runs, field = raw_field, experiments = raw_experiments,
                          registered_to = registered_to))
}
