test_that("load_flyer() gives the runs in physical units, the measured curve on their grid, the I/U map and prior", {
  fl <- load_flyer()
  inputs <- c("eos", "theta0", "kappa", "gamma", "y0", "yinf", "s0", "sinf", "pmin", "vs")
  expect_named(fl, c("runs", "field", "iu", "prior", "t", "ranges", "raw"))
  expect_s3_class(fl$runs, "wv_runs")
  expect_s3_class(fl$field, "wv_field")
  expect_s3_class(fl$iu, "wv_iu")
  expect_identical(names(fl$runs$design), inputs)
  expect_identical(dim(fl$runs$curves$velocity), c(128L, 256L))
  expect_identical(fl$runs$t, fl$t)
  expect_identical(fl$field$t, fl$t)
  expect_identical(dim(fl$field$curves$velocity), c(1L, 256L))
  # the grid is dyadic and equally spaced on the simulator's interval
  expect_true(is_dyadic_grid(fl$t))
  dir <- system.file("extdata", "flyer", package = "wavevalid")
  sim <- as.matrix(utils::read.table(file.path(dir, "sim_outputs.xz")))
  expect_equal(range(fl$t), range(sim[, 1]))
  # the design is the scaled design mapped to the ranges
  scaled <- unname(as.matrix(utils::read.table(file.path(dir, "design.txt.xz"))))
  rg <- unname(as.matrix(utils::read.table(file.path(dir, "fl_ranges"))))
  expect_equal(unname(as.matrix(fl$runs$design)[7, ]), rg[, 1] + scaled[7, ] * (rg[, 2] - rg[, 1]))
  expect_equal(fl$iu$lower, rg[, 1])
  expect_equal(fl$iu$upper, rg[, 2])
  expect_identical(fl$iu$type, ifelse(inputs == "vs", "variation", "calibration"))
  # repeated time stamps are averaged before interpolation
  raw <- fl$raw
  expect_identical(nrow(raw), 170L)
  dup <- raw$t[duplicated(raw$t)][1]
  avg <- mean(raw$velocity[raw$t == dup])
  k <- which.min(abs(fl$t - dup))
  tt <- sort(unique(raw$t))
  vv <- vapply(tt, function(s) mean(raw$velocity[raw$t == s]), numeric(1))
  expect_equal(fl$field$curves$velocity[1, k], stats::approx(tt, vv, xout = fl$t[k])$y)
  expect_equal(vv[tt == dup], avg)
  expect_equal(fl$field$curves$velocity[1, 1], raw$velocity[1])
  # the prior: -log(gamma) turned into log(gamma)
  th <- scan(file.path(dir, "c.theta"), quiet = TRUE)
  cv <- unname(as.matrix(utils::read.table(file.path(dir, "c.cov"))))
  p <- fl$prior
  expect_identical(p$names, inputs[2:8])
  expect_equal(unname(p$mean), c(th[1:2], -th[3], th[4:7]))
  expect_equal(unname(diag(p$cov)), diag(cv))
  expect_equal(unname(p$cov[3, -3]), -cv[3, -3])
  expect_equal(unname(p$cov[-3, -3]), unname(cv[-3, -3]))
  expect_equal(p$cov, t(p$cov))
  expect_true(all(eigen(p$cov, only.values = TRUE)$values > 0))
  expect_identical(unname(p$scale), ifelse(p$names == "gamma", "log", "identity"))
  # the prior mean lies inside the design's ranges (gamma on its log scale)
  at <- ifelse(p$scale == "log", exp(p$mean), p$mean)
  k <- match(p$names, fl$iu$name)
  expect_true(all(at > fl$iu$lower[k] & at < fl$iu$upper[k]))
})

# The flyer plate with every default (one measured curve: the noise learned),
# then under GPMSA's Gaussian prior of the strength parameters: the basis
# meets its tolerances, the print states how the noise was set, and under the
# prior kappa's posterior mean lies within 3 prior standard deviations of the
# prior mean with every chain mixed (R-hat below 1.05). Under uniform priors
# kappa lies about 5 prior standard deviations below it.
test_that("the flyer plate validates with every default and its strength parameters follow GPMSA's prior", {
  skip_unless_slow()
  fl <- load_flyer()
  withr::local_options(list(wavevalid.quiet = TRUE))
  fit <- suppressWarnings(validate(fl$runs, fl$field, fl$iu, chains = 2, seed = 1,
                                   sampler = sampler_control(n_draws = 1000, n_inner = 50)))
  e <- fit$basis$error
  expect_lte(stats::median(e$rel_l2[e$source == "run"]), 0.01)
  expect_lte(max(e$rel_l2[e$source == "field"]), 0.02)
  expect_output(print(fit), "velocity: learned")
  iu <- iu_prior_joint(fl$iu, fl$prior$names, fl$prior$mean, fl$prior$cov, scale = fl$prior$scale)
  fit_p <- suppressWarnings(calibrate(fit$emulators, fit$field, iu, chains = 2, seed = 1,
                                      sampler = sampler_control(n_draws = 1000, n_inner = 50)))
  k <- which(fl$prior$names == "kappa")
  z <- (mean(as.matrix(fit_p$draws)[, "kappa"]) - fl$prior$mean[[k]]) / sqrt(fl$prior$cov[k, k])
  expect_lt(abs(z), 3)
  rhat <- summary(fit_p)$inputs$rhat
  expect_true(all(rhat < 1.05), label = paste(round(rhat, 3), collapse = ", "))
})
