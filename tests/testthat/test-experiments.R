# Several experiments of one unit, calibrated jointly.

# The small two-input problem (u1 calibration, x1 variation) with a second
# experiment whose x1 is raised by `change`: the sampler's spec with R
# replicates per experiment, field variances sigma2, bias variances shared by
# level across the experiments.
sbc_two_experiments <- function(R = 2, sigma2 = 4, change = 0.2, bias = "own") {
  pb <- small_problem(two_inputs = TRUE)
  n <- length(pb$basis$index)
  blank <- field_from_coef(pb$basis, matrix(0, R, n))
  ex <- list(second = experiment(blank, change = c(x1 = change)))
  spec <- calibration_spec(pb$emulators, blank, pb$iu, sigma2 = sigma2)
  ex <- check_experiments(ex, pb$emulators, blank, spec$x_nom)
  spec <- add_experiments(spec, ex, pb$emulators, pb$iu, NULL, FALSE, "shared", bias)
  spec$sites[["second/site1"]]$sigma2 <- rep(sigma2, n)
  list(pb = pb, n = n, spec = spec, G = nrow(spec$groups), bank = pb$emulators$banks$site1)
}

# SBC: inputs from their prior, model and bias coefficients of both
# experiments from the model, field means from the truth; ranks of u1, x1, a
# bias coefficient of each experiment, a model coefficient of the second, and
# of a test quantity that depends on the data (Modrak et al., 2023): the log
# likelihood of the second experiment's field means at the inputs. tau2 and
# sigma2 known. `bias` is the sampler's ("own": one per experiment, "shared"),
# `data_bias` the truth's (by default the same). debug_break 5 drops the second experiment's likelihood from
# the inputs' target: the draws are then the posterior given the first
# experiment alone, whose ranks of the inputs stay uniform, but at which the
# second experiment's data are less likely than at the truth.
sbc_experiment_pvalues <- function(reps, debug_break = 0L, n_draws = 49L, n_inner = 10L, tau2 = 0.05,
                                   sd_eps = 1, R = 2, bias = "own", data_bias = bias) {
  s <- sbc_two_experiments(R, sd_eps^2, bias = bias)
  n <- s$n
  spec <- s$spec
  sh <- spec$sites[["second/site1"]]$shift
  L <- n_draws
  ranks <- matrix(NA_integer_, reps, 6,
                  dimnames = list(NULL, c("u1", "x1", "wb1", "wb1_second", "wM2_second", "loglik_second")))
  e <- tau2 + sd_eps^2 / R
  # (with a shared bias, of the second experiment's field means given the
  # first's bias draw is not a function of the inputs alone: the test
  # quantity then takes the marginal of each experiment on its own, which is
  # still a fixed function of the inputs and the data)
  loglik2 <- function(Z, wbar) {
    pr <- gasp_bank_predict_cpp(s$bank, sweep(Z, 2L, sh, `+`))
    tot <- pr$var + e
    -0.5 * rowSums(log(tot) + sweep(pr$mean, 2L, wbar)^2 / tot)
  }
  for (r in seq_len(reps)) {
    z <- iu_prior_draws(s$pb$iu, 1L)[1, ]
    wbar <- list()
    truth <- list()
    for (k in 1:2) {
      pr <- gasp_bank_predict_cpp(s$bank, matrix(z + if (k == 2) sh else 0, 1))
      wM <- stats::rnorm(n, pr$mean, sqrt(pr$var))
      wb <- if (k == 2 && data_bias == "shared") truth[[1]]$wb else stats::rnorm(n, 0, sqrt(tau2))
      wbar[[k]] <- wM + wb + stats::rnorm(n, 0, sd_eps / sqrt(R))
      truth[[k]] <- list(wM = wM, wb = wb)
    }
    spec$sites$site1$wbar <- wbar[[1]]
    spec$sites[["second/site1"]]$wbar <- wbar[[2]]
    out <- calibrate_chain_cpp(spec$sites, spec$priors, list(
      n_groups = s$G, z_init = c(0.5, 0.5), tau2_init = rep(tau2, s$G), fix_tau2 = TRUE, n_draws = n_draws,
      n_inner = n_inner, step = 0.5, seed = r, chain = 1L, debug_break = debug_break,
      adaptive = TRUE, burnin = 300L, p_indep = 0.5, n_search = 20L))
    ranks[r, ] <- c(sum(out$inputs[, 1] < z[1]), sum(out$inputs[, 2] < z[2]),
                    sum(out$wb[[1]][, 1] < truth[[1]]$wb[1]), sum(out$wb[[2]][, 1] < truth[[2]]$wb[1]),
                    sum(out$wM[[2]][, 2] < truth[[2]]$wM[2]),
                    sum(loglik2(out$inputs, wbar[[2]]) < loglik2(matrix(z, 1), wbar[[2]])))
  }
  sbc_rank_pvalues(ranks, L)
}

