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
  # a bad sigma2 is refused before the emulators are fitted: by bias_control() when it is no noise setting,
  # by validate() itself when it names sites the data do not hold
  cnd <- rlang::catch_cnd(validate(runs, field, iu, bias = bias_control(sigma2 = "median"),
                                   sampler = sampler_control(n_draws = 20, quiet = TRUE)))
  expect_s3_class(cnd, "wavevalid_error_input")
  expect_identical(as.character(cnd$call[[1]]), "bias_control")
  cnd <- rlang::catch_cnd(validate(runs, field, iu, bias = bias_control(sigma2 = list(other = 1)),
                                   sampler = sampler_control(quiet = TRUE)))
  expect_s3_class(cnd, "wavevalid_error_input")
  expect_identical(as.character(cnd$call[[1]]), "validate")
  expect_warning(
    # the bump that reality has and the model lacks may pull x1 to a bound: a warning of its own
    fit <- suppressWarnings(suppressMessages(validate(runs, field, iu, chains = 1, seed = 1,
                                                      bias = bias_control(sigma2 = "finest"),
                                                      sampler = sampler_control(n_draws = 60, n_inner = 10, quiet = TRUE))),
                            classes = "wavevalid_warning_boundary"),
    class = "wavevalid_warning_noise_estimate"
  )
  expect_s3_class(fit, "wv_fit")
  wf <- where_fails(fit)
  expect_s3_class(wf, "wv_fails")
  expect_true(any(wf$start <= 5.3 & wf$end >= 4.7))
})

# SBC for the learned noise: u1 uniform, one noise variance for the 8
# coefficients drawn from its prior, tau2 known; truth (u1, sigma2, w^M, w^b)
# from the model, ranks of the truth among the kept draws.
# With `mult`, coefficient i's noise variance is mult[i] * sigma2 (a curve
# resampled onto the grid); with `df` > 0, repeated measurements add their
# scatter ss ~ sigma2 chi^2_df.
sbc_noise_pvalues <- function(reps, R = 1L, debug_break = 0L, scale = 0.5, family = "half-cauchy",
                              n_draws = 49L, n_inner = 10L, tau2 = 0.05, burnin = 300L, mult = NULL, df = 0) {
  s <- sbc_setup(R, noise_prior(scale = scale, family = family))
  n <- s$n
  spec <- s$spec
  G <- s$G
  bank <- s$bank
  if (!is.null(mult)) spec$sites$site1$noise$mult <- rep_len(mult, n)
  m <- if (is.null(mult)) rep(1, n) else rep_len(mult, n)
  ranks <- matrix(NA_integer_, reps, 2, dimnames = list(NULL, c("u1", "sigma2")))
  for (r in seq_len(reps)) {
    z <- stats::runif(1)
    sig <- if (family == "half-cauchy") abs(stats::rcauchy(1, 0, scale)) else abs(stats::rnorm(1, 0, scale))
    pr <- gasp_bank_predict_cpp(bank, matrix(z, 1))
    wM <- stats::rnorm(n, pr$mean, sqrt(pr$var))
    wb <- stats::rnorm(n, 0, sqrt(tau2))
    W <- matrix(wM + wb, R, n, byrow = TRUE) + matrix(stats::rnorm(R * n, 0, sig * sqrt(m)), R, n, byrow = TRUE)
    spec$sites$site1$wbar <- colMeans(W)
    spec$sites$site1$s2 <- colSums(sweep(W, 2L, colMeans(W))^2)
    if (df > 0) spec$sites$site1$noise[c("ss", "df")] <- list(sig^2 * stats::rchisq(1, df), df)
    out <- calibrate_chain_cpp(spec$sites, spec$priors, list(
      n_groups = G, z_init = 0.5, tau2_init = rep(tau2, G), fix_tau2 = TRUE, n_draws = n_draws,
      n_inner = n_inner, step = 0.5, seed = r, chain = 1L, debug_break = debug_break, adaptive = TRUE,
      burnin = burnin, n_search = 20L))
    ranks[r, ] <- c(sum(out$inputs[, 1] < z), sum(out$sigma2[[1]][, 1] < m[1] * sig^2))
  }
  sbc_rank_pvalues(ranks, n_draws)
}

test_that("SBC of the learned noise at a small size, and not without the Jacobian of its step", {
  withr::local_seed(4401)
  p_ok <- sbc_noise_pvalues(400)
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  withr::local_seed(4401)
  p_broken <- sbc_noise_pvalues(400, debug_break = 4L)
  expect_lt(p_broken[["sigma2"]], 0.001)
})

