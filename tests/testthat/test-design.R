example_fit <- function() {
  ex <- example_problem()
  calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1,
            sampler = sampler_control(n_draws = 200, n_inner = 10, quiet = TRUE))
}

test_that("design_posterior() with no spread places every run at a posterior draw, inside the ranges", {
  fit <- example_fit()
  d <- design_posterior(fit, 20, spread = 0, seed = 3)
  expect_s3_class(d, "data.frame")
  expect_identical(names(d), fit$inputs)
  expect_identical(nrow(d), 20L)
  draws <- as.matrix(fit$draws)[, fit$inputs]
  key <- function(m) apply(signif(as.matrix(m), 12), 1, paste, collapse = ":")
  expect_true(all(key(d) %in% key(draws)))
  expect_identical(design_posterior(fit, 20, spread = 0, seed = 3), d)
  expect_false(identical(design_posterior(fit, 20, spread = 0, seed = 4), d))
})

test_that("design_posterior() spreads the runs by the posterior sd and the step, kept in range", {
  fit <- example_fit()
  draws <- as.matrix(fit$draws)[, fit$inputs]
  k <- match(fit$inputs, fit$prior_iu$name)
  width <- fit$prior_iu$upper[k] - fit$prior_iu$lower[k]
  d <- design_posterior(fit, 400, spread = 0.02, seed = 1)
  expect_true(all(sweep(as.matrix(d), 2, fit$prior_iu$lower[k], `>=`)))
  expect_true(all(sweep(as.matrix(d), 2, fit$prior_iu$upper[k], `<=`)))
  # the design's variance is the posterior variance plus the step's
  ratio <- apply(d, 2, stats::var) / (apply(draws, 2, stats::var) + (0.02 * width)^2)
  expect_true(all(abs(ratio - 1) < 0.25), label = paste(signif(ratio, 3), collapse = ", "))
  expect_true(all(abs(colMeans(d) - colMeans(draws)) < 3 * sqrt(apply(d, 2, stats::var) / 400)))
  # without the step the spread is the posterior's alone, and the step is what widens it
  d0 <- design_posterior(fit, 400, spread = 0, seed = 1)
  expect_true(all(apply(d, 2, stats::var) > apply(d0, 2, stats::var)))
})

test_that("design_posterior() runs do not repeat the emulators' runs or each other", {
  fit <- example_fit()
  d <- design_posterior(fit, 10, spread = 0.05, seed = 2)
  all_points <- rbind(as.matrix(d), as.matrix(fit$emulators$design[, fit$inputs]))
  expect_false(anyDuplicated(all_points) > 0)
})

test_that("design_posterior() refuses bad input with classed errors", {
  fit <- example_fit()
  expect_error(design_posterior(list(), 5), class = "wavevalid_error_input")
  expect_error(design_posterior(fit, 0), class = "wavevalid_error_input")
  expect_error(design_posterior(fit, 2.5), class = "wavevalid_error_input")
  expect_error(design_posterior(fit, 5, spread = -0.1), class = "wavevalid_error_input")
  expect_error(design_posterior(fit, 5, spread = NA), class = "wavevalid_error_input")
  expect_error(design_posterior(fit, 5, seed = "a"), class = "wavevalid_error_input")
})

test_that("c() combines runs in order, inputs matched by name", {
  t <- seq(0, 1, length.out = 32)
  f <- function(a, b) t(mapply(function(a, b) sin(2 * pi * a * t) + b, a, b))
  r1 <- model_runs(data.frame(a = c(0.1, 0.5, 0.9), b = c(1, 2, 3)), list(s1 = f(c(0.1, 0.5, 0.9), 1:3), s2 = f(c(0.1, 0.5, 0.9), 0)), t)
  r2 <- model_runs(data.frame(b = c(4, 5), a = c(0.3, 0.7)), list(s2 = f(c(0.3, 0.7), 0), s1 = f(c(0.3, 0.7), 4:5)), t)
  r <- c(r1, r2)
  expect_s3_class(r, "wv_runs")
  expect_identical(r$design, data.frame(a = c(0.1, 0.5, 0.9, 0.3, 0.7), b = c(1, 2, 3, 4, 5)))
  expect_equal(r$curves$s1, rbind(r1$curves$s1, r2$curves$s1))
  expect_equal(r$curves$s2, f(c(0.1, 0.5, 0.9, 0.3, 0.7), 0))
  expect_identical(c(r1), r1)
})

test_that("c() refuses runs that do not fit together", {
  t <- seq(0, 1, length.out = 32)
  r1 <- model_runs(data.frame(a = c(0.1, 0.5)), rbind(sin(t), cos(t)), t)
  expect_error(c(r1, list(1)), class = "wavevalid_error_input")
  expect_error(c(r1, model_runs(data.frame(a = c(0.2, 0.3)), rbind(t, t), seq(0, 2, length.out = 32))),
               class = "wavevalid_error_input")
  expect_error(c(r1, model_runs(data.frame(a = c(0.2, 0.3)), rbind(t, t), t, site = "other")),
               class = "wavevalid_error_input")
  expect_error(c(r1, model_runs(data.frame(b = c(0.2, 0.3)), rbind(t, t), t)), class = "wavevalid_error_input")
  expect_error(c(r1, model_runs(data.frame(a = c(0.5, 0.3)), rbind(t, t), t)), "repeat", class = "wavevalid_error_input")
})
