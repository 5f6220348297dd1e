#' The diagnosis protocol on the test beds
#'
#' How the package's diagnosis tests and its studies (`studies/` in the
#' package's sources) validate a model on the suspension test bed
#' ([testbed_suspension()]), re-validate it with each candidate mechanism,
#' and judge the diagnosis: where the model fails ([where_fails()]), which
#' effect is missing ([explain_bias()]) and whether adding it fixes the model
#' ([compare_validations()]). The test bed's truth is known, so each verdict
#' says whether the diagnosis found it.
#'
#' @section The protocol's choices:
#' The protocol makes the method's own choices, not the package's defaults:
#' * the report's wavelet basis (`wavelet_basis(retain = "report")`);
#' * one Gaussian process emulator per retained coefficient
#'   (`fit_emulators(engine = "gasp")`: `testbed_emulators()`);
#' * one short chain, 150 draws of 20 cycles with seed 1, its warnings (the
#'   chain is short) muffled (`testbed_calibrate()`);
#' * the method's likelihood of the inputs, which takes the coefficients as
#'   independent (`calibrate(input_likelihood = "independent")`);
#' * the field registered to the mean of the model runs, with further knots
#'   every 2 time units, on the load's minimum and maximum in each event
#'   window; on the maximum alone when the tire lift-off is hidden, whose
#'   minimum is flat (`testbed_register()`).
#'
#' The diagnosis tests' figures and the studies' findings were measured with
#' these choices. The package's defaults gave other answers on the same test
#' beds. With the default emulators (`engine = "gasp_level"`) the signature
#' candidates still ranked the hidden mechanism first, but a decoy
#' sometimes reached an inclusion probability of 0.5 (with a digressive
#' damper hidden); the re-validated mechanisms claimed the tire lift-off with
#' nothing hidden; and flags of the unpooled bias missed a hidden bump stop at
#' the front. With the default likelihood (`input_likelihood = "adjusted"`)
#' the short chain could settle with several inputs in conflict with their
#' prior, and explain_bias() then claimed the tire lift-off with nothing
#' hidden; among the signature candidates the hidden mechanism reached 0.9
#' in only part of the hidden cases; and the pooled flags of a hidden bump
#' stop at the rear were only a few times likelier than flags thrown at
#' random to lie where it acts. `testbed_default_fit()` and
#' `testbed_default_refits()` run the package's defaults instead.
#'
#' @section The steps:
#' * `testbed_validation()` validates the model without any mechanism on
#'   condition A: the field registered to the runs, the report's basis, the
#'   protocol's emulators and chain.
#' * `testbed_revalidation()` re-validates the model of a fit with each
#'   mechanism in turn: its strength `s_<m>` a calibration input on \[0, 1\],
#'   the model with it simulated at an `n_runs`-point maximin design, the
#'   emulators on the fit's basis, calibrated on the fit's field with its bias
#'   pooling (`pool_levels`) and field variance (`registration_variance`).
#'   With `n_check > 0` the emulators are rescaled ([rescale_emulators()]) on
#'   that many held-out runs of the model with the mechanism
#'   (`testbed_check_runs()`).
#' * `testbed_first_pass()` and `testbed_two_pass()` re-register: the field
#'   registered to the model's `runs` (`start = "runs"`) or to the
#'   replicates' own pointwise mean (`"replicates"`), the basis and
#'   emulators (rescaled on the held-out runs `check` unless `NULL`),
#'   calibrated with levels `pool_levels` pooled; then, `passes - 1` times,
#'   the field registered again to one run of the model at the posterior
#'   mean inputs of the last fit ([stats::coef()]) and calibrated again on
#'   the same emulators. Each chain's start is searched among `n_search`
#'   draws from the prior.
#' * `testbed_loop()` runs the whole loop of criterion 3 below.
#' * `testbed_beds()`, `testbed_default_fit()` and `testbed_default_refits()`
#'   run the package's defaults on either test bed: [validate()] with its
#'   defaults on condition A, and the model re-validated with each mechanism
#'   (66 runs of the model with it at a maximin design, joined by the model's
#'   own runs with the strength at 0 unless `off_runs = FALSE`, the default
#'   emulators unless `engine` is given).
#'
#' @section Reading the verdicts:
#' Criterion 1, *where* (`testbed_where_verdict()`), from a [where_fails()]
#' table of a fit with mechanism `hidden` hidden and that mechanism's
#' signature `effect` at the true inputs. With nothing hidden the case passes
#' (`where_ok` and `localised`) when no flagged interval is longer than
#' `max_steps` grid steps. Otherwise `where_ok` asks that more than 20% of the
#' points where the mechanism acts be flagged at every site (`recall`,
#' [flagged_share()]), and `localised` adds that the flags lie where it acts:
#' their `precision` (the share of the flagged points where it acts) exceeds
#' the rate of flags thrown at random (`base`, the share of the grid where it
#' acts) by at least that rate, or by half the room above it when the
#' mechanism acts over more than a third of the grid.
#'
#' Criterion 2, *which* (`testbed_explain_verdict()`), from an
#' [explain_bias()] table: with a mechanism hidden, `ok` when it is first
#' among the mechanisms (the shift candidates aside) with an inclusion
#' probability of 0.9 or more and every other mechanism is below 0.5; with
#' nothing hidden, when no candidate (shifts included) reaches 0.5. `top` and
#' `top_prob` name the leading candidate (among the mechanisms when one is
#' hidden).
#'
#' Criterion 3, *the loop* (`testbed_loop()`): the model without the hidden
#' mechanism (`before`) and the model with it (`after`, its strength a
#' calibration input on \[0, 1\], its 66 runs at condition A's design with
#' the strength spread over \[0, 1\]), each fitted by `fit_model`, compared
#' by [compare_validations()] with condition B held out: new nominal inputs,
#' the after-model's B runs spreading the strength over its 99% posterior
#' interval, B's replicates registered to the mean of each model's B runs (or
#' with `holdout_again` to one run of each model at its posterior mean
#' calibration inputs and B's nominal variation inputs). The studies count a
#' case as passing when adding the mechanism cuts `bias_rms` by more than 70%
#' and the held-out error falls.
#'
#' @param tb A test bed: a `wv_testbed` ([testbed_suspension()]) or, for the
#'   defaults, a `wv_testbed_dosing` ([testbed_dosing()]).
#' @param reference The reference of the registration: model runs (a
#'   `wv_runs`, whose mean is the reference) or curves by site (a named list
#'   of vectors), as [register_curves()] takes it.
#' @param condition The test bed's condition whose field data are registered:
#'   `"A"`, `"B"` or `"added_mass"`.
#' @param refine Passed to [register_curves()].
#' @param runs Model runs (`wv_runs`).
#' @param basis A `wv_basis` ([wavelet_basis()]).
#' @param emulators A `wv_emulators` object ([fit_emulators()]).
#' @param field Registered field data (`wv_field`).
#' @param iu The I/U map (`wv_iu`) of the model's inputs.
#' @param pool_levels,registration_variance,n_search Passed to [calibrate()].
#' @param n_draws,n_inner The chain's draws and the cycles between draws.
#' @param hidden `"none"` or one of [testbed_mechanisms()]: the mechanism
#'   reality has and the model lacks.
#' @param seed The test bed's seed ([testbed_suspension()]).
#' @param mechanism `NULL` (none) or the mechanism the model is simulated
#'   with.
#' @param check `NULL` or held-out runs for [rescale_emulators()].
#' @param start `"runs"` or `"replicates"`: what the field is first
#'   registered to.
#' @param passes The number of calibrations, each but the first on the field
#'   registered again.
#' @param fit A `wv_fit` (for `testbed_revalidation()`, one of
#'   `testbed_validation()`).
#' @param mechanisms The mechanisms to re-validate the model with.
#' @param n_runs The number of runs of each re-validated model.
#' @param n_check The number of held-out runs to rescale each re-validated
#'   model's emulators on (0: none).
#' @param n The number of held-out runs.
#' @param fails A `wv_fails` table ([where_fails()]).
#' @param effect The hidden mechanism's signature at the true inputs (a list
#'   by site, one element of [testbed_signatures()]); `NULL` with nothing
#'   hidden.
#' @param max_steps The longest flagged interval, in grid steps, allowed with
#'   nothing hidden.
#' @param ex A `wv_explain` table ([explain_bias()]).
#' @param fit_model `NULL` or a function `(tb, runs, iu, mechanism)`
#'   returning a `wv_fit`; `NULL` takes the last fit of `testbed_two_pass()`.
#' @param holdout_again Register B's replicates to one run of each model at
#'   its posterior mean inputs rather than to the mean of its B runs.
#' @param features The landmarks of the registration ([register_curves()]).
#' @param ... Passed to [validate()].
#' @param simulate The test bed's simulator ([simulate_suspension()] or
#'   [simulate_dosing()]).
#' @param engine `NULL` (the default emulators) or the engine of
#'   [fit_emulators()].
#' @param off_runs Join the model's own runs, with the strength at 0, to each
#'   re-validated model's design.
#' @return
#' * `testbed_register()`: a `wv_field` ([register_curves()]).
#' * `testbed_emulators()`: a `wv_emulators`.
#' * `testbed_calibrate()`, `testbed_default_fit()`: a `wv_fit`.
#' * `testbed_validation()`, `testbed_first_pass()`: a list of `field`,
#'   `basis`, `emulators` and `fit` (and `tb` for `testbed_validation()`).
#' * `testbed_two_pass()`: a list of `first` (the first pass), `fits` (every
#'   pass's fit) and `fit`, the last.
#' * `testbed_revalidation()`, `testbed_default_refits()`: a list of fits
#'   named by mechanism, for [explain_bias()].
#' * `testbed_check_runs()`: a `wv_runs`.
#' * `testbed_where_verdict()`: a list of `longest` (grid steps), `recall`,
#'   `precision` and `base` by site (`NULL` with nothing hidden), `where_ok`
#'   and `localised`.
#' * `testbed_explain_verdict()`: a list of `top`, `top_prob` and `ok`.
#' * `testbed_loop()`: a list of `tb`, `before`, `after` and `comparison`.
#' * `testbed_beds()`: a list by test bed (`suspension`, `dosing`) of its
#'   constructor `make`, simulator `simulate`, `mechanisms` and `signatures`
#'   functions, and the `features` that mark when its events happen (the
#'   suspension's load extremes at the road events; a dose's rise).
#' @seealso [testbed_noise()] for the test bed's field noise without the
#'   time warps.
#' @name testbed_protocol
#' @examples
#' tb <- testbed_suspension(seed = 1)
#' check <- testbed_check_runs(tb$iu, n = 4)
#' names(testbed_beds())
#' # a verdict of criterion 1 on a small fit, nothing hidden
#' testbed_where_verdict(where_fails(example_fit()), "none")$where_ok
#' \donttest{
#' field <- testbed_register(tb, tb$A$runs)
#' # the model without any mechanism, validated and judged (about a minute)
#' v <- testbed_validation("none", seed = 1)
#' testbed_where_verdict(where_fails(v$fit), "none")
#' ex <- explain_bias(v$fit, testbed_signatures(coef(v$fit)), n_draws = 50, seed = 1)
#' testbed_explain_verdict(ex, "none")
#' }
NULL

