# Test conditions: inputs of type "condition", known for each experiment.

cond_iu <- function() {
  iu_map(c("u1", "x1"), c("calibration", "condition"), lower = c(0, 0), upper = c(1, 1), nominal = c(0.5, 0.5))
}

cond_sampler <- function() sampler_control(n_draws = 60, n_inner = 10, burnin = 300, n_search = 20, quiet = TRUE)

# example_problem() with x1 a condition: the base experiment at 0.5, a
# second one (two replicates) at 0.7.
cond_fit <- function(bias = bias_control(), seed = 3) {
  ex <- example_problem(1)
  f2 <- ex$field
  f2$curves$site1 <- f2$curves$site1[1:2, , drop = FALSE]
  exps <- list(hot = experiment(f2, condition = c(x1 = 0.7)))
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, cond_iu(), experiments = exps, bias = bias,
                                    chains = 1, seed = seed, sampler = cond_sampler()))
  list(ex = ex, f2 = f2, fit = fit)
}

test_that("a condition input has no prior, prints as a condition and keeps its design range", {
  iu <- cond_iu()
  expect_identical(iu$type, c("calibration", "condition"))
  expect_identical(iu$prior, c("uniform", "none"))
  expect_true(is.na(iu$prior_sd[2]) && is.na(iu$prior_mean[2]))
  expect_output(print(iu), "1 condition")
  expect_output(print(iu), "none \\(a condition, known\\), design \\[0, 1\\]")
  expect_output(print(summary(iu)), "condition:   x1")
  # a prior asked of a condition is dropped; its draws are its nominal
  iu2 <- iu_add(iu_map("u1", "calibration", 0, 1), "temp", type = "condition", lower = 280, upper = 320,
                nominal = 300)
  expect_identical(iu2$prior[2], "none")
  withr::local_seed(1)
  expect_true(all(iu_prior_sample(iu2, 50)[, "temp"] == 300))
  expect_error(iu_map("a", "conditon", 0, 1), class = "wavevalid_error")
  # the map without conditions prints as before
  expect_false(any(grepl("condition", capture.output(print(example_problem()$iu)))))
})

test_that("coef() gives the estimated inputs and the conditions apart, at their known values", {
  fit <- cond_fit()$fit
  z <- coef(fit)
  expect_identical(names(z), "u1")
  expect_identical(attr(z, "conditions"), c(x1 = 0.5))
  expect_equal(z[["u1"]], mean(as.matrix(fit$draws)[, "u1"]))
})

test_that("the condition path gives the same draws as experiment(change =) with the input held", {
  s <- cond_fit()
  ex <- s$ex
  held <- iu_hold(ex$iu, c(x1 = 0.5))
  # the change the condition stands for, computed as the condition path does
  exps <- list(hot = experiment(s$f2, change = c(x1 = 0.7 - 0.5)))
  ref <- suppressWarnings(calibrate(ex$emulators, ex$field, held, experiments = exps, chains = 1, seed = 3,
                                    sampler = cond_sampler()))
  expect_identical(as.matrix(s$fit$draws), as.matrix(ref$draws))
  expect_identical(s$fit$wb, ref$wb)
  expect_identical(s$fit$wM, ref$wM)
  expect_identical(s$fit$sigma2, ref$sigma2)
  # the condition is held at the base value; the fit keeps the I/U map with the condition
  expect_true(all(abs(as.matrix(s$fit$draws)[, "x1"] - 0.5) < 1e-6))
  expect_identical(s$fit$iu$type[2], "condition")
  expect_equal(s$fit$conditions$values, data.frame(experiment = c("base", "hot"), x1 = c(0.5, 0.7)))
  expect_output(print(s$fit), "hot: x1 = 0.7")
  # a condition is known, not estimated: no row among the inputs, its values in the priors' line
  printed <- capture.output(print(s$fit))
  expect_false(any(grepl("^\\s*x1\\s+condition", printed)))
  expect_identical(summary(s$fit)$inputs$input, "u1")
  expect_identical(report_inputs_table(s$fit)$input, "u1")
  expect_output(print(s$fit), "none: a condition, known")
  expect_false(any(boundary_check_flags <- s$fit$flags$boundary$input == "x1"))
  # a condition has no prior: the conflicts table names it a condition, with no distance and no conflict
  cf <- input_conflicts(s$fit)
  expect_identical(cf$type[cf$input == "x1"], "condition")
  expect_true(is.na(cf$prior_sds[cf$input == "x1"]) && is.na(cf$prior_sd[cf$input == "x1"]))
  expect_false(cf$conflict[cf$input == "x1"])
  expect_identical(cf$type[cf$input == "u1"], "calibration")
})

