test_that("example_problem() holds what calibrate() takes, the same for the same seed", {
  ex <- example_problem()
  expect_named(ex, c("emulators", "field", "iu"))
  expect_s3_class(ex$emulators, "wv_emulators")
  expect_s3_class(ex$field, "wv_field")
  expect_s3_class(ex$iu, "wv_iu")
  expect_setequal(ex$emulators$inputs, ex$iu$name)
  expect_identical(ex$field$t, ex$emulators$basis$t)
  expect_identical(names(ex$field$curves), "site1")
  expect_identical(dim(ex$field$curves$site1), c(4L, 32L))
  expect_identical(example_problem(), ex)
  expect_identical(example_problem(seed = 1), ex)
  expect_false(identical(example_problem(seed = 2)$field, ex$field))
  expect_error(example_problem(seed = 1.5), class = "wavevalid_error_input")
})

test_that("example_fit() is a small calibrated fit, the same for the same seed", {
  fit <- expect_no_warning(example_fit())
  expect_s3_class(fit, "wv_fit")
  expect_identical(fit$inputs, c("u1", "x1"))
  expect_identical(fit$settings$n_draws, 200)
  expect_identical(fit$settings$chains, 2)
  expect_identical(nrow(as.matrix(fit$draws)), 400L)
  expect_identical(fit$seed, 1L)
  # the stored fit at seed 1 is a calibration of example_problem(seed = 1) (its field) under the
  # package's current defaults (a stored fit made under other defaults fails here)
  expect_identical(fit$field, example_problem(seed = 1)$field)
  expect_identical(fit$control$bias, bias_control())
  expect_identical(fit$settings$pool_levels, coarse_levels(fit$basis))
  ex <- example_problem(seed = 2)
  direct <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 2,
                                       sampler = sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE)))
  # the same fit but for the chains' wall time
  untimed <- function(f) `[[<-`(f, "sampling_seconds", NULL)
  expect_gt(direct$sampling_seconds, 0)
  expect_identical(untimed(example_fit(seed = 2)), untimed(direct))
})

test_that("the example fit shipped with the package is what its calibration gives now", {
  # example_fit() returns the stored fit at seed 1; a change to the calibration that moves it fails
  # here (remake it with data-raw/make-example.R)
  # (the stored fit keeps no wall time of its chains)
  expect_null(example_fit()$sampling_seconds)
  expect_equal(example_fit(), fit_set(compute_example_fit(1), sampling_seconds = NULL))
  ex <- example_problem(seed = 1)
  direct <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 1,
                                       sampler = sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE)))
  expect_identical(as.matrix(example_fit()$draws), as.matrix(direct$draws))
  expect_identical(example_fit()$wb, direct$wb)
})

test_that("augment_emulators() and loo_residuals() take `emulators`; `object` is deprecated", {
  ex <- example_problem()
  em <- ex$emulators
  loo <- loo_residuals(em)
  expect_identical(loo_residuals(emulators = em), loo)
  expect_warning(old <- loo_residuals(object = em), class = "wavevalid_warning_deprecated")
  expect_identical(old, loo)
  expect_warning(loo_residuals(object = em), "emulators =")

  z <- c(u1 = 0.4, x1 = 0.6)
  w <- predict(em, z, site = "site1")$mean[1, ]
  aug <- augment_emulators(em, z, w)
  expect_identical(augment_emulators(emulators = em, z = z, w = w), aug)
  expect_warning(old <- augment_emulators(object = em, z, w), class = "wavevalid_warning_deprecated")
  expect_identical(old, aug)
  expect_warning(old <- augment_emulators(z = z, w = w, object = em), class = "wavevalid_warning_deprecated")
  expect_identical(old, aug)

  expect_error(loo_residuals(em, extra = 1), class = "wavevalid_error_input")
  expect_error(augment_emulators(em, z, w, 1), class = "wavevalid_error_input")
})