test_that("SBC with two experiments: ranks are uniform, and not when one experiment's likelihood is dropped", {
  withr::local_seed(20261127)
  p_ok <- sbc_experiment_pvalues(600)
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  withr::local_seed(20261127)
  p_broken <- sbc_experiment_pvalues(600, debug_break = 5L)
  expect_lt(p_broken[["loglik_second"]], 0.01)
})

test_that("SBC with two experiments sharing one bias: uniform, and not when the data have one bias each", {
  # a bias large against the noise, so that sharing it matters
  withr::local_seed(20261129)
  p_ok <- sbc_experiment_pvalues(600, bias = "shared", tau2 = 1, sd_eps = 0.3, n_inner = 30L)
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  withr::local_seed(20261129)
  p_wrong <- sbc_experiment_pvalues(600, bias = "shared", tau2 = 1, sd_eps = 0.3, n_inner = 30L, data_bias = "own")
  expect_lt(min(p_wrong), 0.01)
})

test_that("SBC with two experiments at full size", {
  skip_unless_slow()
  withr::local_seed(20261128)
  p_ok <- sbc_experiment_pvalues(3000)
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  p_shared <- sbc_experiment_pvalues(3000, bias = "shared", tau2 = 1, sd_eps = 0.3, n_inner = 30L)
  expect_true(all(p_shared > 0.01), label = paste(signif(p_shared, 3), collapse = ", "))
})

