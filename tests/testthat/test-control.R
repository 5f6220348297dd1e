test_that("the control objects check their settings once, before anything is fitted", {
  cls <- "wavevalid_error_input"
  expect_error(bias_control(pool_levels = 1), class = cls)
  expect_error(bias_control(inform_levels = -1), class = cls)
  expect_error(bias_control(temper = 0), class = cls)
  expect_error(bias_control(input_likelihood = "both"), class = cls)
  expect_error(bias_control(sigma2 = "coarsest"), class = cls)
  expect_error(bias_control(sigma2 = list(0.1)), class = cls)
  expect_error(bias_control(fix_tau2 = -1), class = cls)
  expect_error(bias_control(level_variances = "per_experiment", experiment_bias = "shared"),
               class = "wavevalid_error_experiment")
  expect_error(sampler_control(n_draws = 0), class = cls)
  expect_error(sampler_control(step = 2), class = cls)
  expect_error(sampler_control(proposal = "gibbs"), class = cls)
  expect_error(sampler_control(burnin = -1), class = cls)
  expect_error(sampler_control(quiet = NA), class = cls)
  expect_error(sampler_control(chains = 0), class = cls)
  expect_error(registration_control(windows = list(c(2, 1))), class = cls)
  expect_error(registration_control(knots_every = -1), class = cls)
  expect_error(registration_control(features = "peak"), class = cls)
  expect_error(emulation_control(basis_args = "report"), class = cls)
  expect_error(emulation_control(engine = "kriging"), class = cls)
  ex <- example_problem()
  expect_error(calibrate(ex$emulators, ex$field, ex$iu, bias = list(temper = 1)), class = cls)
  expect_error(calibrate(ex$emulators, ex$field, ex$iu, sampler = bias_control()), class = cls)
  expect_error(calibrate(ex$emulators, ex$field, ex$iu, n_draw = 10), class = cls)
  expect_output(print(bias_control(pool_levels = 0:3)), "pool_levels: 0:3")
  expect_output(print(sampler_control(n_draws = 50)), "n_draws: 50")
  expect_output(print(registration_control(windows = list(c(6, 11), c(37, 41)))), "windows: (6, 11), (37, 41)",
                fixed = TRUE)
  expect_output(print(emulation_control(engine = "gasp")), "engine: gasp")
})

test_that("settings named directly give the same fit as the control objects", {
  ex <- example_problem()
  new <- calibrate(ex$emulators, ex$field, ex$iu, seed = 4,
                   bias = bias_control(pool_levels = 0:2, input_likelihood = "independent"),
                   sampler = sampler_control(n_draws = 30, n_inner = 5, quiet = TRUE, chains = 1))
  expect_no_warning(old <- calibrate(ex$emulators, ex$field, ex$iu, n_draws = 30, n_inner = 5, chains = 1, seed = 4,
                                     pool_levels = 0:2, input_likelihood = "independent", quiet = TRUE))
  expect_identical(as.matrix(old$draws), as.matrix(new$draws))
  expect_identical(old$wb, new$wb)
  expect_identical(old$control, new$control)
  expect_identical(new$control$sampler$chains, 1)
  # the fit keeps its controls and prints them as calls
  out <- capture.output(print(new))
  expect_true(any(grepl("Model: bias_control(pool_levels = 0:2, input_likelihood = \"independent\")", out, fixed = TRUE)))
  expect_true(any(grepl("Sampler: sampler_control(n_draws = 30, n_inner = 5), chains = 1, seed = 4", out, fixed = TRUE)))
  # a control object's setting that changes the posterior changes the draws
  other <- calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 4,
                     bias = bias_control(input_likelihood = "independent"),
                     sampler = sampler_control(n_draws = 30, n_inner = 5, quiet = TRUE))
  expect_false(identical(as.matrix(other$draws), as.matrix(new$draws)))
})
