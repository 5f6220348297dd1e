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
#' @section The default protocol:
#' The defaults are one protocol for the whole diagnosis, from the
#' registration to which effect is missing:
#' * the field curves registered on landmarks in the event windows, with a
#'   further warp knot every 1/32 of the record between them (`knots_every =
#'   "auto"`; `NULL` is the method's report's landmark warp);
#' * the basis that reconstructs the runs to 1% and each field curve to 2%
#'   or its noise (`wavelet_basis(retain = "error")`), the `"gasp_level"`
#'   emulators, the bias prior by level (no pooling);
#' * [where_fails()] reading the bias by scale (the record-wide part apart,
#'   the intervals from the rest) and [explain_bias()] weighing the model
#'   re-validated with each candidate mechanism (its runs joined by the
#'   model's own runs with the mechanism switched off), the signatures being
#'   the quick first pass.
#'
#' Choose as landmarks (`features`) the features that mark when an event
#' happens, not those whose timing the model's own physics sets: the
#' registration moves each landmark of a replicate onto the reference's, and
#' a landmark the inputs move carries part of the model's error away with it,
#' or adds one. The price of landmarks that mark only when an event happens:
#' a mechanism that only delays an event (an absorption lag) is aligned away
#' with the timing jitter and cannot be found. On the package's dosing test
#' bed ([testbed_dosing()]) with nothing hidden, registering on each dose's
#' peak, whose time the absorption rate sets, left flagged intervals and
#' claimed mechanisms where registering on each dose's steepest rise did not.
#'
#' Each replicate has one warp for all sites, tied to the landmarks of every
#' site in every window (an event that reaches the sites at different times,
#' as a pothole the front and then the rear axle, is pinned where each site
#' sees it; `register_curves(landmark_site = "all")`). On the package's
#' suspension test bed this halved the scatter of the registered replicates
#' at the rear site, whose events the front site's landmarks do not mark.
#'
#' Without the further knots the reality band covers the registered truth
#' less well. Without the model's own runs among those of a re-validated
#' model, the weighing of a mechanism against itself switched off rests on
#' the emulators' extrapolation to the strength's lower bound. On the
#' package's test beds ([testbed_suspension()], [testbed_dosing()]) the band
#' without the further knots fell well short of its level, and re-validated
#' models without the model's own runs claimed a mechanism with nothing
#' hidden where those with them did not.
#'
#' The calibrated inputs can take up a mechanism they mimic where it acts
#' (see the inputs in conflict that [where_fails()] reports, and the bias it
#' reads with them held), and can trade a credible offset of the whole record
#' against the events; after a change, compare the localised part of the bias
#' (`bias_rms_local` of [compare_validations()]). With these defaults on the
#' package's two test beds, the re-validated models name most hidden
#' mechanisms first and seldom claim one with nothing hidden, while
#' `where_fails()` with nothing hidden can leave short localised intervals
#' at sharp events; the figures by mechanism are in the package's source
#' repository (`studies/README.md`, "diagnosis_defaults.R").
#'
#' @inheritParams fit_emulators
#' @inheritParams calibrate
#' @param windows Optional list of `c(from, to)` event windows; when given,
#'   the field curves are registered first.
#' @param reference Reference curves for the registration (passed to
#'   [register_curves()]; default: the mean of the model runs). When the I/U
#'   map has test conditions (inputs of type `"condition"`), the runs span
#'   them all, so by default the field is registered twice: first to the
#'   mean of the runs, to build the basis and fit the emulators, then again
#'   to the model at the base experiment's condition (the runs' inputs with
#'   the conditions set to their nominal values, through the emulators), as
#'   the experiments are registered to the model at theirs.
#' @param knots_every Spacing of the further warp knots fitted between the
#'   windows (passed to [register_curves()]): `"auto"` (default) a knot
#'   every 1/32 of the record (at least four steps of the field's grid, the
#'   closest spacing [register_curves()] takes), a number (in time units), or `NULL` for the
#'   method's report's landmark warp (landmarks only).
#' @param features The landmarks located in each window (passed to
#'   [register_curves()]): `c("min", "max")` (default), or any of `"min"`,
#'   `"max"`, `"rise"`, `"fall"`, `"cross"` that the physics of the events
#'   makes sharp.
#' @param basis_args A list of further arguments to [wavelet_basis()].
#' @param experiments `NULL` or a named list of further experiments of the
#'   same unit ([experiment()]), calibrated jointly with `field` (see
#'   [calibrate()]). With `windows`, their field data are registered like
#'   `field`, after the basis (built from `runs` and `field` alone) and the
#'   emulators are fitted: to the mean of the experiment's `reference` runs
#'   when it has them, else to the model in the experiment's own condition,
#'   never to the base condition's reference. For an experiment with
#'   `change`, that is the mean of the runs with their retained coefficients
#'   replaced by the emulators' means at the runs' inputs plus the change
#'   (the analogue of the mean of the runs for `field`; runs the change moves
#'   outside the design's range are kept, the emulators extrapolating); for
#'   one with its own `emulators`, the mean of their means at their own
#'   design. The part of the curves the basis does not retain comes from
#'   `runs`; for an experiment at a test condition, from the tenth of the
#'   runs nearest its condition (at least 5), since a condition can change
#'   that detail too (a dose scales the kink where it is given: on the
#'   package's dosing test bed, detail from every run put the landmark
#'   before a dose at 250 mg 0.28 h off and a correct model showed seven
#'   false intervals). A message says which reference each experiment was registered
#'   to. On the package's suspension test bed with nothing hidden and
#'   replicates of an added mass, this put the true inputs inside their 95%
#'   intervals at least as often as condition A alone and narrowed the
#'   calibration inputs' posterior, where registering to condition A's runs
#'   could pull them from the truth (`studies/README.md` in the package's
#'   source repository, "experiment_reference.R").
#' @param bias,sampler,chains,seed Passed to [calibrate()]: a
#'   [bias_control()] (the field noise, the bias variances, the inputs'
#'   likelihood), a [sampler_control()] (draws, thinning, proposal; its
#'   `quiet` also silences the message on the experiments' registration), the
#'   number of chains and the seed.
#' @param ... Must be empty. Settings of `bias_control()` and
#'   `sampler_control()` named here (`n_draws = 200`, `sigma2 = ...`,
#'   `quiet = TRUE`) work for this version, with a warning of class
#'   `wavevalid_warning_deprecated`.
#' @return A `wv_fit` object (see [calibrate()]). It keeps the arguments
#'   of the pipeline in `call_args` (`runs`, the `field` as given, before its
#'   registration, `windows`, `reference`, `knots_every`, `features`,
#'   `basis_args`, `engine`, the `experiments` as given, `chains`, and
#'   `registered_to`: the reference runs the field data were registered to,
#'   and the experiments' by name), so that [update()][update.wv_fit]
#'   validates again with the same settings against the same registered
#'   field and [compare_validations()] registers held-out data as the fit
#'   registered its own; and the time each phase took in `timing`, a data frame of
#'   `phase` (`"preflight"`, `"registration"`, `"basis"`, `"emulators"`,
#'   `"experiments"` (their field data's registration), `"calibration"`, those
#'   that ran), `elapsed` and `cpu` seconds (user and system).
#' @seealso [update.wv_fit()] to validate again with new runs.
#' @export
#' @examples
#' \donttest{
#' tb <- load_testbed()
#' fit <- validate(tb$A$runs, tb$A$field, tb$iu, windows = list(c(6, 11), c(37, 41)),
#'                 sampler = sampler_control(n_draws = 200, n_inner = 50), seed = 1)
#' fit
#'
#' # with the added-mass experiment of the same vehicle, its field data
#' # registered to the model with the mass added
#' exps <- list(added_mass = experiment(tb$added_mass$field, change = tb$added_mass$delta))
#' fit2 <- validate(tb$A$runs, tb$A$field, tb$iu, windows = list(c(6, 11), c(37, 41)),
#'                  experiments = exps, sampler = sampler_control(n_draws = 200, n_inner = 50),
#'                  seed = 1)
#' }
validate <- function(runs, field, iu, windows = NULL, reference = NULL, knots_every = "auto",
                     features = c("min", "max"), basis_args = list(), engine = "gasp_level",
                     experiments = NULL, bias = bias_control(), sampler = sampler_control(), chains = 2,
                     seed = NULL, ...) {
  ctl <- resolve_controls(bias, sampler, list(...), "validate")
  bias <- ctl$bias
  sampler <- ctl$sampler
  quiet <- sampler$quiet
  check_class(runs, "wv_runs")
  check_class(field, "wv_field")
  check_class(iu, "wv_iu")
  if (!is.list(basis_args)) wv_abort("{.arg basis_args} must be a list of arguments to {.fn wavelet_basis}.")
  sigma2 <- bias$sigma2
  check_sigma2(sigma2, names(field$curves))
  clock <- phase_clock()
  enforce_preflight(clock("preflight", preflight(runs, field, iu, sigma2 = sigma2, windows = windows,
                                                 basis_args = basis_args)))
  raw_field <- field
  raw_experiments <- experiments
  knots_every_arg <- knots_every
  if (identical(knots_every, "auto")) knots_every <- max(diff(range(field$t)) / 32, 4 * diff(field$t[1:2]))
  if (!is.null(experiments)) {
    check_experiment_list(experiments)
    check_not_base_data(experiments, field)
  }
  check_runs <- if (isTRUE(bias$registration_variance %in% c("auto", "check"))) 5L else 0L
  registered_to <- NULL
  if (!is.null(windows)) {
    registered_to <- list(field = reference %||% runs)
    field <- clock("registration", register_curves(field, registered_to$field, windows, features = features,
                                                   knots_every = knots_every, check_runs = check_runs,
                                                   landmark_site = "all"))
  }
  basis <- clock("basis", do.call(wavelet_basis, c(list(runs, field), basis_args)))
  emulators <- clock("emulators", fit_emulators(runs, basis, engine))
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
      experiments <- clock("experiments", register_experiments(experiments, emulators, runs, windows,
                                                               features = features, knots_every = knots_every,
                                                               landmark_site = "all",
                                                               quiet = quiet))
      registered_to$experiments <- attr(experiments, "references")
      attr(experiments, "references") <- NULL
    }
  }
  fit <- clock("calibration", calibrate(emulators, field, iu, experiments = experiments, bias = bias,
                                        sampler = sampler, chains = chains, seed = seed))
  fit$call_args <- list(runs = runs, field = raw_field, windows = windows, reference = reference,
                        knots_every = knots_every_arg, features = features, basis_args = basis_args, engine = engine,
                        experiments = raw_experiments, chains = chains, registered_to = registered_to)
  fit_set(fit, timing = clock())
}
