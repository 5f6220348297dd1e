test_that("fit_assumptions() gives the lines print() gives for each part of a fit", {
  fit <- example_fit()
  expect_identical(fit_assumptions(fit), prior_lines(fit$prior_iu))
  expect_identical(fit_assumptions(fit, "noise"), noise_lines(fit))
  expect_identical(fit_assumptions(fit, "likelihood"), shared_error_lines(fit))
  expect_identical(fit_assumptions(fit, "experiments"), character(0))
  expect_identical(fit_assumptions(fit, "joint_prior"), character(0))
  printed <- utils::capture.output(print(fit))
  for (part in c("priors", "noise", "likelihood")) {
    expect_true(all(fit_assumptions(fit, part) %in% printed), label = part)
  }
  expect_error(fit_assumptions(fit, "bias"), class = "wavevalid_error_input")
  expect_error(fit_assumptions(fit$emulators, "noise"), class = "wavevalid_error_input")
})

test_that("fit_assumptions() gives the joint prior's correlations of a fit under a joint prior", {
  fit <- example_fit()
  fit$prior_iu <- iu_prior_joint(fit$prior_iu, "u1", mean = 0.5, cov = matrix(0.04))
  expect_identical(fit_assumptions(fit, "joint_prior"), joint_prior_text(fit$prior_iu))
  expect_match(fit_assumptions(fit, "joint_prior")[1], "Joint Gaussian 1 on u1")
})

test_that("iu_prior_sample() draws from the I/U map's prior with R's random numbers", {
  tb <- load_testbed()
  nom <- c(x1 = 0.4, x3 = 0.6)
  z <- withr::with_seed(4, iu_prior_sample(tb$iu, 500, nominal = nom))
  expect_identical(z, withr::with_seed(4, iu_prior_draws(tb$iu, 500L, nominal = nom)))
  expect_identical(dim(z), c(500L, nrow(tb$iu)))
  expect_identical(colnames(z), tb$iu$name)
  # the variations drawn about the new nominals, the others about theirs
  expect_lt(abs(mean(z[, "x1"]) - 0.4), 0.02)
  expect_lt(abs(mean(z[, "x2"]) - tb$iu$nominal[tb$iu$name == "x2"]), 0.02)
  expect_identical(nrow(iu_prior_sample(tb$iu, 1)), 1L)
  expect_error(iu_prior_sample(tb$iu, 0), class = "wavevalid_error_input")
  expect_error(iu_prior_sample(tb$iu, 5, nominal = c(u1 = 0.3)), class = "wavevalid_error_input")
  expect_error(iu_prior_sample(tb$iu, 5, nominal = 0.3), class = "wavevalid_error_input")
  expect_error(iu_prior_sample(as.data.frame(tb$iu), 5), class = "wavevalid_error_input")
})

test_that("testbed_noise() is the test bed's AR(1) field noise", {
  e <- withr::with_seed(1, testbed_noise(20000))
  expect_identical(e, withr::with_seed(1, ar1_noise(20000)))
  expect_lt(abs(stats::sd(e) - 0.03), 0.005)
  expect_lt(abs(stats::cor(e[-1], e[-20000]) - 0.95), 0.02)
  e2 <- withr::with_seed(1, testbed_noise(20000, sd = 0.04, phi = 0.9))
  expect_lt(abs(stats::cor(e2[-1], e2[-20000]) - 0.9), 0.02)
  expect_error(testbed_noise(0), class = "wavevalid_error_input")
  expect_error(testbed_noise(10, phi = 2), class = "wavevalid_error_input")
})

test_that("testbed_unwarped_field() is the field without time warps, a warp given as knots", {
  tb <- load_testbed()
  expect_identical(testbed_unwarped_field(tb, 3), unwarped_field(tb, 3))
  w <- tb$truth$warps
  w <- w[w$condition == "A" & w$replicate == 1, ]
  expect_identical(testbed_unwarped_field(tb, 3, w), unwarped_field(tb, 3, w[c("t", "w")]))
  expect_error(testbed_unwarped_field(tb, 3, warp = list(1)), class = "wavevalid_error_input")
  expect_error(testbed_unwarped_field(tb$A$field, 3), class = "wavevalid_error_input")
})

test_that("testbed_beds() names each test bed's constructor, simulator, mechanisms and landmarks", {
  beds <- testbed_beds()
  expect_named(beds, c("suspension", "dosing"))
  expect_identical(beds$suspension$mechanisms(), testbed_mechanisms())
  expect_identical(beds$dosing$mechanisms(), dosing_mechanisms())
  expect_identical(beds$suspension$features, c("min", "max"))
  expect_identical(beds$dosing$features, "rise")
  expect_identical(beds$dosing$simulate, simulate_dosing)
})