# The emulators' engine of the protocol: the report's per-coefficient fit.
testbed_engine <- "gasp"

#' @rdname testbed_protocol
#' @export
testbed_register <- function(tb, reference, condition = "A", refine = FALSE) {
  features <- if (identical(tb$truth$hidden, "tire_liftoff")) "max" else c("min", "max")
  register_curves(tb[[condition]]$field, reference, tb$windows, features = features, knots_every = 2,
                  refine = refine)
}

#' @rdname testbed_protocol
#' @export
testbed_emulators <- function(runs, basis) {
  suppressWarnings(fit_emulators(runs, basis, engine = testbed_engine))
}

#' @rdname testbed_protocol
#' @export
testbed_calibrate <- function(emulators, field, iu, pool_levels = NULL, n_draws = 150L, n_inner = 20L,
                              registration_variance = FALSE, n_search = 200L) {
  suppressWarnings(calibrate(emulators, field, iu, chains = 1, seed = 1,
                             bias = bias_control(pool_levels = pool_levels, registration_variance = registration_variance,
                                                 input_likelihood = "independent"),
                             sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, n_search = n_search, quiet = TRUE)))
}

#' @rdname testbed_protocol
#' @export
testbed_validation <- function(hidden, seed, n_draws = 150L, n_inner = 20L, pool_levels = NULL,
                               registration_variance = FALSE) {
  old <- options(wavevalid.quiet = TRUE)
  on.exit(options(old), add = TRUE)
  tb <- testbed_suspension(seed = seed, hidden = hidden)
  field <- testbed_register(tb, tb$A$runs)
  basis <- wavelet_basis(tb$A$runs, field, retain = "report")
  em <- testbed_emulators(tb$A$runs, basis)
  fit <- testbed_calibrate(em, field, tb$iu, pool_levels, n_draws, n_inner, registration_variance)
  list(tb = tb, field = field, basis = basis, emulators = em, fit = fit)
}

