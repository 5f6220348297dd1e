test_that("explain_bias weighs each coefficient by the tau2 of its group, pooled levels included", {
  ex <- example_problem()
  lv <- sort(unique(ex$emulators$basis$level))
  pool <- lv[1:2]
  fit <- calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1,
                   bias = bias_control(pool_levels = pool),
                   sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE))
  d <- as.matrix(fit$draws)
  V <- bias_level_variances(fit, d)
  name <- sprintf("tau2[site1:%d-%d]", pool[1], pool[2])
  pooled <- fit$basis$level %in% pool
  expect_equal(unname(V[, pooled]), matrix(d[, name], nrow(d), sum(pooled)))
  other <- which(!pooled)[1]
  expect_equal(unname(V[, other]), unname(d[, sprintf("tau2[site1:%d]", fit$basis$level[other])]))
  t <- ex$field$t
  out <- explain_bias(fit, list(bump = exp(-((t - 0.25) / 0.05)^2)), n_draws = 10, seed = 1)
  expect_s3_class(out, "wv_explain")
})

test_that("candidates on the user's grid of a non-dyadic field are interpolated to the fit's grid", {
  # runs and field on 480 points, interpolated to 512 by model_runs() and field_runs()
  t480 <- seq(0, 2, length.out = 480)
  bump <- function(t, at) exp(-((t - at) / 0.08)^2)
  model <- function(u, x) sin(pi * t480) * (1 + 0.3 * x) + u * bump(t480, 1.2)
  design <- data.frame(u = seq(0, 1, length.out = 10), x = c(0.5, 0.1, 0.9, 0.3, 0.7, 0.2, 0.8, 0.4, 0.6, 0))
  withr::local_seed(1)
  expect_message(runs <- model_runs(design, t(mapply(model, design$u, design$x)), t480), "not dyadic")
  reps <- t(replicate(3, model(0.4, 0.5) + 0.3 * bump(t480, 0.5) + stats::rnorm(480, sd = 0.01)))
  field <- suppressMessages(field_runs(reps, t480))
  iu <- iu_map(c("u", "x"), c("calibration", "variation"), c(0, 0), c(1, 1))
  fit <- suppressWarnings(validate(runs, field, iu, chains = 1, seed = 1,
                                   sampler = sampler_control(n_draws = 40, n_inner = 5, quiet = TRUE)))
  tb <- fit$basis$t
  expect_length(tb, 512L)

  cand <- list(early = bump(t480, 0.5), late = bump(t480, 1.6))
  expect_message(got <- explain_bias(fit, cand, n_draws = 20, seed = 1),
                 "interpolated to it from 480 equally spaced points", class = "wavevalid_message")
  by_hand <- lapply(cand, function(y) stats::approx(t480, y, xout = tb)$y)
  expect_equal(got, explain_bias(fit, by_hand, n_draws = 20, seed = 1))
  # the same curves computed on the fit's grid: within the interpolation error
  on_fit <- explain_bias(fit, list(early = bump(tb, 0.5), late = bump(tb, 1.6)), n_draws = 20, seed = 1)
  expect_equal(got$inclusion_prob, on_fit$inclusion_prob, tolerance = 1e-3)
  expect_equal(got$amplitude, on_fit$amplitude, tolerance = 1e-2)
  expect_identical(got$candidate[1], "early")

  # a grid given explicitly, not equally spaced, and curves by site
  tu <- 2 * seq(0, 1, length.out = 300)^1.3
  by_site <- list(early = list(site1 = bump(tu, 0.5)), late = list(site1 = bump(tu, 1.6)))
  expect_message(got_t <- explain_bias(fit, by_site, n_draws = 20, seed = 1, t = tu), "the 300 points of `t`")
  by_hand_t <- lapply(by_site, function(y) stats::approx(tu, y$site1, xout = tb)$y)
  expect_equal(got_t, explain_bias(fit, by_hand_t, n_draws = 20, seed = 1))
  # curves on the fit's grid pass as they are, with `t` or without
  expect_no_message(explain_bias(fit, by_hand, n_draws = 5, seed = 1, t = tu))

  # candidates that cannot be placed
  expect_error(explain_bias(fit, by_site, t = 2 * tu), class = "wavevalid_error_grid")
  expect_error(explain_bias(fit, by_site, t = rev(tu)), class = "wavevalid_error_grid")
  expect_error(explain_bias(fit, list(short = c(0, 1, 0))), class = "wavevalid_error_grid")
  # 200 equally spaced points would have gone to a grid of 256, not this one
  expect_error(explain_bias(fit, list(coarse = bump(seq(0, 2, length.out = 200), 0.5))),
               class = "wavevalid_error_grid")
  expect_error(explain_bias(fit, list(other = bump(t480[-1], 0.5)), t = tu), class = "wavevalid_error_grid")
  holed <- cand$early
  holed[10] <- NA
  expect_error(explain_bias(fit, list(holed = holed)), class = "wavevalid_error_input")
})

test_that("a candidate the inputs' shifts span is skipped with a message, a partly spanned one is weighed", {
  fit <- example_fit()
  sh <- shift_candidates(fit)
  Psi <- fit$basis$Psi
  t <- fit$basis$t
  same <- list(site1 = drop(Psi %*% (sh[, 1] - 2 * sh[, 2])))
  bump <- list(site1 = 0.3 * exp(-((t - 0.25) / 0.05)^2))
  msg <- expect_message(ex <- explain_bias(fit, list(same = same, bump = bump), shifts = TRUE),
                        class = "wavevalid_message_spanned")
  expect_match(conditionMessage(msg), "same", fixed = TRUE)
  expect_false("same" %in% ex$candidate)
  expect_true("bump" %in% ex$candidate)
  expect_equal(attr(ex, "absorbed")$absorbed[attr(ex, "absorbed")$candidate == "same"], 1)
  # without the shifts nothing is skipped
  expect_no_message(ex0 <- explain_bias(fit, list(same = same, bump = bump), shifts = FALSE),
                    class = "wavevalid_message_spanned")
  expect_true("same" %in% ex0$candidate)
})
