test_that("the finest-level estimate recovers the sd of white noise", {
  withr::local_seed(3)
  t <- seq(0, 10, length.out = 1024)
  signal <- 3 * exp(-((t - 4) / 0.5)^2) + sin(t)
  field <- field_runs(rbind(signal + rnorm(1024, sd = 0.2)), t)
  runs <- model_runs(data.frame(a = 1:3), t(sapply(1:3, function(k) k * signal)), t)
  basis <- wavelet_basis(runs, field)
  s2 <- field_noise(field, basis)
  expect_named(s2, "site1")
  expect_length(s2$site1, length(basis$index))
  expect_equal(unname(attr(s2, "sd")), 0.2, tolerance = 0.1)
  expect_error(field_noise(runs, basis), class = "wavevalid_error_input")
  flat <- field_runs(rbind(rep(1, 1024)), t)
  expect_error(field_noise(flat, basis), class = "wavevalid_error_numeric")
})

test_that("a one-replicate, non-dyadic problem validates end to end with the finest-level noise", {
  skip_on_cran()
  withr::local_seed(8)
  t <- seq(0, 10, length.out = 136)
  p <- 10
  K <- 128
  design <- as.data.frame(matrix(runif(K * p), K, p, dimnames = list(NULL, paste0("x", 1:p))))
  model <- function(z) {
    (1 + 0.3 * z[1]) * exp(-((t - 3 - z[2]) / (0.4 + 0.2 * z[3]))^2) - 0.5 * z[4] * exp(-((t - 7) / 0.5)^2) +
      0.1 * sum(z[5:10]) * sin(t)
  }
  curves <- t(apply(design, 1, model))
  iu <- iu_map(paste0("x", 1:p), rep(c("calibration", "variation"), c(2, 8)), rep(0, p), rep(1, p))
  zt <- rep(0.45, p)
  measured <- rbind(model(zt) + 0.15 * exp(-((t - 5) / 0.3)^2) + rnorm(136, sd = 0.02))
  runs <- suppressMessages(model_runs(design, curves, t, site = "load"))
  field <- suppressMessages(field_runs(measured, t, site = "load"))
  expect_error(validate(runs, field, iu, n_draws = 20, n_inner = 5, chains = 1, seed = 1, quiet = TRUE),
               class = "wavevalid_error_input")
  expect_warning(
    fit <- suppressMessages(validate(runs, field, iu, sigma2 = "finest", n_draws = 60, n_inner = 10, chains = 1,
                                     seed = 1, quiet = TRUE)),
    class = "wavevalid_warning_noise_estimate"
  )
  expect_s3_class(fit, "wv_fit")
  wf <- where_fails(fit)
  expect_s3_class(wf, "wv_fails")
  expect_true(any(wf$start <= 5.3 & wf$end >= 4.7))
})
