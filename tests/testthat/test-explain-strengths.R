# explain_bias() with re-validated models whose mechanism adds several inputs:
# the example problem's model with a bump of strength s_bump and width w_bump
# (a rate of the mechanism, without effect while the bump is off) added. The
# field has a bump of height `bump` and width 0.05 near t = 0.25.
strengths_problem <- function(bump = 0.3, seed = 7) {
  ex <- example_problem()
  t <- ex$field$t
  truth <- (1 + 0.5 * 0.55) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2) +
    bump * exp(-((t - 0.25) / 0.05)^2)
  ex$field$curves$site1 <- withr::with_seed(seed, t(replicate(4, truth + rnorm(length(t), sd = 0.03))))
  K <- 40
  on <- withr::with_seed(21, data.frame(u1 = (sample(K) - runif(K)) / K, x1 = (sample(K) - runif(K)) / K,
                                        s_bump = (sample(K) - runif(K)) / K,
                                        w_bump = 0.03 + 0.07 * (sample(K) - runif(K)) / K))
  # the model's own runs (the bump off) join the runs of the model with it
  design <- rbind(transform(on[1:20, ], s_bump = 0), on)
  base <- function(z) (1 + 0.5 * z[["x1"]]) * sin(2 * pi * t) + z[["u1"]] * exp(-((t - 0.6) / 0.08)^2)
  make <- function(model, d = design) {
    em <- suppressWarnings(fit_emulators(model_runs(d, t(apply(d, 1, model)), t, site = "site1"),
                                         ex$emulators$basis))
    em
  }
  list(ex = ex, t = t, design = design, base = base, make = make)
}

strengths_calibrate <- function(em, field, iu, seed = 2, n_draws = 150, ...) {
  suppressWarnings(calibrate(em, field, iu, chains = 1, seed = seed,
                             sampler = sampler_control(n_draws = n_draws, n_inner = 10, quiet = TRUE), ...))
}

test_that("a mechanism with a strength and a rate: the real one is weighed above a misplaced one", {
  withr::local_options(list(wavevalid.quiet = TRUE))
  p <- strengths_problem(bump = 0.3)
  t <- p$t
  early <- function(z) p$base(z) + z[["s_bump"]] * 0.5 * exp(-((t - 0.25) / z[["w_bump"]])^2)
  late <- function(z) p$base(z) + z[["s_bump"]] * 0.5 * exp(-((t - 0.8) / z[["w_bump"]])^2)
  iu2 <- iu_add(p$ex$iu, c("s_bump", "w_bump"), lower = c(0, 0.03), upper = c(1, 0.1),
                off = c(0, NA))
  expect_identical(attr(iu2, "off"), c(s_bump = 0, w_bump = NA_real_))
  fit <- strengths_calibrate(p$ex$emulators, p$ex$field, p$ex$iu, seed = 1)
  f_early <- strengths_calibrate(p$make(early), p$ex$field, iu2, seed = 2)
  f_late <- strengths_calibrate(p$make(late), p$ex$field, iu2, seed = 3)
  expect_no_warning(ex <- explain_bias(fit, list(late = f_late, early = f_early)))
  expect_identical(ex$candidate, c("early", "late"))
  expect_gt(ex$inclusion_prob[1], 0.99)
  expect_lt(ex$inclusion_prob[2], 0.01)
  # the strength (0.3 / 0.5) and the width (0.05) within their intervals
  ins <- attr(ex, "inputs")
  expect_identical(ins$input, c("s_bump", "w_bump", "s_bump", "w_bump"))
  expect_identical(ins$role, c("strength", "rate", "strength", "rate"))
  e <- ins[ins$candidate == "early", ]
  expect_true(e$lower[1] < 0.6 && e$upper[1] > 0.6, label = paste(signif(e$lower[1], 3), signif(e$upper[1], 3)))
  expect_true(e$lower[2] < 0.05 && e$upper[2] > 0.05, label = paste(signif(e$lower[2], 3), signif(e$upper[2], 3)))
  expect_equal(ex$amplitude[1], e$mean[1])
  expect_output(print(ex), "Inputs added by early: s_bump .*\\(off at 0\\), w_bump .*\\(rate\\)")
  expect_true(any(grepl("^early at s_bump = .*, w_bump = ", unique(attr(ex, "curves")$curve))))
})

