# explain_bias() with re-validated models as candidates: the example problem's
# model with a bump of strength s_bump added, on the example's basis and field.
refit_problem <- function(bump = 0.1, upper = 1) {
  ex <- example_problem()
  t <- ex$field$t
  truth <- (1 + 0.5 * 0.55) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2) +
    bump * exp(-((t - 0.25) / 0.05)^2)
  ex$field$curves$site1 <- withr::with_seed(7, t(replicate(4, truth + rnorm(length(t), sd = 0.03))))
  model <- function(u, x, s) (1 + 0.5 * x) * sin(2 * pi * t) + u * exp(-((t - 0.6) / 0.08)^2) +
    s / upper * 0.5 * exp(-((t - 0.25) / 0.05)^2)
  K <- 30
  design <- withr::with_seed(21, data.frame(u1 = (sample(K) - runif(K)) / K, x1 = (sample(K) - runif(K)) / K,
                                            s_bump = upper * (sample(K) - runif(K)) / K))
  runs <- model_runs(design, t(apply(design, 1, function(z) model(z[1], z[2], z[3]))), t, site = "site1")
  iu <- iu_map(c("u1", "x1", "s_bump"), c("calibration", "variation", "calibration"),
               lower = c(0, 0, 0), upper = c(1, 1, upper), nominal = c(0.5, 0.5, upper / 2))
  em <- suppressWarnings(fit_emulators(runs, ex$emulators$basis))
  list(ex = ex, em = em, iu = iu, model = model, t = t)
}

# The log Bayes factor of s_bump free against s_bump = 0 by quadrature over
# (u1, x1, s_bump), with the field and bias variances fixed.
exact_log_bf <- function(fit, sigma2, tau2, upper) {
  g <- seq(0, 1, length.out = 81)
  w <- c(0.5, rep(1, 79), 0.5) / 80
  Z <- as.matrix(expand.grid(u1 = g, x1 = g, s_bump = upper * g))
  pr <- fit$prior_iu
  lx <- dnorm(Z[, "x1"], pr$nominal[pr$name == "x1"], pr$prior_sd[pr$name == "x1"], log = TRUE)
  P <- gasp_bank_predict_cpp(fit$emulators$banks$site1, Z)
  tot <- sweep(P$var, 2, sigma2 / fit$n_rep$site1 + tau2, "+")
  ll <- -0.5 * rowSums(log(tot) + sweep(P$mean, 2, fit$wbar$site1)^2 / tot) + lx
  lse <- function(x, wt) max(x) + log(sum(wt * exp(x - max(x))))
  off <- Z[, "s_bump"] == 0
  lse(ll, as.vector(outer(outer(w, w), w))) - lse(ll[off], as.vector(outer(w, w)))
}

test_that("the Savage-Dickey Bayes factor of a re-validated model matches quadrature", {
  withr::local_options(list(wavevalid.quiet = TRUE))
  cases <- list(list(bump = 0.1, sigma2 = 0.02, tau2 = 0.004, upper = 1),
                list(bump = 0.1, sigma2 = 0.005, tau2 = 0.001, upper = 2),
                list(bump = 0, sigma2 = 0.02, tau2 = 0.004, upper = 2))
  for (cs in cases) {
    p <- refit_problem(cs$bump, cs$upper)
    base <- calibrate(p$ex$emulators, p$ex$field, p$ex$iu, chains = 1, seed = 1,
                      bias = bias_control(sigma2 = cs$sigma2, fix_tau2 = cs$tau2),
                      sampler = sampler_control(n_draws = 50, n_inner = 5, quiet = TRUE))
    after <- calibrate(p$em, p$ex$field, p$iu, chains = 1, seed = 2,
                       bias = bias_control(sigma2 = cs$sigma2, fix_tau2 = cs$tau2),
                       sampler = sampler_control(n_draws = 400, n_inner = 5, quiet = TRUE))
    # the runs hold no model with the bump off: the weight rests on the
    # emulators' extrapolation, and the user is told
    expect_warning(ex <- explain_bias(base, list(bump = after), n_draws = 400),
                   class = "wavevalid_warning_refit_off")
    exact <- exact_log_bf(after, cs$sigma2, cs$tau2, cs$upper)
    lab <- sprintf("bump %g, upper %g: exact %.3f", cs$bump, cs$upper, exact)
    expect_lt(abs(attr(ex, "log_bf")[["bump"]] - exact), 0.3, label = paste(lab, "estimate", attr(ex, "log_bf")))
    # no mechanism and the bump alone, equally likely a priori
    expect_equal(ex$inclusion_prob, unname(plogis(attr(ex, "log_bf"))), label = lab)
  }
})

