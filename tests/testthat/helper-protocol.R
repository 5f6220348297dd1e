# The diagnosis protocol on the test beds: how the diagnosis tests and the
# studies (studies/, sourced from the package's root by studies/common.R)
# validate a model on the suspension test bed (testbed_suspension()),
# re-validate it with each candidate mechanism, and judge the diagnosis:
# where the model fails (where_fails()), which effect is missing
# (explain_bias()) and whether adding it fixes the model
# (compare_validations()). The test bed's truth is known, so each verdict
# says whether the diagnosis found it. It calls only the package's exported
# functions, so that a study can source it after library(wavevalid):
#   source("tests/testthat/helper-protocol.R")
#
# The protocol's choices (the method's own, not the package's defaults):
# * the report's wavelet basis (wavelet_basis(retain = "report"));
# * one Gaussian process emulator per retained coefficient
#   (fit_emulators(engine = "gasp"): testbed_emulators());
# * one short chain, 150 draws of 20 cycles with seed 1, its warnings (the
#   chain is short) muffled (testbed_calibrate());
# * the method's likelihood of the inputs, which takes the coefficients as
#   independent (calibrate(input_likelihood = "independent"));
# * the field registered to the mean of the model runs, with further knots
#   every 2 time units, on the load's minimum and maximum in each event
#   window; on the maximum alone when the tire lift-off is hidden, whose
#   minimum is flat (testbed_register()).
# The diagnosis tests' figures and the studies' findings were measured with
# these choices. The package's defaults gave other answers on the same test
# beds (studies/README.md); testbed_default_fit() and
# testbed_default_refits() run the package's defaults instead.
#
# The steps:
# * testbed_validation(hidden, seed) validates the model without any
#   mechanism on condition A: the field registered to the runs, the report's
#   basis, the protocol's emulators and chain. A list of tb, field, basis,
#   emulators and fit.
# * testbed_revalidation(tb, fit) re-validates the model of a fit with each
#   mechanism in turn: its strength s_<m> a calibration input on [0, 1], the
#   model with it simulated at an n_runs-point maximin design, the emulators
#   on the fit's basis, calibrated on the fit's field with its bias pooling
#   (pool_levels) and field variance (registration_variance). With
#   n_check > 0 the emulators are rescaled (rescale_emulators()) on that many
#   held-out runs of the model with the mechanism (testbed_check_runs()).
#   A list of fits named by mechanism, for explain_bias().
# * testbed_first_pass() and testbed_two_pass() re-register: the field
#   registered to the model's runs (start = "runs") or to the replicates'
#   own pointwise mean ("replicates"), the basis and emulators (rescaled on
#   the held-out runs `check` unless NULL), calibrated with levels
#   pool_levels pooled; then, passes - 1 times, the field registered again
#   to one run of the model at the posterior mean inputs of the last fit
#   (coef()) and calibrated again on the same emulators. Each chain's start
#   is searched among n_search draws from the prior. testbed_first_pass()
#   gives a list of field, basis, emulators and fit; testbed_two_pass() a
#   list of first (the first pass), fits (every pass's fit) and fit, the
#   last.
# * testbed_loop() runs the whole loop of criterion 3 below: a list of tb,
#   before, after and comparison.
# * testbed_beds(), testbed_default_fit() and testbed_default_refits() run
#   the package's defaults on either test bed: validate() with its defaults
#   on condition A, and the model re-validated with each mechanism (66 runs
#   of the model with it at a maximin design, joined by the model's own runs
#   with the strength at 0 unless off_runs = FALSE, the default emulators
#   unless `engine` is given). testbed_beds() is a list by test bed
#   (suspension, dosing) of its constructor `make`, simulator `simulate`,
#   `mechanisms` and `signatures` functions, and the `features` that mark
#   when its events happen (the suspension's load extremes at the road
#   events; a dose's rise).
#
# Reading the verdicts:
# Criterion 1, where (testbed_where_verdict()), from a where_fails() table
# of a fit with mechanism `hidden` hidden and that mechanism's signature
# `effect` at the true inputs (one element of testbed_signatures()). With
# nothing hidden the case passes (where_ok and localised) when no flagged
# interval is longer than max_steps grid steps. Otherwise where_ok asks that
# more than 20% of the points where the mechanism acts be flagged at every
# site (recall, flagged_share()), and localised adds that the flags lie
# where it acts: their precision (the share of the flagged points where it
# acts) exceeds the rate of flags thrown at random (base, the share of the
# grid where it acts) by at least that rate, or by half the room above it
# when the mechanism acts over more than a third of the grid. A list of
# longest (grid steps), recall, precision and base by site (NULL with
# nothing hidden), where_ok and localised.
#
# Criterion 2, which (testbed_explain_verdict()), from an explain_bias()
# table: with a mechanism hidden, ok when it is first among the mechanisms
# (the shift candidates aside) with an inclusion probability of 0.9 or more
# and every other mechanism is below 0.5; with nothing hidden, when no
# candidate (shifts included) reaches 0.5. top and top_prob name the leading
# candidate (among the mechanisms when one is hidden).
#
# Criterion 3, the loop (testbed_loop()): the model without the hidden
# mechanism (before) and the model with it (after, its strength a
# calibration input on [0, 1], its 66 runs at condition A's design with the
# strength spread over [0, 1]), each fitted by fit_model (NULL: the last fit
# of testbed_two_pass(); else a function (tb, runs, iu, mechanism) returning
# a wv_fit), compared by compare_validations() with condition B held out:
# new nominal inputs, the after-model's B runs spreading the strength over
# its 99% posterior interval, B's replicates registered to the mean of each
# model's B runs (or with holdout_again to one run of each model at its
# posterior mean calibration inputs and B's nominal variation inputs). The
# studies count a case as passing when adding the mechanism cuts bias_rms by
# more than 70% and the held-out error falls.