test_that("SBC of the learned noise of a resampled curve with repeated measurements, and not without its multipliers", {
  # the first coefficient's multiplier is 1, so its reported variance is the learned variance of one
  # measurement with or without the multipliers: the broken run fails by what it learns, not by how
  # it reports (without them the other coefficients' larger noise is taken as that of one measurement)
  mult <- c(1, 1.8, 1.2, 2.4, 2.5, 0.8, 1.5, 2.2)
  withr::local_seed(4405)
  p_ok <- sbc_noise_pvalues(400, mult = mult, df = 6)
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  withr::local_seed(4405)
  p_broken <- sbc_noise_pvalues(400, mult = mult, df = 6, debug_break = 6L)
  expect_lt(p_broken[["sigma2"]], 0.001)
})

test_that("SBC of the learned noise, full size, with one and with three replicates", {
  skip_unless_slow()
  # the half-Cauchy's tail puts some truths far from the start: a longer burn-in
  withr::local_seed(4402)
  p_one <- sbc_noise_pvalues(3000, burnin = 1500L)
  expect_true(all(p_one > 0.01), label = paste(signif(p_one, 3), collapse = ", "))
  withr::local_seed(4403)
  p_three <- sbc_noise_pvalues(2000, R = 3L, family = "half-normal")
  expect_true(all(p_three > 0.01), label = paste(signif(p_three, 3), collapse = ", "))
  withr::local_seed(4404)
  p_broken <- sbc_noise_pvalues(2000, R = 3L, debug_break = 4L, family = "half-normal")
  expect_lt(p_broken[["sigma2"]], 0.001)
})

# One input, one bias level, one field curve with 6 df of repeated
# measurements and the noise learned under a half-Cauchy prior of scale 0.3.
# `run(debug_break)`: the chain's draws (u1, log sigma2, log tau2; tau2 free,
# the adaptive sampler), every third one (tau2's effective sample size is
# about 600 of 1500); `margins(c)`: the posterior's margins (cdfs) on a grid
# of (u1, log sigma2, log tau2), tau2's prior 1 / (tau2 + c).
learned_noise_grid <- function() {
  withr::local_seed(4410)
  scale <- 0.3
  pb <- small_problem(two_inputs = FALSE, level = 4L)
  n <- length(pb$basis$index)
  spec <- calibration_spec(pb$emulators, field_from_coef(pb$basis, matrix(0, 1, n)), pb$iu,
                           sigma2 = noise_prior(scale = scale))
  bank <- pb$emulators$banks$site1
  wbar <- drop(gasp_bank_predict_cpp(bank, matrix(0.4, 1))$mean) + stats::rnorm(n, 0, sqrt(0.02 + 0.01))
  ss <- 0.01 * stats::rchisq(1, 6)
  spec$sites$site1$wbar <- wbar
  spec$sites$site1$noise[c("ss", "df")] <- list(ss, 6)
  run <- function(debug_break = 0L) {
    out <- calibrate_chain_cpp(spec$sites, spec$priors, list(
      n_groups = 1L, z_init = 0.5, tau2_init = numeric(0), fix_tau2 = FALSE, n_draws = 1500L, n_inner = 30L,
      step = 0.5, seed = 3, chain = 1L, debug_break = debug_break, adaptive = TRUE, burnin = 3000L, n_search = 50L))
    keep <- seq(1, 1500, by = 3)
    list(u1 = out$inputs[keep, 1], sigma2 = log(out$sigma2[[1]][keep, 1]), tau2 = log(out$tau2[keep, 1]))
  }
  u <- seq(0.0025, 0.9975, by = 0.005)
  eta <- seq(log(1e-4), log(2), length.out = 60)
  lt <- seq(log(1e-6), log(3), length.out = 120)
  P <- gasp_bank_predict_cpp(bank, matrix(u, ncol = 1))
  S <- outer(exp(eta), rep(1, length(lt)))
  Tt <- outer(rep(1, length(eta)), exp(lt))
  # the repeats' scatter, the half-Cauchy prior of the sd with the Jacobian of log sigma2, log tau2's Jacobian
  rest <- matrix(-0.5 * (6 * eta + ss / exp(eta)) - log1p(exp(eta) / scale^2) + 0.5 * eta, length(eta), length(lt)) +
    log(Tt)
  ll <- array(0, c(length(u), length(eta), length(lt)))
  for (a in seq_along(u)) {
    l <- rest
    for (i in seq_len(n)) {
      tot <- P$var[a, i] + S + Tt
      l <- l - 0.5 * (log(tot) + (wbar[i] - P$mean[a, i])^2 / tot)
    }
    ll[a, , ] <- l
  }
  edge <- function(x) x + diff(x)[1] / 2
  margins <- function(c_tau) {
    lp <- sweep(ll, 2:3, -log(Tt + c_tau), `+`)
    d <- exp(lp - max(lp))
    cdf <- function(x, m) stats::approxfun(edge(x), cumsum(m) / sum(m), yleft = 0, yright = 1)
    list(u1 = cdf(u, apply(d, 1, sum)), sigma2 = cdf(eta, apply(d, 2, sum)), tau2 = cdf(lt, apply(d, 3, sum)))
  }
  list(run = run, margins = margins, scale = scale, S = S)
}