#' @rdname testbed_protocol
#' @export
testbed_two_pass <- function(tb, runs, iu, mechanism = NULL, check = NULL, pool_levels = 0:3,
                             start = c("runs", "replicates"), passes = 2L, n_search = 2000L) {
  start <- match.arg(start)
  first <- testbed_first_pass(tb, runs, iu, check, pool_levels, start, n_search)
  fits <- list(first$fit)
  for (k in seq_len(passes - 1L)) {
    at <- simulate_suspension(as.data.frame(as.list(stats::coef(fits[[k]]))), mechanism = mechanism)
    fits[[k + 1L]] <- testbed_calibrate(first$emulators, testbed_register(tb, at), iu, pool_levels,
                                        n_search = n_search)
  }
  list(first = first, fits = fits, fit = fits[[passes]])
}

#' @rdname testbed_protocol
#' @export
testbed_first_pass <- function(tb, runs, iu, check = NULL, pool_levels = 0:3, start = c("runs", "replicates"),
                               n_search = 200L) {
  start <- match.arg(start)
  field <- testbed_register(tb, if (start == "runs") runs else lapply(tb$A$field$curves, colMeans))
  basis <- wavelet_basis(runs, field, retain = "report")
  em <- testbed_emulators(runs, basis)
  if (!is.null(check)) em <- rescale_emulators(em, check)
  list(field = field, basis = basis, emulators = em,
       fit = testbed_calibrate(em, field, iu, pool_levels, n_search = n_search))
}