test_that("a rate the model ignores leaves the answer of the one-input candidate", {
  withr::local_options(list(wavevalid.quiet = TRUE))
  p <- strengths_problem(bump = 0.15)
  t <- p$t
  # the same content: a bump of fixed width, with and without an input that does nothing
  bump <- function(z) p$base(z) + z[["s_bump"]] * 0.5 * exp(-((t - 0.25) / 0.05)^2)
  ctl <- bias_control(sigma2 = 0.02, fix_tau2 = 0.004)
  fit <- strengths_calibrate(p$ex$emulators, p$ex$field, p$ex$iu, seed = 1, n_draws = 50, bias = ctl)
  iu1 <- iu_add(p$ex$iu, "s_bump", lower = 0, upper = 1)
  iu2 <- iu_add(p$ex$iu, c("s_bump", "w_bump"), lower = c(0, 0.03), upper = c(1, 0.1), off = c(0, NA))
  one <- strengths_calibrate(p$make(bump, p$design[, 1:3]), p$ex$field, iu1, n_draws = 400, bias = ctl)
  two <- strengths_calibrate(p$make(bump), p$ex$field, iu2, n_draws = 400, bias = ctl)
  ex <- explain_bias(fit, list(one = one, two = two), n_draws = 400)
  lbf <- attr(ex, "log_bf")
  expect_gt(lbf[["one"]], 0.5)
  expect_lt(abs(lbf[["one"]] - lbf[["two"]]), 0.5, label = paste(signif(lbf, 3), collapse = " vs "))
  ins <- attr(ex, "inputs")
  s1 <- ins[ins$candidate == "one", ]
  s2 <- ins[ins$candidate == "two" & ins$input == "s_bump", ]
  expect_lt(abs(s1$mean - s2$mean), 0.05)
  # the same no-effect value given or inferred (the lower bound of a single added input)
  iu1_off <- iu_add(p$ex$iu, "s_bump", lower = 0, upper = 1, off = 0)
  one_off <- one
  one_off$iu <- iu1_off
  expect_equal(attr(explain_bias(fit, list(one = one_off), n_draws = 50), "log_bf"),
               attr(explain_bias(fit, list(one = one), n_draws = 50), "log_bf"))
})

test_that("a strength whose no-effect value is its upper bound is weighed at that value", {
  withr::local_options(list(wavevalid.quiet = TRUE))
  p <- strengths_problem(bump = -0.3)
  t <- p$t
  # the strength runs over [-1, 0], 0 switching the dip off
  d <- transform(p$design, s_bump = s_bump - 1)
  d$s_bump[1:20] <- 0
  dip <- function(z) p$base(z) + z[["s_bump"]] * 0.5 * exp(-((t - 0.25) / 0.05)^2)
  em <- p$make(dip, d[, 1:3])
  fit <- strengths_calibrate(p$ex$emulators, p$ex$field, p$ex$iu, seed = 1)
  iu_neg <- iu_add(p$ex$iu, "s_bump", lower = -1, upper = 0, off = 0)
  f_neg <- strengths_calibrate(em, p$ex$field, iu_neg)
  expect_no_warning(ex <- explain_bias(fit, list(dip = f_neg)))
  expect_gt(ex$inclusion_prob, 0.99)
  expect_equal(attr(ex, "inputs")$off, 0)
  expect_true(ex$amplitude_lower < -0.6 && ex$amplitude_upper > -0.6)
  # nothing hidden: the same model is not claimed
  q <- strengths_problem(bump = 0)
  fit0 <- strengths_calibrate(q$ex$emulators, q$ex$field, q$ex$iu, seed = 1)
  f0 <- strengths_calibrate(em, q$ex$field, iu_neg)
  expect_lt(explain_bias(fit0, list(dip = f0))$inclusion_prob, 0.5)
})