test_that("a second experiment: sites, shared level variances, bands and where_fails by experiment", {
  ex <- example_problem(1)
  field2 <- ex$field
  field2$curves$site1 <- field2$curves$site1[1:2, , drop = FALSE]
  exps <- list(loaded = experiment(field2, change = c(x1 = 0.1)))
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 3, experiments = exps,
                                    sampler = sampler_control(n_draws = 40, n_inner = 10, burnin = 300, n_search = 20, quiet = TRUE)))
  expect_identical(names(fit$wb), c("site1", "loaded/site1"))
  expect_identical(fit$experiments$experiment, c("base", "loaded"))
  expect_identical(unname(fit$shift[["loaded/site1"]]), c(0, 0.1))
  # one tau2 per level, shared: the second experiment adds no group
  base <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 3,
                                     sampler = sampler_control(n_draws = 40, n_inner = 10, burnin = 300, n_search = 20, quiet = TRUE)))
  expect_identical(fit$groups, base$groups)
  expect_identical(fit$bias_group[["loaded/site1"]], fit$bias_group$site1)
  own <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 3, experiments = exps,
                                    bias = bias_control(level_variances = "per_experiment"),
                                    sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 100, n_search = 5, quiet = TRUE)))
  expect_equal(nrow(own$groups), 2 * nrow(base$groups))
  expect_true(all(startsWith(own$bias_group[["loaded/site1"]], "loaded/")))
  # one bias shared by the experiments: the same bias draws at both sites
  shared <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 3,
                                       experiments = exps, bias = bias_control(experiment_bias = "shared"),
                                       sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 100, n_search = 5, quiet = TRUE)))
  expect_identical(shared$wb[["loaded/site1"]], shared$wb$site1)
  expect_false(identical(shared$wM[["loaded/site1"]], shared$wM$site1))
  expect_output(print(shared), "one bias shared by the experiments")
  # the second experiment's model coefficients follow the emulators at the changed inputs
  z <- colMeans(as.matrix(fit$draws)[, fit$inputs])
  m2 <- gasp_bank_predict_cpp(ex$emulators$banks$site1, matrix(z + c(0, 0.1), 1))$mean
  m1 <- gasp_bank_predict_cpp(ex$emulators$banks$site1, matrix(z, 1))$mean
  expect_equal(pure_model_curve(fit, "loaded/site1", z), drop(fit$basis$Psi %*% t(m2)))
  expect_equal(pure_model_curve(fit, "site1", z), drop(fit$basis$Psi %*% t(m1)))
  b <- bias(fit)
  expect_setequal(unique(b$site), c("site1", "loaded/site1"))
  wf <- where_fails(fit)
  expect_true(all(as.data.frame(wf)$site %in% c("site1", "loaded/site1")))
  expect_true(all(as.data.frame(wf)$experiment %in% c("base", "loaded")))
  expect_output(print(fit), "loaded: inputs changed by x1 \\+0.1; loaded/site1 2 replicates")
  expect_output(print(summary(fit)), "level variances shared")
  for (type in c("bias", "reality")) expect_silent(ggplot2::ggplot_build(autoplot(fit, type = type)))
  pr <- predict(fit, type = "reality")
  expect_setequal(unique(pr$summary$site), c("site1", "loaded/site1"))
  nv <- predict(fit, type = "new_vehicle")
  expect_identical(unique(nv$summary$site), "site1")
  cmp <- compare_validations(own, fit)
  expect_s3_class(cmp, "wv_comparison")
  # a signature per site of every experiment: the mechanism acts differently under another load
  sig <- sin(seq_along(ex$field$t) / 3)
  expect_error(explain_bias(fit, list(bump = list(site1 = sig)), n_draws = 50, seed = 1), class = "wavevalid_error")
  cand <- list(bump = list(site1 = sig, "loaded/site1" = 1.2 * sig))
  ex_b <- explain_bias(fit, cand, n_draws = 50, seed = 1)
  expect_true("bump" %in% as.data.frame(unclass(ex_b))$candidate)
})

test_that("experiments: classed errors before any sampling", {
  ex <- example_problem(1)
  expect_error(experiment(ex$field), class = "wavevalid_error_experiment")
  expect_error(experiment(ex$field, change = c(x1 = 0.1), emulators = ex$emulators),
               class = "wavevalid_error_experiment")
  expect_error(experiment(ex$field, change = 0.1), class = "wavevalid_error_experiment")
  expect_error(experiment(ex$field, change = c(x1 = NA)), class = "wavevalid_error_experiment")
  run <- function(exps, ...) calibrate(ex$emulators, ex$field, ex$iu, experiments = exps, bias = bias_control(...),
                                       sampler = sampler_control(n_draws = 5, n_inner = 2, quiet = TRUE), chains = 1,
                                       seed = 1)
  expect_error(run(experiment(ex$field, change = c(x1 = 0.1))), class = "wavevalid_error_experiment")
  expect_error(run(list(experiment(ex$field, change = c(x1 = 0.1)))), class = "wavevalid_error_experiment")
  expect_error(run(list(a = experiment(ex$field, change = c(x9 = 0.1)))), class = "wavevalid_error_experiment")
  expect_error(run(list(a = experiment(ex$field, change = c(x1 = 2)))), class = "wavevalid_error_experiment")
  expect_error(run(list(site1 = experiment(ex$field, change = c(x1 = 0.1)))), class = "wavevalid_error_experiment")
  other <- ex$field
  names(other$curves) <- "site9"
  expect_error(run(list(a = experiment(other, change = c(x1 = 0.1)))), class = "wavevalid_error_experiment")
  expect_error(run(list(a = experiment(ex$field, change = c(x1 = 0.1))), level_variances = "both"),
               class = "wavevalid_error")
  expect_error(run(list(a = experiment(ex$field, change = c(x1 = 0.1))), level_variances = "per_experiment",
                   experiment_bias = "shared"), class = "wavevalid_error_experiment")
  expect_output(print(experiment(ex$field, change = c(x1 = 0.1))), "changed by x1 \\+0.1")
})