#' @rdname testbed_protocol
#' @export
testbed_revalidation <- function(tb, fit, mechanisms = testbed_mechanisms(), n_runs = 66L, n_draws = 150L,
                                 n_inner = 20L, n_check = 0L) {
  old <- options(wavevalid.quiet = TRUE)
  on.exit(options(old), add = TRUE)
  fits <- lapply(mechanisms, function(m) {
    iu_m <- iu_add(tb$iu, paste0("s_", m), lower = 0, upper = 1, nominal = 0.5)
    runs <- simulate_suspension(design_maximin(iu_m, n_runs, seed = 2), mechanism = m)
    em <- testbed_emulators(runs, fit$basis)
    if (n_check > 0L) em <- rescale_emulators(em, testbed_check_runs(iu_m, m, n_check))
    testbed_calibrate(em, fit$field, iu_m, fit$settings$pool_levels, n_draws, n_inner,
                      isTRUE(fit$settings$registration_variance))
  })
  stats::setNames(fits, mechanisms)
}

#' @rdname testbed_protocol
#' @export
testbed_check_runs <- function(iu, mechanism = NULL, n = 30L) {
  simulate_suspension(design_maximin(iu, n, nominal = FALSE, seed = 9), mechanism = mechanism)
}

#' @rdname testbed_protocol
#' @export
testbed_where_verdict <- function(fails, hidden, effect = NULL, max_steps = 3) {
  check_class(fails, "wv_fails")
  t <- attr(fails, "bias")$t
  iv <- finding_rows(fails, "interval")
  longest <- if (nrow(iv)) round(max(iv$end - iv$start) / (t[2] - t[1])) else 0
  if (identical(hidden, "none")) {
    ok <- longest <= max_steps
    return(list(longest = longest, recall = NULL, precision = NULL, base = NULL, where_ok = ok, localised = ok))
  }
  if (is.null(effect)) wv_abort("A hidden mechanism needs its {.arg effect} to judge the flags.")
  recall <- flagged_share(fails, effect)
  precision <- flagged_share(fails, effect, of = "flags")
  base <- attr(precision, "acting")
  precision <- c(precision)
  precision[is.na(precision)] <- 0
  where_ok <- all(recall > 0.2)
  list(longest = longest, recall = c(recall), precision = precision, base = base, where_ok = where_ok,
       localised = where_ok && all(precision - base > pmin(base, (1 - base) / 2)))
}

#' @rdname testbed_protocol
#' @export
testbed_explain_verdict <- function(ex, hidden) {
  check_class(ex, "wv_explain")
  ex <- as.data.frame(unclass(ex))
  if (identical(hidden, "none")) {
    return(list(top = ex$candidate[1], top_prob = ex$inclusion_prob[1], ok = all(ex$inclusion_prob < 0.5)))
  }
  mech <- ex[!startsWith(ex$candidate, "shift:"), , drop = FALSE]
  if (!hidden %in% mech$candidate) {
    wv_abort("{.val {hidden}} is not among the candidates {.val {mech$candidate}}.")
  }
  p <- mech$inclusion_prob[mech$candidate == hidden]
  list(top = mech$candidate[1], top_prob = mech$inclusion_prob[1],
       ok = mech$candidate[1] == hidden && p >= 0.9 && all(mech$inclusion_prob[mech$candidate != hidden] < 0.5))
}