ks_pvalues <- function(draws, m) {
  vapply(names(m), function(q) suppressWarnings(stats::ks.test(draws[[q]], m[[q]])$p.value), numeric(1))
}

test_that("with the noise learned and tau2 free, the draws follow their posterior on a grid, tau2's prior at the noise prior's scale; not without tau2's Hastings ratio", {
  g <- learned_noise_grid()
  post <- g$margins(g$scale^2)
  ok <- g$run()
  p_ok <- ks_pvalues(ok, post)
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  # a tau2 prior whose scale follows the learned sigma2 is another posterior, told apart
  expect_lt(ks_pvalues(ok, g$margins(g$S))[["tau2"]], 0.001)
  expect_lt(ks_pvalues(g$run(debug_break = 2L), post)[["tau2"]], 0.001)
})

test_that("how the noise was set is stored, printed and checked", {
  ex <- example_problem()
  one <- ex$field
  one$curves$site1 <- one$curves$site1[1, , drop = FALSE]
  run <- function(field, ...) {
    calibrate(ex$emulators, field, ex$iu, chains = 1, seed = 1, bias = bias_control(...),
              sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 200, n_search = 10, quiet = TRUE))
  }
  expect_message(fit <- suppressWarnings(run(one)), "learned", class = "wavevalid_message")
  expect_identical(fit$noise_setting, c(site1 = "learned"))
  expect_identical(fit$noise_prior$family, "half-cauchy")
  # one variance for all coefficients, moved between draws
  expect_true(all(apply(fit$sigma2$site1, 1, function(v) length(unique(v)) == 1L)))
  expect_gt(length(unique(fit$sigma2$site1[, 1])), 5)
  expect_true(any(grepl("site1: learned, one variance for all coefficients; half-cauchy prior", capture.output(print(fit)))))
  expect_true(any(grepl("site1: learned", capture.output(print(summary(fit))))))
  fit4 <- suppressWarnings(run(ex$field))
  expect_identical(fit4$noise_setting, c(site1 = "replicates"))
  expect_true(any(grepl("site1: from 4 replicates", capture.output(print(fit4)))))
  fitg <- suppressWarnings(run(one, sigma2 = 0.03^2))
  expect_identical(fitg$noise_setting, c(site1 = "given"))
  expect_true(any(grepl("site1: given by the user", capture.output(print(fitg)))))
  fitf <- suppressWarnings(run(one, sigma2 = "finest"))
  expect_identical(fitf$noise_setting, c(site1 = "finest"))
  fitn <- suppressWarnings(run(ex$field, sigma2 = noise_prior(scale = 0.05, family = "half-normal")))
  expect_identical(fitn$noise_setting, c(site1 = "learned"))
  expect_identical(fitn$noise_prior$scale, c(site1 = 0.05))
  # classed errors, before any sampling
  expect_error(run(one, sigma2 = -1), class = "wavevalid_error_input")
  expect_error(run(one, sigma2 = "median"), class = "wavevalid_error_input")
  expect_error(run(one, sigma2 = list(other = 1)), class = "wavevalid_error_input")
  expect_error(run(one, sigma2 = noise_prior(scale = c(a = 1, b = 2))), class = "wavevalid_error_input")
  expect_error(noise_prior(scale = -1), class = "wavevalid_error_input")
  expect_error(noise_prior(family = "cauchy"), class = "wavevalid_error_input")
  expect_snapshot(print(noise_prior(scale = 0.1)))
})