test_that("re-validated models: the missing bump is found, a misplaced one and nothing hidden are not", {
  withr::local_options(list(wavevalid.quiet = TRUE))
  p <- refit_problem(bump = 0.3)
  base <- suppressWarnings(calibrate(p$ex$emulators, p$ex$field, p$ex$iu, chains = 1, seed = 1,
                                     sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)))
  after <- suppressWarnings(calibrate(p$em, p$ex$field, p$iu, chains = 1, seed = 2,
                                      sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)))
  # the same model with its bump late, where reality has none
  late <- function(u, x, s) p$model(u, x, 0) + s * 0.5 * exp(-((p$t - 0.8) / 0.05)^2)
  d <- p$em$design
  runs_late <- model_runs(d, t(apply(d, 1, function(z) late(z[1], z[2], z[3]))), p$t, site = "site1")
  em_late <- suppressWarnings(fit_emulators(runs_late, p$ex$emulators$basis))
  after_late <- suppressWarnings(calibrate(em_late, p$ex$field, p$iu, chains = 1, seed = 3,
                                           sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)))
  ex <- suppressWarnings(explain_bias(base, list(late_bump = after_late, bump = after)))
  expect_s3_class(ex, "wv_explain")
  expect_named(ex, c("candidate", "inclusion_prob", "amplitude", "amplitude_lower", "amplitude_upper",
                     "share_explained", "share_of_bias"))
  expect_identical(ex$candidate, c("bump", "late_bump"))
  expect_gt(ex$inclusion_prob[1], 0.99)
  expect_lt(ex$inclusion_prob[2], 0.01)
  # the strength: 0.3 / 0.5 of the model's bump
  expect_true(ex$amplitude_lower[1] < 0.6 && ex$amplitude_upper[1] > 0.6)
  expect_gt(ex$share_explained[1], 0.7)
  expect_output(print(ex), "re-validated model")
  expect_s3_class(autoplot(ex), "ggplot")
  expect_true(any(startsWith(unique(attr(ex, "curves")$curve), "bump at s_bump")))

  # nothing hidden: neither claims
  q <- refit_problem(bump = 0)
  base0 <- suppressWarnings(calibrate(q$ex$emulators, q$ex$field, q$ex$iu, chains = 1, seed = 1,
                                      sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)))
  a0 <- suppressWarnings(calibrate(q$em, q$ex$field, q$iu, chains = 1, seed = 2,
                                   sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)))
  l0 <- suppressWarnings(calibrate(em_late, q$ex$field, q$iu, chains = 1, seed = 3,
                                   sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)))
  ex0 <- suppressWarnings(explain_bias(base0, list(late_bump = l0, bump = a0)))
  expect_true(all(ex0$inclusion_prob < 0.5), label = paste(round(ex0$inclusion_prob, 3), collapse = ", "))
  sub <- attr(ex0, "subsets")
  expect_identical(sub$subset[1], "(none)")

  # with the model's own runs (the bump switched off) among the runs, no
  # warning, and the missing bump is still found
  d_off <- transform(p$em$design, s_bump = 0)
  runs_off <- model_runs(d_off, t(apply(d_off, 1, function(z) p$model(z[1], z[2], z[3]))), p$t, site = "site1")
  runs_on <- model_runs(p$em$design, t(apply(p$em$design, 1, function(z) p$model(z[1], z[2], z[3]))), p$t,
                        site = "site1")
  em_both <- suppressWarnings(fit_emulators(c(runs_off, runs_on), p$ex$emulators$basis))
  both <- suppressWarnings(calibrate(em_both, p$ex$field, p$iu, chains = 1, seed = 2,
                                     sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)))
  expect_no_warning(ex_off <- explain_bias(base, list(bump = both)))
  expect_gt(ex_off$inclusion_prob[1], 0.99)
})

test_that("re-validated models on another basis or field, without a strength, or mixed with curves are refused", {
  withr::local_options(list(wavevalid.quiet = TRUE))
  p <- refit_problem()
  base <- suppressWarnings(calibrate(p$ex$emulators, p$ex$field, p$ex$iu, chains = 1, seed = 1,
                                     sampler = sampler_control(n_draws = 20, n_inner = 2, quiet = TRUE)))
  after <- suppressWarnings(calibrate(p$em, p$ex$field, p$iu, chains = 1, seed = 1,
                                      sampler = sampler_control(n_draws = 20, n_inner = 2, quiet = TRUE)))
  expect_error(explain_bias(base, list(bump = after, wiggle = sin(6 * pi * p$t))), class = "wavevalid_error_input")
  expect_error(explain_bias(base, list(after)), class = "wavevalid_error_input")
  expect_error(explain_bias(base, list(same = base)), "one more", class = "wavevalid_error_input")
  other <- p$ex$field
  other$curves$site1 <- other$curves$site1 + 0.1
  moved <- suppressWarnings(calibrate(p$em, other, p$iu, chains = 1, seed = 1,
                                      sampler = sampler_control(n_draws = 20, n_inner = 2, quiet = TRUE)))
  expect_error(explain_bias(base, list(bump = moved)), "field data", class = "wavevalid_error_input")
  runs <- model_runs(p$em$design, p$em$design[, 1:3] %*% matrix(rnorm(3 * 32), 3), p$t, site = "site1")
  b2 <- basis_from_index(p$t, 1:8)
  em2 <- suppressWarnings(fit_emulators(runs, b2))
  f2 <- p$ex$field
  expect_error(explain_bias(base, list(bump = suppressWarnings(calibrate(em2, f2, p$iu, chains = 1, seed = 1,
                                                                         sampler = sampler_control(n_draws = 20, n_inner = 2, quiet = TRUE))))),
               "basis", class = "wavevalid_error_input")
  iu_var <- iu_map(c("u1", "x1", "s_bump"), c("calibration", "variation", "variation"),
                   lower = c(0, 0, 0), upper = c(1, 1, 1), nominal = c(0.5, 0.5, 0.5))
  as_var <- suppressWarnings(calibrate(p$em, p$ex$field, iu_var, chains = 1, seed = 1,
                                       sampler = sampler_control(n_draws = 20, n_inner = 2, quiet = TRUE)))
  expect_error(explain_bias(base, list(bump = as_var)), "calibration input", class = "wavevalid_error_input")
})

test_that("the log of a trapezoidal integral is exact for a linear integrand and does not overflow", {
  v <- seq(1, 2, length.out = 7)
  expect_equal(log_trapezoid(v, log(v)), log(1.5))
  w <- seq(-8, 8, length.out = 2001)
  expect_equal(log_trapezoid(w, stats::dnorm(w, log = TRUE) + 1000), 1000, tolerance = 1e-6)
  expect_equal(log_trapezoid(w, stats::dnorm(w, log = TRUE) - 1000), -1000, tolerance = 1e-6)
})