test_that("bad conditions are classed errors naming the fix", {
  ex <- example_problem(1)
  iu <- cond_iu()
  run <- function(exps, iu_use = iu) {
    calibrate(ex$emulators, ex$field, iu_use, experiments = exps, chains = 1, seed = 1, sampler = cond_sampler())
  }
  cls <- "wavevalid_error_condition"
  expect_error(experiment(ex$field, condition = 0.7), class = cls)
  expect_error(experiment(ex$field, condition = c(x1 = NA)), class = cls)
  expect_error(experiment(ex$field, condition = c(x1 = 0.7), emulators = ex$emulators), class = cls)
  # missing for an experiment, outside the design range, set by a change, not a condition
  expect_error(run(list(a = experiment(ex$field, change = c(x1 = 0.1)))), class = cls)
  expect_error(run(list(a = experiment(ex$field, condition = c(x1 = 1.2)))), "outside the design range",
               class = cls)
  expect_error(run(list(a = experiment(ex$field, condition = c(x1 = 0.7), change = c(x1 = 0.1)))),
               "sets condition input", class = cls)
  expect_error(run(list(a = experiment(ex$field, condition = c(u1 = 0.7, x1 = 0.7)))), "not a condition",
               class = cls)
  expect_error(run(list(a = experiment(ex$field, condition = c(x1 = 0.7))), ex$iu), "no condition input",
               class = cls)
  expect_error(run(list(a = experiment(ex$field, emulators = ex$emulators))), class = cls)
  expect_snapshot(run(list(a = experiment(ex$field, condition = c(x1 = 1.2)))), error = TRUE)
})