test_that("field_runs() averages repeated time stamps and keeps their scatter, the curve's detail and the resampling", {
  withr::local_seed(21)
  t0 <- seq(0, 1, length.out = 40)
  t_obs <- sort(c(t0, t0[c(3, 10, 11, 30)]))
  Y <- rbind(sin(2 * pi * t_obs), cos(2 * pi * t_obs)) + matrix(rnorm(2 * length(t_obs), sd = 0.1), 2)
  grid <- seq(-0.01, 1, length.out = 64)
  expect_message(f <- field_runs(Y, t_obs, grid = grid), class = "wavevalid_message")
  expect_identical(f$t, grid)
  nz <- f$noise$site1
  k <- match(t_obs, t0)
  avg <- t(apply(Y, 1, function(y) tapply(y, k, mean)))
  expect_equal(nz$ss, sum((Y - avg[, k])^2))
  expect_identical(nz$df, 8)
  expect_identical(nz$n_repeated, 4L)
  expect_equal(f$curves$site1[2, ], stats::approx(t0, avg[2, ], xout = grid, rule = 2)$y)
  # the multipliers are the diagonal of Psi' A D A' Psi, A the interpolation
  A <- sapply(seq_along(t0), function(j) stats::approx(t0, as.numeric(seq_along(t0) == j), xout = grid, rule = 2)$y)
  D <- diag(1 / tabulate(k, length(t0)))
  Psi <- qr.Q(qr(matrix(rnorm(64 * 9), 64, 9)))
  expect_equal(resampled_noise_multipliers(nz$map, Psi), diag(t(Psi) %*% A %*% D %*% t(A) %*% Psi))
  # on a dyadic grid without repeats there is nothing to keep
  expect_null(field_runs(Y[, !duplicated(t_obs)][, 1:32], t0[1:32])$noise)
  expect_error(field_runs(Y[, rev(seq_along(t_obs))], rev(t_obs)), class = "wavevalid_error")
  expect_error(field_runs(Y, t_obs, grid = seq(-0.2, 1, length.out = 64)), class = "wavevalid_error_grid")
  expect_error(field_runs(Y, t_obs, grid = seq(0, 1, length.out = 60)), class = "wavevalid_error_grid")
})

test_that("the noise learned from one curve with repeated time stamps recovers the truth", {
  skip_on_cran()
  f <- function(t, a, b) sin(2 * pi * t * (1 + a)) + b * t
  tg <- seq(0, 1, length.out = 128)
  withr::local_seed(1)
  design <- data.frame(a = runif(25), b = runif(25))
  runs <- model_runs(design, t(apply(design, 1, function(z) f(tg, z[1], z[2]))), tg)
  iu <- iu_map(c("a", "b"), c("calibration", "calibration"), c(0, 0), c(1, 1))
  # 100 time stamps, every other one measured twice, noise sd 0.05
  t0 <- seq(0, 1, length.out = 100)
  t_obs <- sort(c(t0, t0[seq(1, 100, by = 2)]))
  for (seed in 1:3) {
    withr::local_seed(seed)
    y <- f(t_obs, 0.4, 0.6) + rnorm(length(t_obs), sd = 0.05)
    field <- suppressMessages(field_runs(rbind(y), t_obs, grid = tg))
    fit <- suppressWarnings(suppressMessages(validate(runs, field, iu, chains = 1, seed = seed,
                                                      sampler = sampler_control(n_draws = 300, n_inner = 20, quiet = TRUE))))
    ev <- fit$noise_evidence$site1
    sd_draws <- sqrt(fit$sigma2$site1[, 1] / ev$mult[1])
    expect_lt(abs(stats::median(sd_draws) / 0.05 - 1), 0.3)
    expect_true(any(grepl("repeated measurements in the likelihood", capture.output(print(fit)))))
  }
})

test_that("on the flyer plate the learned noise lies between the robust and the plain scatter of the repeats", {
  skip_on_cran()
  fl <- load_flyer()
  nz <- fl$field$noise$velocity
  expect_identical(nz$df, 34)
  pairs_sd <- sqrt(nz$ss / nz$df)
  expect_equal(pairs_sd, 4.3e-4, tolerance = 0.02)
  fit <- suppressWarnings(suppressMessages(validate(fl$runs, fl$field, fl$iu, chains = 1, seed = 1,
                                                    sampler = sampler_control(n_draws = 100, n_inner = 20, quiet = TRUE))))
  sd_draws <- sqrt(fit$sigma2$velocity[, 1] / fit$noise_evidence$velocity$mult[1])
  # the repeats' sd is held up by two pairs on the steep rise (differences of 2.4e-3 and 2.0e-3; the
  # pairs' MAD-based sd is 1.7e-4), and the curve's own difference residuals (65 effective df, capped
  # at 3 MAD-based sds where the curve bends) say 1.0e-4: the learned sd (2.6e-4) lies between the
  # repeats' robust and plain sd. With no evidence from the measurements in the likelihood it was
  # 2.9 times the repeats' sd.
  pairs <- vapply(split(fl$raw$velocity, fl$raw$t), function(v) if (length(v) == 2L) diff(v) else NA_real_, 0)
  robust_sd <- stats::mad(pairs, na.rm = TRUE) / sqrt(2)
  expect_gt(stats::median(sd_draws), robust_sd)
  expect_lt(stats::median(sd_draws), 1.1 * pairs_sd)
})