# Bad input stops with the package's error classes.
protocol_abort <- function(message, .envir = parent.frame()) {
  cli::cli_abort(message, class = c("wavevalid_error_input", "wavevalid_error"), call = NULL, .envir = .envir)
}

protocol_check_class <- function(x, class, arg = deparse(substitute(x))) {
  if (!inherits(x, class)) {
    protocol_abort("{.arg {arg}} must be a {.cls {class}} object, not {.obj_type_friendly {x}}.")
  }
  invisible(x)
}

# Evaluates code with R's RNG (default kinds) seeded by seed, restoring the
# caller's RNG state and kind (the seeding of the package's with_rng_seed(), through withr).
protocol_with_seed <- function(seed, code) {
  withr::with_seed(seed, code, .rng_kind = "Mersenne-Twister", .rng_normal_kind = "Inversion",
                   .rng_sample_kind = "Rejection")
}

# The emulators' engine of the protocol: the report's per-coefficient fit.
testbed_engine <- "gasp"

testbed_register <- function(tb, reference, condition = "A", refine = FALSE) {
  features <- if (identical(tb$truth$hidden, "tire_liftoff")) "max" else c("min", "max")
  register_curves(tb[[condition]]$field, reference, tb$windows, features = features, knots_every = 2,
                  refine = refine)
}

testbed_emulators <- function(runs, basis) {
  suppressWarnings(fit_emulators(runs, basis, engine = testbed_engine))
}

testbed_calibrate <- function(emulators, field, iu, pool_levels = NULL, n_draws = 150L, n_inner = 20L,
                              registration_variance = FALSE, n_search = 200L) {
  suppressWarnings(calibrate(emulators, field, iu, chains = 1, seed = 1,
                             bias = bias_control(pool_levels = pool_levels, registration_variance = registration_variance,
                                                 input_likelihood = "independent"),
                             sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, n_search = n_search, quiet = TRUE)))
}

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

testbed_check_runs <- function(iu, mechanism = NULL, n = 30L) {
  simulate_suspension(design_maximin(iu, n, nominal = FALSE, seed = 9), mechanism = mechanism)
}

testbed_where_verdict <- function(fails, hidden, effect = NULL, max_steps = 3) {
  protocol_check_class(fails, "wv_fails")
  t <- attr(fails, "bias")$t
  iv <- if (is.null(fails$kind)) fails else fails[fails$kind %in% "interval", , drop = FALSE]
  longest <- if (nrow(iv)) round(max(iv$end - iv$start) / (t[2] - t[1])) else 0
  if (identical(hidden, "none")) {
    ok <- longest <= max_steps
    return(list(longest = longest, recall = NULL, precision = NULL, base = NULL, where_ok = ok, localised = ok))
  }
  if (is.null(effect)) protocol_abort("A hidden mechanism needs its {.arg effect} to judge the flags.")
  recall <- flagged_share(fails, effect)
  precision <- flagged_share(fails, effect, of = "flags")
  base <- attr(precision, "acting")
  precision <- c(precision)
  precision[is.na(precision)] <- 0
  where_ok <- all(recall > 0.2)
  list(longest = longest, recall = c(recall), precision = precision, base = base, where_ok = where_ok,
       localised = where_ok && all(precision - base > pmin(base, (1 - base) / 2)))
}

testbed_explain_verdict <- function(ex, hidden) {
  protocol_check_class(ex, "wv_explain")
  ex <- as.data.frame(unclass(ex))
  if (identical(hidden, "none")) {
    return(list(top = ex$candidate[1], top_prob = ex$inclusion_prob[1], ok = all(ex$inclusion_prob < 0.5)))
  }
  mech <- ex[!startsWith(ex$candidate, "shift:"), , drop = FALSE]
  if (!hidden %in% mech$candidate) {
    protocol_abort("{.val {hidden}} is not among the candidates {.val {mech$candidate}}.")
  }
  p <- mech$inclusion_prob[mech$candidate == hidden]
  list(top = mech$candidate[1], top_prob = mech$inclusion_prob[1],
       ok = mech$candidate[1] == hidden && p >= 0.9 && all(mech$inclusion_prob[mech$candidate != hidden] < 0.5))
}

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
  protocol_with_seed(1, design[[s_name]] <- (sample(nrow(design)) - 0.5) / nrow(design))
  runs <- simulate_suspension(design, mechanism = hidden)
  iu_after <- iu_add(tb$iu, s_name, lower = 0, upper = 1, nominal = 0.5)
  after <- fit_model(tb, runs, iu_after, hidden)

  design_B <- tb$B$runs$design
  s_range <- stats::quantile(as.matrix(after$draws)[, s_name], c(0.005, 0.995))
  protocol_with_seed(2, design_B[[s_name]] <- s_range[1] + diff(s_range) * (sample(nrow(design_B)) - 0.5) /
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

testbed_beds <- function() {
  list(
    suspension = list(make = testbed_suspension, simulate = simulate_suspension, mechanisms = testbed_mechanisms,
                      signatures = testbed_signatures, features = c("min", "max")),
    dosing = list(make = testbed_dosing, simulate = simulate_dosing, mechanisms = dosing_mechanisms,
                  signatures = dosing_signatures, features = "rise")
  )
}

testbed_default_fit <- function(tb, features, n_draws = 150L, n_inner = 20L, ...) {
  suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, features = features,
                            sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, quiet = TRUE),
                            chains = 1, seed = 1, ...))
}

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
