test_that("pointwise bands cover the stated fraction of draws at each t", {
  withr::local_seed(1)
  Y <- matrix(stats::rnorm(2000 * 30, sd = rep(seq(0.5, 2, length.out = 30), each = 2000)), 2000, 30)
  q <- wavevalid:::pointwise_quantiles(Y, c(0.05, 0.95))
  inside <- sweep(Y, 2, q[1, ], ">=") & sweep(Y, 2, q[2, ], "<=")
  expect_true(all(abs(colMeans(inside) - 0.9) < 0.002))
  expect_equal(q[1, ], unname(apply(Y, 2, stats::quantile, 0.05)))
  sim <- wavevalid:::simultaneous_band(Y, 0.9)
  whole <- apply(sweep(Y, 2, sim$lower, ">=") & sweep(Y, 2, sim$upper, "<="), 1, all)
  expect_gte(mean(whole), 0.9)
  expect_true(all(sim$lower <= q[1, ] & sim$upper >= q[2, ]))
})

test_that("bias(), reality() and model_prediction() give tidy bands built from the draws", {
  ex <- wavevalid:::example_calibration_inputs()
  fit <- calibrate(ex$emulators, ex$field, ex$iu, n_draws = 300, n_inner = 10, chains = 1, seed = 2, quiet = TRUE)
  b <- bias(fit)
  expect_named(b, c("site", "t", "mean", "lower", "upper", "lower_curve", "upper_curve"))
  expect_equal(nrow(b), length(fit$basis$t))
  expect_equal(b$mean, unname(colMeans(fit$wb$site1 %*% t(fit$basis$Psi))))
  expect_true(all(b$lower <= b$mean & b$mean <= b$upper))
  r <- reality(fit, level = 0.5, residual = FALSE)
  yR <- (fit$wM$site1 + fit$wb$site1) %*% t(fit$basis$Psi)
  expect_equal(r$upper, unname(apply(yR, 2, stats::quantile, 0.75)))
  expect_error(bias(fit, level = 1.2), class = "wavevalid_error_input")
  m <- model_prediction(fit)
  expect_true(all(c("site", "t", "mean", "lower", "upper", "error_lower", "error_upper") %in% names(m)))
  zhat <- colMeans(as.matrix(fit$draws)[, c("u1", "x1")])
  mhat <- wavevalid:::gasp_bank_predict_cpp(fit$emulators$banks$site1, matrix(zhat, 1))$mean
  expect_equal(m$mean, drop(fit$basis$Psi %*% t(mhat)))
  expect_equal(m$lower, m$mean + m$error_lower)
  fr <- wavevalid:::curve_draws(fit, "site1", "field_run", seed = 1)
  expect_identical(fr, wavevalid:::curve_draws(fit, "site1", "field_run", seed = 1))
  expect_gt(mean(apply(fr, 2, stats::var)), mean(apply(yR, 2, stats::var)))
  expect_s3_class(autoplot(fit, "bias", windows = list(c(0.1, 0.5))), "ggplot")
  expect_s3_class(autoplot(fit, "reality"), "ggplot")
})

test_that("the field detail outside the basis gets bands with their nominal coverage", {
  # a basis of 16 orthonormal columns in 128 points; truth with detail outside it
  set.seed(11)
  n_t <- 128
  Psi <- qr.Q(qr(matrix(stats::rnorm(n_t * 16), n_t)))
  truth <- stats::rnorm(n_t)
  detail <- truth - drop(Psi %*% crossprod(Psi, truth))
  band_cover <- function(R, H = 400) {
    Y <- matrix(truth, R, n_t, byrow = TRUE) + matrix(stats::rnorm(R * n_t, sd = 0.2), R)
    fit <- list(field = list(curves = list(a = Y)), basis = list(Psi = Psi),
                sigma2 = list(a = matrix(0.04, 10, 16)))
    E <- wavevalid:::residual_draws(fit, "a", H)
    q <- apply(E, 2, stats::quantile, c(0.05, 0.95))
    mean(detail >= q[1, ] & detail <= q[2, ])
  }
  cover7 <- mean(replicate(150, band_cover(7)))
  cover3 <- mean(replicate(150, band_cover(3)))
  cover1 <- mean(replicate(150, band_cover(1)))
  # nominal 90%: Student t intervals with 7 and 3 replicates, known variance with one
  expect_gt(cover7, 0.87)
  expect_lt(cover7, 0.93)
  expect_gt(cover3, 0.86)
  expect_lt(cover3, 0.94)
  expect_gt(cover1, 0.87)
  expect_lt(cover1, 0.95)
  # replicates without spread: every draw is the mean's detail itself
  fit3 <- list(field = list(curves = list(a = matrix(truth, 3, n_t, byrow = TRUE))),
               basis = list(Psi = Psi), sigma2 = list(a = matrix(0.04, 10, 16)))
  expect_equal(colMeans(wavevalid:::residual_draws(fit3, "a", 5)), detail)
})