#' @rdname testbed_protocol
#' @export
testbed_loop <- function(hidden, seed, fit_model = NULL, refine = FALSE, holdout_again = FALSE) {
  old <- options(wavevalid.quiet = TRUE)
  on.exit(options(old), add = TRUE)
  if (is.null(fit_model)) {
    fit_model <- function(tb, runs, iu, mechanism) testbed_two_pass(tb, runs, iu, mechanism)$fit
  }
  tb <- testbed_suspension(seed = seed, hidden = hidden)
  before <- fit_model(tb, tb$A$runs, tb$iu, NULL)
  s_name <- paste0("s_", hidden)
  design <- tb$A$runs$design
  with_rng_seed(1, design[[s_name]] <- (sample(nrow(design)) - 0.5) / nrow(design))
  runs <- simulate_suspension(design, mechanism = hidden)
  iu_after <- iu_add(tb$iu, s_name, lower = 0, upper = 1, nominal = 0.5)
  after <- fit_model(tb, runs, iu_after, hidden)

  design_B <- tb$B$runs$design
  s_range <- stats::quantile(as.matrix(after$draws)[, s_name], c(0.005, 0.995))
  with_rng_seed(2, design_B[[s_name]] <- s_range[1] + diff(s_range) * (sample(nrow(design_B)) - 0.5) /
                  nrow(design_B))
  runs_B <- simulate_suspension(design_B, mechanism = hidden)
  p_before <- suppressWarnings(stats::predict(before, type = "new_nominal", new_runs = tb$B$runs,
                                              x_nom = tb$B$x_nom, seed = 1))
  p_after <- suppressWarnings(stats::predict(after, type = "new_nominal", new_runs = runs_B, x_nom = tb$B$x_nom,
                                             seed = 1))
  ref_B <- if (holdout_again) {
    list(before = testbed_run_at(tb, before, NULL), after = testbed_run_at(tb, after, hidden))
  } else {
    list(before = tb$B$runs, after = runs_B)
  }
  reg_B <- function(ref) testbed_register(tb, ref, condition = "B", refine = refine)
  holdout <- list(field = list(before = reg_B(ref_B$before), after = reg_B(ref_B$after)), before = p_before,
                  after = p_after)
  list(tb = tb, before = before, after = after, comparison = compare_validations(before, after, holdout = holdout))
}

# One run of the model of `fit` (with `mechanism`) at its posterior mean
# calibration inputs and condition B's nominal variation inputs.
testbed_run_at <- function(tb, fit, mechanism) {
  z <- stats::coef(fit)
  z[names(tb$B$x_nom)] <- tb$B$x_nom
  simulate_suspension(as.data.frame(as.list(z)), mechanism = mechanism)
}

#' @rdname testbed_protocol
#' @export
testbed_beds <- function() {
  list(
    suspension = list(make = testbed_suspension, simulate = simulate_suspension, mechanisms = testbed_mechanisms,
                      signatures = testbed_signatures, features = c("min", "max")),
    dosing = list(make = testbed_dosing, simulate = simulate_dosing, mechanisms = dosing_mechanisms,
                  signatures = dosing_signatures, features = "rise")
  )
}

#' @rdname testbed_protocol
#' @export
testbed_default_fit <- function(tb, features, n_draws = 150L, n_inner = 20L, ...) {
  suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, features = features,
                            sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, quiet = TRUE),
                            chains = 1, seed = 1, ...))
}

#' @rdname testbed_protocol
#' @export
testbed_default_refits <- function(tb, fit, simulate, mechanisms, n_draws = 150L, n_inner = 20L, engine = NULL,
                                   off_runs = TRUE) {
  old <- options(wavevalid.quiet = TRUE)
  on.exit(options(old), add = TRUE)
  fits <- lapply(mechanisms, function(m) {
    s_name <- paste0("s_", m)
    iu_m <- iu_add(tb$iu, s_name, lower = 0, upper = 1, nominal = 0.5)
    runs <- simulate(design_maximin(iu_m, 66L, seed = 2), mechanism = m)
    if (off_runs) {
      off <- tb$A$runs$design
      off[[s_name]] <- 0
      runs <- c(model_runs(off, tb$A$runs$curves, tb$A$runs$t), runs)
    }
    em <- suppressWarnings(if (is.null(engine)) fit_emulators(runs, fit$basis) else
      fit_emulators(runs, fit$basis, engine = engine))
    suppressWarnings(calibrate(em, fit$field, iu_m, chains = 1, seed = 1,
                               bias = bias_control(pool_levels = fit$settings$pool_levels),
                               sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, quiet = TRUE)))
  })
  stats::setNames(fits, mechanisms)
}

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
