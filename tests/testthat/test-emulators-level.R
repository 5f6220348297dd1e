# The shared-parameter engine ("gasp_level"): one set of correlation
# parameters per site and wavelet level.

level_runs <- function(K = 24) {
  t <- seq(0, 1, length.out = 64)
  design <- data.frame(u1 = (seq_len(K) - 0.5) / K, x1 = ((seq_len(K) * 7) %% K + 0.5) / K)
  g <- function(z) sin(2 * pi * t * (1 + 0.5 * z[1])) + z[2] * t + 0.2 * z[1] * z[2] * cos(6 * pi * t)
  list(runs = model_runs(design, t(apply(design, 1, g)), t), g = g, t = t)
}

test_that("the shared objective's gradient matches finite differences", {
  withr::local_seed(3)
  K <- 25
  X <- matrix(stats::runif(K * 3), K, 3)
  Y <- cbind(sin(3 * X[, 1]) + X[, 2]^2, cos(2 * X[, 1] * X[, 3]), X[, 2] + 0.1 * X[, 3]^3)
  for (prior in list(list(type = 0L), list(type = 1L))) {
    for (restricted in 0:1) {
      th <- c(stats::runif(3, -2, 2), stats::runif(3, 0.05, 0.95))
      obj <- function(x) gasp_level_loglik_cpp(X, Y, x, 1e-8, prior, restricted)$loglik
      g <- gasp_level_loglik_cpp(X, Y, th, 1e-8, prior, restricted)$gradient
      fd <- vapply(seq_along(th), function(j) {
        h <- 1e-6
        e <- replace(numeric(length(th)), j, h)
        (obj(th + e) - obj(th - e)) / (2 * h)
      }, numeric(1))
      expect_equal(g, fd, tolerance = 1e-5)
    }
  }
})

test_that("the shared objective is the sum of the coefficients' profile log-likelihoods plus the log prior", {
  withr::local_seed(4)
  K <- 20
  X <- matrix(stats::runif(K * 2), K, 2)
  Y <- cbind(sin(3 * X[, 1]) + X[, 2], X[, 1] * X[, 2], cos(4 * X[, 2]))
  th <- c(0.5, -1, 0.2, 0.7)
  sum_ll <- sum(vapply(1:3, function(i) gasp_loglik_cpp(X, Y[, i], th, 0)$loglik, numeric(1)))
  none <- gasp_level_loglik_cpp(X, Y, th, 0, list(type = 0L), 0L)
  jr <- gasp_level_loglik_cpp(X, Y, th, 0, list(type = 1L), 0L)
  expect_equal(none$loglik, sum_ll, tolerance = 1e-10)
  expect_equal(none$log_prior, 0)
  # jointly robust prior on the inverse ranges rho = beta^(1 / (2 - alpha))
  rho <- exp(th[1:2] / (2 - th[3:4]))
  C <- K^(-1 / 2)
  expect_equal(jr$log_prior, 0.2 * log(C * sum(rho)) - C * (0.2 + 2) * C * sum(rho), tolerance = 1e-12)
  expect_equal(jr$loglik, sum_ll + jr$log_prior, tolerance = 1e-10)
})

test_that("with one coefficient and no prior the shared fit is the per-coefficient fit", {
  withr::local_seed(5)
  K <- 22
  X <- matrix(stats::runif(K * 3), K, 3)
  y <- sin(3 * X[, 1]) + X[, 2]^2 + 0.2 * X[, 3]
  ctl <- gasp_control(1L, c(-8, 6))
  one <- gasp_fit_cpp(X, matrix(y), 1L, ctl)
  lev <- gasp_level_fit_cpp(X, matrix(y), ctl, list(type = 0L), 0L, list())
  # the same screening and optimiser on the same function: equal up to the
  # rounding of the two ways of summing (and the optimiser's tolerance)
  expect_equal(as.numeric(lev$beta), as.numeric(one$beta), tolerance = 1e-4)
  expect_equal(as.numeric(lev$alpha), as.numeric(one$alpha), tolerance = 1e-4)
  expect_equal(lev$objective, one$loglik, tolerance = 1e-8)
})