test_that("a new condition: a tested one is that experiment's prediction, an untested one moves the model", {
  s <- cond_fit()
  fit <- s$fit
  r <- predict(fit, type = "reality", residual = FALSE, seed = 1)
  for (case in list(c(x1 = 0.5, site = "site1"), c(x1 = 0.7, site = "hot/site1"))) {
    p <- predict(fit, type = "new_condition", condition = c(x1 = as.numeric(case[["x1"]])), noise = FALSE, seed = 1)
    a <- r$summary[r$summary$site == case[["site"]], ]
    expect_equal(p$summary$mean, a$mean)
    expect_equal(p$summary$lower, a$lower)
    expect_equal(p$summary$upper_curve, a$upper_curve)
    expect_equal(p$summary$model, a$model)
    expect_identical(p$bias_from, "tested")
    expect_identical(unique(p$summary$site), "site1")
  }
  # untested: the model moved by the emulators' change, the biases pooled
  p <- predict(fit, type = "new_condition", condition = c(x1 = 0.6), noise = FALSE, seed = 1)
  expect_identical(p$bias_from, "pooled")
  expect_true(is.na(p$tested))
  z <- colMeans(as.matrix(fit$draws)[, fit$inputs])
  m <- gasp_bank_predict_cpp(fit$emulators$banks$site1, matrix(z + c(0, 0.1), 1))$mean
  expect_equal(p$summary$model, drop(fit$basis$Psi %*% t(m)))
  expect_true(all(p$summary$model_lower <= p$summary$model_upper))
  expect_output(print(p), "untested, the tested conditions' biases pooled")
  # each draw's bias is the same draw's bias of one tested condition, in equal shares, its deviation
  # from the conditions' mean widened by sqrt((J + 1) / (J - 1)) = sqrt(3) as a new member's
  set <- withr::with_seed(2, new_condition_setup(fit, c(x1 = 0.6)))
  B <- set$sites$site1$B
  centre <- (fit$wb$site1 + fit$wb[["hot/site1"]]) / 2
  near <- function(A) rowSums(abs(B - A)) < 1e-12 * (1 + rowSums(abs(A)))
  from_base <- near(centre + sqrt(3) * (fit$wb$site1 - centre))
  from_hot <- near(centre + sqrt(3) * (fit$wb[["hot/site1"]] - centre))
  expect_true(all(from_base | from_hot))
  expect_equal(sum(from_base), nrow(B) / 2)
  # the model's draws at the new condition: the emulators conditioned on each draw's value at the base
  # condition, so that at the base condition itself they are those values, and elsewhere they vary
  # about the emulators' conditional mean
  post <- as.matrix(fit$draws)[, fit$inputs]
  same <- withr::with_seed(1, moved_model_draws(fit, "site1", post, c(x1 = 0)))
  expect_equal(same, fit$wM$site1, tolerance = 1e-6)
  moved <- withr::with_seed(1, moved_model_draws(fit, "site1", post, c(x1 = 0.1)))
  aug <- gasp_bank_predict_augmented_cpp(fit$emulators$banks$site1, post, fit$wM$site1,
                                         sweep(post, 2, c(0, 0.1), `+`))
  expect_gt(min(aug$var[, 1]), 0)
  expect_equal(mean((moved - aug$mean)^2 / aug$var), 1, tolerance = 0.1)
  # one bias shared by the experiments: carried as it is
  sh <- cond_fit(bias_control(experiment_bias = "shared"))$fit
  set <- withr::with_seed(2, new_condition_setup(sh, c(x1 = 0.6)))
  expect_identical(set$bias_from, "shared")
  expect_identical(set$sites$site1$B, sh$wb$site1)
  # same seed, same bands
  expect_identical(predict(fit, type = "new_condition", condition = c(x1 = 0.6), seed = 5)$summary,
                   predict(fit, type = "new_condition", condition = c(x1 = 0.6), seed = 5)$summary)
})

test_that("predicting a new condition checks its input", {
  fit <- cond_fit()$fit
  cls <- "wavevalid_error_condition"
  expect_error(predict(fit, type = "new_condition"), class = cls)
  expect_error(predict(fit, type = "new_condition", condition = c(x1 = 2)), class = cls)
  expect_error(predict(fit, type = "new_condition", condition = c(x2 = 0.5)), class = cls)
  expect_error(predict(fit, type = "reality", condition = c(x1 = 0.5)), class = cls)
  expect_error(predict(example_fit(), type = "new_condition", condition = c(x1 = 0.5)), "no condition input",
               class = cls)
})

test_that("experiments_at() makes experiments from lists of fields and from long data", {
  ex <- example_problem(1)
  e <- experiments_at(list(a = ex$field, b = ex$field), data.frame(x1 = c(0.3, 0.7)))
  expect_identical(names(e), c("a", "b"))
  expect_identical(e$b$condition, c(x1 = 0.7))
  long <- expand.grid(t = 0:15, replicate = 1:2, dose = c(250, 550))
  long$y <- long$dose / 400 * exp(-long$t / 2)
  e <- experiments_at(long, "dose", t = "t", y = "y", replicate = "replicate")
  expect_identical(names(e), c("dose=250", "dose=550"))
  expect_identical(e[["dose=550"]]$condition, c(dose = 550))
  expect_equal(e[["dose=550"]]$field$curves$site1[1, ], 550 / 400 * exp(-(0:15) / 2))
  expect_error(experiments_at(list(a = ex$field), data.frame(x1 = c(0.3, 0.7))), class = "wavevalid_error_condition")
  expect_error(experiments_at(long, "mass", t = "t", y = "y"), class = "wavevalid_error_condition")
  expect_output(print(e[[1]]), "at the condition dose = 250")
})