test_that("added inputs without a no-effect value, or a candidate lacking an input, are refused", {
  withr::local_options(list(wavevalid.quiet = TRUE))
  p <- strengths_problem()
  t <- p$t
  model <- function(z) p$base(z) + z[["s_bump"]] * 0.5 * exp(-((t - 0.25) / z[["w_bump"]])^2)
  em <- p$make(model)
  fit <- strengths_calibrate(p$ex$emulators, p$ex$field, p$ex$iu, seed = 1, n_draws = 20)
  iu_none <- iu_add(p$ex$iu, c("s_bump", "w_bump"), lower = c(0, 0.03), upper = c(1, 0.1))
  f_none <- strengths_calibrate(em, p$ex$field, iu_none, n_draws = 20)
  expect_error(explain_bias(fit, list(bump = f_none)), "no-effect value", class = "wavevalid_error_input")
  iu_rates <- iu_add(p$ex$iu, c("s_bump", "w_bump"), lower = c(0, 0.03), upper = c(1, 0.1), off = c(NA, NA))
  f_rates <- strengths_calibrate(em, p$ex$field, iu_rates, n_draws = 20)
  expect_error(explain_bias(fit, list(bump = f_rates)), "one or two", class = "wavevalid_error_input")
  expect_error(iu_add(p$ex$iu, c("s_bump", "w_bump"), lower = c(0, 0.03), upper = c(1, 0.1), off = c(2, NA)),
               "inside its range", class = "wavevalid_error_input")
  expect_error(iu_add(p$ex$iu, c("s_bump", "w_bump"), lower = c(0, 0.03), upper = c(1, 0.1), off = 0),
               class = "wavevalid_error_input")
  # the candidate drops x1 of the fit
  iu_drop <- iu_add(p$ex$iu[1, ], c("s_bump", "w_bump"), lower = c(0, 0.03), upper = c(1, 0.1), off = c(0, NA))
  em_drop <- suppressWarnings(fit_emulators(model_runs(transform(p$design, x1 = NULL),
                                                       t(apply(p$design, 1, model)), t, site = "site1"),
                                            p$ex$emulators$basis))
  f_drop <- strengths_calibrate(em_drop, p$ex$field, iu_drop, n_draws = 20)
  expect_error(explain_bias(fit, list(bump = f_drop)), "lacks", class = "wavevalid_error_input")
})

test_that("update() takes a mechanism that adds two inputs, their no-effect values kept", {
  withr::local_options(list(wavevalid.quiet = TRUE))
  ex <- example_problem()
  runs <- model_runs(as.data.frame(ex$emulators$design),
                     ex$emulators$banks$site1$y %*% t(ex$emulators$basis$Psi), ex$field$t, site = "site1")
  fit <- suppressWarnings(validate(runs, ex$field, ex$iu, seed = 1, chains = 1,
                                   sampler = sampler_control(n_draws = 20, n_inner = 2, quiet = TRUE)))
  d <- runs$design
  d$s_bump <- withr::with_seed(3, runif(nrow(d)))
  d$w_bump <- withr::with_seed(4, runif(nrow(d), 0.03, 0.1))
  t <- runs$t
  curves <- runs$curves$site1 + 0.5 * d$s_bump * exp(-outer(1 / d$w_bump, t - 0.25)^2)
  runs2 <- model_runs(d, curves, t, site = "site1")
  iu2 <- iu_add(ex$iu, c("s_bump", "w_bump"), lower = c(0, 0.03), upper = c(1, 0.1), off = c(0, NA))
  expect_error(update(fit, runs = runs2, iu = iu_add(ex$iu, "s_bump", lower = 0, upper = 1)),
               "w_bump", class = "wavevalid_error_update")
  fit2 <- suppressWarnings(update(fit, runs = runs2, iu = iu2))
  expect_true(all(c("s_bump", "w_bump") %in% fit2$inputs))
  expect_identical(attr(fit2$iu, "off"), c(s_bump = 0, w_bump = NA_real_))
})

test_that("the trapezoidal integral over a grid of two strengths is exact for a bilinear integrand", {
  axes <- list(c(0, 0.3, 1), c(0, 0.5, 1.2, 2))
  S <- as.matrix(expand.grid(axes))
  expect_equal(log_trapezoid_grid(axes, log((1 + S[, 1]) * (2 + S[, 2]))), log(1.5 * 6))
  expect_equal(log_trapezoid_grid(axes[1], log(1 + axes[[1]])), log(1.5))
})