test_that("the gasp_level engine gives valid emulators sharing parameters within a level", {
  pb <- level_runs()
  basis <- wavelet_basis(pb$runs)
  em <- suppressWarnings(fit_emulators(pb$runs, basis, engine = "gasp_level"))
  expect_s3_class(em, "wv_emulators")
  expect_identical(em$engine, "gasp_level")
  expect_no_error(validate_wv_emulators(em))
  p <- em$params[is.finite(em$params$loglik), ]
  bcols <- grep("^(beta|alpha)_", names(p), value = TRUE)
  for (lv in unique(p$level)) {
    sub <- as.matrix(p[p$level == lv, bcols])
    expect_equal(unname(sweep(sub, 2L, sub[1, ])), matrix(0, nrow(sub), ncol(sub)))
  }
  # exponents kept at most 1.9 and variances those of the Student-t predictive
  expect_true(all(as.matrix(p[grep("^alpha_", names(p))]) >= 0.1 - 1e-12))
  b <- em$banks$site1
  k <- nrow(b$X)
  ok <- is.finite(em$params$loglik)
  f <- gasp_finalize_cpp(b$X, b$y[, ok, drop = FALSE], b$beta[ok, , drop = FALSE], b$alpha[ok, , drop = FALSE],
                         b$nugget[ok])
  expect_equal(b$lambda[ok], f$lambda * (k - 3) / k)
  # predictions interpolate the runs and calibrate() runs on the emulators
  pr <- predict(em, pb$runs$design[3, ], site = "site1")
  expect_equal(as.numeric(pr$mean), as.numeric(b$y[3, ]), tolerance = 1e-5)
  iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), c(0, 0), c(1, 1), nominal = c(0.5, 0.5))
  withr::local_seed(6)
  field <- field_runs(list(site1 = t(replicate(3, pb$g(c(0.4, 0.5)) + stats::rnorm(length(pb$t), sd = 0.01)))),
                      pb$t)
  fit <- suppressWarnings(calibrate(em, field, iu, chains = 1, seed = 1,
                                    sampler = sampler_control(n_draws = 40, n_inner = 5)))
  expect_s3_class(fit, "wv_fit")
  r <- reality(fit)
  expect_true(all(r$lower <= r$upper))
})

test_that("bad input to the gasp_level engine gives classed errors", {
  pb <- level_runs(K = 12)
  basis <- wavelet_basis(pb$runs)
  expect_error(fit_emulators(pb$runs, basis, engine = "gasp_levels"), class = "wavevalid_error_input")
  expect_error(fit_emulators(pb$runs, basis, engine = "gasp_level", log_beta_range = c(2, 1)),
               class = "wavevalid_error_input")
  expect_error(fit_emulators(pb$runs, basis, engine = "gasp_level", starts = 0), class = "wavevalid_error_input")
  expect_error(fit_emulators(pb$runs, "basis", engine = "gasp_level"), class = "wavevalid_error_input")
})

# The test bed with nothing hidden, condition A's runs, the field registered
# to them, emulators of `engine` and two chains: the 90% reality band's
# coverage of the noise-free truth (registered like the field) and the true
# inputs inside their 95% posterior intervals.
band_coverage_case <- function(seed, engine, n_draws, n_inner) {
  tb <- testbed_suspension(seed = seed, hidden = "none")
  runs <- tb$A$runs
  field <- register_curves(tb$A$field, runs, tb$windows, knots_every = 2)
  em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, field), engine = engine))
  fit <- suppressWarnings(calibrate(em, field, tb$iu, chains = 2, seed = 1,
                                    sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, quiet = TRUE)))
  truth <- field_runs(lapply(tb$truth$reality, function(y) matrix(y, nrow = 1)), tb$A$field$t)
  truth <- register_curves(truth, runs, tb$windows, knots_every = 2)
  r <- reality(fit)
  hit <- unlist(lapply(names(truth$curves), function(s) {
    b <- r[r$site == s, ]
    y <- truth$curves[[s]][1, ]
    y >= b$lower & y <= b$upper
  }))
  X <- as.matrix(fit$draws)
  true_in <- c(tb$truth$u, 0.5 + tb$truth$delta)[fit$inputs]
  inside <- vapply(fit$inputs, function(p) {
    q <- stats::quantile(X[, p], c(0.025, 0.975))
    true_in[[p]] >= q[1] && true_in[[p]] <= q[2]
  }, logical(1))
  c(cover = mean(hit), inputs_in = sum(inside))
}

test_that("the reality band of the default emulators covers the truth on one test bed", {
  res <- band_coverage_case(1, "gasp_level", n_draws = 100, n_inner = 20)
  expect_gte(res[["cover"]], 0.75)
  expect_lte(res[["cover"]], 0.97)
})

# The test of record for the bands: nothing hidden, seeds 1 to 5, condition
# A's 66 runs. The 90% reality band covers the noise-free truth at 85-95% of
# the points on average and at no seed below 75%. The true inputs inside
# their 95% intervals are reported, not asserted: 4 to 5 of 9 at these
# seeds, the manufacturing variations most often outside.
test_that("the reality band of the default emulators covers the truth at 85-95% over five test beds", {
  skip_unless_slow()
  res <- vapply(1:5, band_coverage_case, numeric(2), engine = "gasp_level", n_draws = 200, n_inner = 25)
  expect_gte(mean(res["cover", ]), 0.85)
  expect_lte(mean(res["cover", ]), 0.95)
  expect_gte(min(res["cover", ]), 0.75)
})