test_that("the test bed's added mass takes replicates without changing the rest", {
  tb1 <- testbed_suspension(3)
  tb4 <- testbed_suspension(3, n_added_mass = 4)
  expect_identical(tb1$A, tb4$A)
  expect_identical(tb1$B, tb4$B)
  expect_identical(tb1$truth$u, tb4$truth$u)
  expect_identical(dim(tb4$added_mass$field$curves$site1), c(4L, length(tb4$A$field$t)))
  expect_identical(nrow(tb1$added_mass$field$curves$site1), 1L)
  expect_error(testbed_suspension(3, n_added_mass = 0), class = "wavevalid_error")
})

test_that("validate() registers an experiment without reference to the model with its change", {
  withr::local_seed(1)
  tb <- testbed_suspension(1, "none", n_added_mass = 2)
  dm <- tb$added_mass$delta
  exps <- list(added_mass = experiment(tb$added_mass$field, change = dm))
  msg <- expect_message(
    fit <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, chains = 1, seed = 1,
                                     experiments = exps,
                                     sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 200, n_search = 10))),
    class = "wavevalid_message")
  said <- function(m) gsub("\\s+", " ", conditionMessage(m))
  expect_match(said(msg), "\"added_mass\": the emulators at the runs' inputs changed by x1 +0.15", fixed = TRUE)
  expect_identical(names(fit$wb), c("site1", "site2", "added_mass/site1", "added_mass/site2"))
  expect_identical(dim(fit$field$curves[["added_mass/site1"]]), c(2L, length(tb$A$field$t)))
  expect_equal(unname(fit$shift[["added_mass/site2"]][["x1"]]), 0.15)
  # the basis comes from the runs and condition A's field alone
  knots <- diff(range(tb$A$field$t)) / 32
  field_A <- register_curves(tb$A$field, tb$A$runs, tb$windows, knots_every = knots, landmark_site = "all")
  expect_identical(fit$basis$index, wavelet_basis(tb$A$runs, field_A)$index)

  # registered as to the simulator's runs with the change, not as to condition A's runs
  d <- tb$A$runs$design
  d$x1 <- d$x1 + dm[["x1"]]
  true_runs <- simulate_suspension(d)
  to_true <- register_curves(tb$added_mass$field, true_runs, tb$windows, knots_every = knots, landmark_site = "all")
  to_base <- register_curves(tb$added_mass$field, tb$A$runs, tb$windows, knots_every = knots, landmark_site = "all")
  rms <- function(a, b) sqrt(mean((a - b)^2))
  reg <- fit$field$curves[["added_mass/site1"]]
  expect_lt(rms(reg, to_true$curves$site1), 0.005)
  expect_gt(rms(to_base$curves$site1, to_true$curves$site1), 5 * rms(reg, to_true$curves$site1))
  again <- register_experiments(exps, fit$emulators, tb$A$runs, tb$windows, knots_every = knots,
                                landmark_site = "all", quiet = TRUE)$added_mass$field
  expect_equal(again$curves$site1, reg)
  # the landmarks and the warp knots between them
  expect_identical(again$warps$t_after, to_true$warps$t_after)
  knot_dt <- function(x) max(abs(x$warps$t_before - to_true$warps$t_before))
  expect_lt(knot_dt(again), 0.02)
  expect_gt(knot_dt(to_base), 5 * knot_dt(again))

  # the reference the user gives is used as given
  given <- list(added_mass = experiment(tb$added_mass$field, change = dm, reference = true_runs))
  expect_identical(register_experiments(given, fit$emulators, tb$A$runs, tb$windows,
                                        knots_every = knots, landmark_site = "all",
                                        quiet = TRUE)$added_mass$field, to_true)
  msg <- expect_message(register_experiments(given, fit$emulators, tb$A$runs, tb$windows,
                                             knots_every = knots), class = "wavevalid_message")
  expect_match(said(msg), "\"added_mass\": its reference (66 runs)", fixed = TRUE)
  # an experiment with emulators of its own: their prediction at their design
  sub <- model_runs(true_runs$design[1:30, ], lapply(true_runs$curves, function(m) m[1:30, ]), true_runs$t)
  em_own <- withr::with_options(list(wavevalid.quiet = TRUE), suppressWarnings(fit_emulators(sub, fit$basis)))
  ref_own <- experiment_reference(experiment(tb$added_mass$field, emulators = em_own), fit$emulators,
                                  tb$A$runs)
  expect_identical(ref_own$design, as.data.frame(em_own$design))
  expect_lt(rms(colMeans(ref_own$curves$site1), colMeans(sub$curves$site1)), 0.05)
  expect_gt(rms(colMeans(tb$A$runs$curves$site1), colMeans(sub$curves$site1)), 0.2)
})