test_that("where_fails() names each finding's condition; a held-out condition is judged", {
  s <- cond_fit()
  w <- where_fails(s$fit)
  expect_true(all(w$condition[w$experiment == "hot"] == "x1 = 0.7"))
  expect_true(all(w$condition[w$experiment == "base"] == "x1 = 0.5"))
  ho <- experiment(s$ex$field, condition = c(x1 = 0.6))
  cmp <- compare_validations(s$fit, s$fit, holdout = ho, n_boot = 200, seed = 1)
  hr <- attr(cmp, "holdout_ratio")
  expect_equal(hr$ratio, c(1, 1))
  # the held-out prediction is the new condition's
  p <- predict(s$fit, type = "new_condition", condition = c(x1 = 0.6), seed = 1)
  err <- sweep(s$ex$field$curves$site1, 2L, p$summary$mean)
  expect_equal(cmp$before[cmp$metric == "holdout_rmse"], sqrt(mean(err^2)))
})

test_that("the dosing model takes the dose amount; testbed_dosing(doses =) adds the amounts", {
  r <- simulate_dosing(data.frame(dose = c(400, 200)))
  # without the mechanisms the model is linear in the dose
  expect_equal(r$curves$plasma[2, ], r$curves$plasma[1, ] / 2, tolerance = 1e-8)
  expect_equal(simulate_dosing(data.frame(u1 = 0.4))$curves, simulate_dosing(data.frame(u1 = 0.4, dose = 400))$curves)
  expect_error(simulate_dosing(data.frame(dose = -1)), "must be positive")
  tb0 <- testbed_dosing(2)
  tb <- testbed_dosing(2, doses = c(250, 550), n_dose_runs = 12)
  expect_identical(tb$A, tb0$A)
  expect_identical(tb$truth, tb0$truth)
  expect_identical(names(tb$doses$fields), c("dose_250", "dose_550"))
  expect_identical(tb$doses$iu$type[tb$doses$iu$name == "dose"], "condition")
  expect_identical(names(tb$doses$runs$design), tb$doses$iu$name)
  # reality at 250 mg is reality at 400 mg scaled, the model being linear with nothing hidden
  expect_equal(tb$doses$truth$reality$dose_250$plasma, tb$truth$reality$plasma * 250 / 400, tolerance = 1e-8)
  expect_output(print(tb), "doses: 12 model runs")
  expect_error(testbed_dosing(2, doses = 400), class = "wavevalid_error_condition")
})

test_that("with conditions, validate() registers the base field to the model at its own condition", {
  withr::local_seed(2)
  t <- seq(0, 1, length.out = 129)[-129]
  # an event whose time moves with the condition c1
  bump <- function(u, c) u * exp(-((t - 0.3 - 0.3 * c) / 0.04)^2) + 0.3 * sin(2 * pi * t)
  design <- data.frame(u1 = stats::runif(40, 0.5, 1.5), c1 = (sample(40) - stats::runif(40)) / 40)
  runs <- model_runs(design, list(site1 = t(mapply(bump, design$u1, design$c1))), t)
  truth <- bump(1, 0.1)
  field <- field_runs(list(site1 = t(replicate(3, truth + stats::rnorm(length(t), sd = 0.01)))), t)
  iu <- iu_map(c("u1", "c1"), c("calibration", "condition"), lower = c(0.5, 0), upper = c(1.5, 1),
               nominal = c(1, 0.1))
  windows <- list(c(0.2, 0.7))
  msg <- expect_message(
    fit <- suppressWarnings(validate(runs, field, iu, windows = windows, chains = 1, seed = 1,
                                     sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 200,
                                                               n_search = 10))),
    "registered to the model at the base condition c1 = 0.1", class = "wavevalid_message")
  rms <- function(m) sqrt(mean(sweep(m, 2L, truth)^2))
  # the model at c1 = 0.1 has the field's timing: registration leaves it near the truth
  expect_lt(rms(fit$field$curves$site1), 0.02)
  # the mean of runs over every condition would pull it off
  to_all <- register_curves(field, runs, windows, knots_every = 4 * diff(t[1:2]))
  expect_gt(rms(to_all$curves$site1), 4 * rms(fit$field$curves$site1))
  # the time of each phase, the base field's two registrations in one row
  expect_identical(fit$timing$phase, c("preflight", "registration", "basis", "emulators", "calibration"))
  expect_true(all(fit$timing$elapsed >= 0) && all(fit$timing$cpu >= 0) && fit$timing$cpu[5] > 0)
  # a reference given is used as given
  given <- suppressWarnings(validate(runs, field, iu, windows = windows, reference = runs, chains = 1, seed = 1,
                                     sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 200,
                                                               n_search = 10, quiet = TRUE)))
  expect_equal(given$field$curves$site1, to_all$curves$site1)
})

test_that("an experiment at a condition is registered to a reference whose fine detail is the condition's", {
  withr::local_seed(1)
  withr::local_options(wavevalid.quiet = TRUE)
  tb <- testbed_dosing(1, "none", doses = 250)
  runs <- tb$doses$runs
  field_250 <- tb$doses$fields$dose_250
  basis <- wavelet_basis(runs, tb$A$field)
  em <- suppressWarnings(fit_emulators(runs, basis))
  x <- check_experiments(list(d250 = experiment(field_250, condition = c(dose = 250))), em, tb$A$field,
                         iu = tb$doses$iu)
  knots <- 48 / 32
  reg <- register_experiments(x, em, runs, tb$windows, knots_every = knots)$d250$field
  # the runs nearest 250 mg give the detail the basis leaves out (8 of 80)
  near <- condition_neighbours(runs$design, c(dose = 250))
  expect_length(near, 8L)
  expect_true(all(abs(runs$design$dose[near] - 250) <= sort(abs(runs$design$dose - 250))[8]))
  # registered as to the simulator's runs at 250 mg
  d <- runs$design
  d$dose <- 250
  to_true <- register_curves(field_250, simulate_dosing(d), tb$windows, knots_every = knots)
  # against the emulated curves with every run's detail (each at its own dose)
  ref_all <- experiment_reference(x$d250, em, runs)
  pred <- stats::predict(em, d, site = "plasma")$mean
  ref_all$curves$plasma <- basis_curves(basis, pred) +
    basis_remainder(basis, runs$curves$plasma)
  to_all <- register_curves(field_250, ref_all, tb$windows, knots_every = knots)
  rms <- function(a, b) sqrt(mean((a - b)^2))
  landmarks <- function(f) f$warps$t_after[f$warps$feature != "fitted" & f$warps$replicate == 1]
  dt <- diff(tb$A$field$t[1:2])
  # measured: rms 0.009 mg/L against 0.037, landmarks within a grid step against up to 5 steps
  expect_lt(rms(reg$curves$plasma, to_true$curves$plasma), 0.015)
  expect_gt(rms(to_all$curves$plasma, to_true$curves$plasma), 2.5 * rms(reg$curves$plasma, to_true$curves$plasma))
  expect_lte(max(abs(landmarks(reg) - landmarks(to_true))), dt * 1.01)
  expect_gt(max(abs(landmarks(to_all) - landmarks(to_true))), 3 * dt)
})