test_that("the report shows each experiment", {
  skip_if_not(rmarkdown::pandoc_available())
  ex <- example_problem(1)
  loaded <- ex$field
  loaded$curves$site1 <- loaded$curves$site1 + 0.02
  exps <- list(loaded = experiment(loaded, change = c(x1 = 0.1)))
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 3, experiments = exps,
                                    sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 100, n_search = 5, quiet = TRUE)))
  out <- withr::local_tempfile(fileext = ".html")
  suppressWarnings(suppressMessages(validation_report(fit, file = out, quiet = TRUE)))
  html <- paste(readLines(out, warn = FALSE), collapse = "\n")
  expect_match(html, "Experiments</h2>", fixed = TRUE)
  expect_match(html, "loaded: inputs changed by x1 +0.1", fixed = TRUE)
})

test_that("an experiment's sites evaluate the base site's emulators from one copy, with the same draws", {
  s <- sbc_two_experiments()
  spec <- s$spec
  withr::local_seed(3)
  spec$sites$site1$wbar <- stats::rnorm(s$n)
  spec$sites[["second/site1"]]$wbar <- stats::rnorm(s$n)
  run <- function(sites) {
    calibrate_chain_cpp(sites, spec$priors, list(
      n_groups = s$G, z_init = c(0.5, 0.5), tau2_init = rep(0.05, s$G), fix_tau2 = TRUE, n_draws = 30L,
      n_inner = 5L, step = 0.5, seed = 4, chain = 1L, debug_break = 0L, adaptive = TRUE, burnin = 100L,
      p_indep = 0.5, n_search = 10L))
  }
  shared <- shared_banks(spec$sites)
  expect_null(shared[["second/site1"]][["bank"]])
  expect_identical(shared[["second/site1"]][["bank_of"]], 0L)
  expect_lt(length(serialize(shared, NULL)), 0.75 * length(serialize(spec$sites, NULL)))
  a <- run(spec$sites)
  b <- run(shared)
  expect_identical(b$inputs, a$inputs)
  expect_identical(b$wb, a$wb)
  expect_identical(b$wM, a$wM)
  # a bank_of that does not name an earlier site with its own bank is refused
  bad <- shared
  bad[["second/site1"]][["bank_of"]] <- 1L
  expect_error(run(bad), "bank_of")
})

test_that("an experiment holding the base field's own curves is refused before any fit: the data would count twice", {
  ex <- example_problem()
  dup <- list(again = experiment(ex$field, change = c(x1 = 0.1)))
  expect_error(calibrate(ex$emulators, ex$field, ex$iu, experiments = dup), class = "wavevalid_error_experiment")
  expect_error(calibrate(ex$emulators, ex$field, ex$iu, experiments = dup), "counted twice")
  runs <- model_runs(as.data.frame(ex$emulators$design), ex$emulators$banks$site1$y %*% t(ex$emulators$basis$Psi),
                     ex$field$t, site = "site1")
  expect_error(validate(runs, ex$field, ex$iu, experiments = dup), class = "wavevalid_error_experiment")
  # other replicates of the same condition are new data
  other <- ex$field
  other$curves$site1 <- other$curves$site1[1:2, , drop = FALSE] + 0.01
  expect_silent(check_not_base_data(list(more = experiment(other, change = c(x1 = 0.1))), ex$field))
})