test_that("design_maximin() places runs at the tested conditions, and the reach check takes what the runs bridge", {
  iu <- iu_map(c("A", "T"), c("calibration", "condition"), lower = c(0, 293), upper = c(1, 1203),
               nominal = c(0.5, 293))
  tested <- c(293, 473, 673, 873, 1203)
  d0 <- design_maximin(iu, 31, seed = 2)
  d <- design_maximin(iu, 31, seed = 2, conditions = list(T = tested))
  expect_true(all(tested %in% d$T[1:30]))
  # only the tested condition's column moves, and only the runs moved onto a tested value
  expect_identical(d$A, d0$A)
  moved <- d$T != d0$T
  expect_lte(sum(moved), length(tested))
  expect_true(all(d$T[moved] %in% tested))
  # each moved run was the nearest of those free to its value
  expect_true(all(abs(d0$T[moved] - d$T[moved]) <= (1203 - 293) / 30 * 2))
  expect_error(design_maximin(iu, 31, conditions = list(T = 2000)), class = "wavevalid_error_input")
  expect_error(design_maximin(iu, 31, conditions = list(P = 1)), class = "wavevalid_error_input")
  expect_error(design_maximin(iu, 31, conditions = c(T = 300)), class = "wavevalid_error_input")
  expect_error(design_maximin(iu, 4, conditions = list(T = tested)), class = "wavevalid_error_input")

  # an experiment's condition a hair beyond the runs is within their reach; far beyond, refused
  ex <- example_problem(1)
  iu2 <- iu_map(c("u1", "x1"), c("calibration", "condition"), lower = c(0, 0), upper = c(1, 2),
                nominal = c(0.5, 0.5))
  x1 <- ex$emulators$design[, "x1"]
  gap <- max(diff(sort(x1)))
  near <- list(near = experiment(ex$field, condition = c(x1 = max(x1) + gap / 2)))
  expect_silent(check_experiments(near, ex$emulators, list(curves = list()), x_nom = c(u1 = 0.5, x1 = 0.5),
                                  iu = iu2))
  far <- list(far = experiment(ex$field, condition = c(x1 = max(x1) + 2 * gap)))
  err <- expect_error(check_experiments(far, ex$emulators, list(curves = list()), x_nom = c(u1 = 0.5, x1 = 0.5),
                                        iu = iu2), class = "wavevalid_error_experiment")
  expect_match(conditionMessage(err), "design_maximin", fixed = TRUE)
})

test_that("experiments_at(base =) keeps the base condition's curves as the field, and validate() reads the whole set", {
  ex <- example_problem(1)
  t <- ex$field$t
  y <- ex$field$curves$site1
  long <- do.call(rbind, lapply(c(0.5, 0.7), function(x1) {
    do.call(rbind, lapply(seq_len(nrow(y)), function(r) {
      data.frame(x1 = x1, replicate = paste0("unit", r), t = t, y = y[r, ] + (x1 - 0.5))
    }))
  }))
  all_data <- experiments_at(long, "x1", t = "t", y = "y", replicate = "replicate", base = c(x1 = 0.5))
  expect_s3_class(all_data, "wv_experiments_at")
  expect_named(all_data, "x1=0.7")
  expect_equal(attr(all_data, "field")$curves$site1, y, ignore_attr = TRUE)
  expect_output(print(all_data), "the base field at x1 = 0.5")
  # without base, the base condition is an experiment too, and giving it beside the field is refused
  both <- experiments_at(long, "x1", t = "t", y = "y", replicate = "replicate")
  expect_named(both, c("x1=0.5", "x1=0.7"))
  expect_error(experiments_at(long, "x1", t = "t", y = "y", replicate = "replicate", base = c(x1 = 0.6)),
               class = "wavevalid_error_condition")
  expect_error(experiments_at(long, "x1", t = "t", y = "y", replicate = "replicate", base = c(dose = 0.5)),
               class = "wavevalid_error_condition")
  # calibrate() with the whole set draws what it draws with the field and the experiment given apart
  iu <- cond_iu()
  whole <- suppressWarnings(calibrate(ex$emulators, all_data, iu, chains = 1, seed = 3, sampler = cond_sampler()))
  apart <- suppressWarnings(calibrate(ex$emulators, attr(all_data, "field"), iu,
                                      experiments = list(`x1=0.7` = all_data[["x1=0.7"]]),
                                      chains = 1, seed = 3, sampler = cond_sampler()))
  expect_identical(as.matrix(whole$draws), as.matrix(apart$draws))
  expect_error(calibrate(ex$emulators, all_data, iu, experiments = list(`x1=0.7` = all_data[["x1=0.7"]])),
               class = "wavevalid_error_experiment")
})
