# A small problem whose emulators are overconfident away from the design:
# a rough function of the inputs, few runs, one fit per coefficient (the
# "gasp" engine: the per-level engine is not overconfident here).
rough_problem <- function() {
  t <- seq(0, 1, length.out = 64)
  f <- function(z) sin(2 * pi * t * (1 + 0.8 * z[1])) + 0.5 * sin(9 * z[2]) * exp(-30 * (t - 0.4)^2)
  runs_of <- function(design) model_runs(design, t(apply(design, 1, f)), t, site = "site1")
  design <- withr::with_seed(3, data.frame(x1 = (sample(14) - stats::runif(14)) / 14,
                                           x2 = (sample(14) - stats::runif(14)) / 14))
  held <- function(seed, n) {
    withr::with_seed(seed, data.frame(x1 = stats::runif(n), x2 = stats::runif(n)))
  }
  runs <- runs_of(design)
  em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, fraction = 1), engine = "gasp"))
  list(em = em, runs_of = runs_of, held = held)
}

test_that("rescale_emulators widens each level's variances by the mean squared studentised error", {
  p <- rough_problem()
  check <- p$runs_of(p$held(11, 25))
  em2 <- rescale_emulators(p$em, check)
  expect_s3_class(em2, "wv_emulators")
  vc <- em2$variance_check
  expect_named(vc, c("site", "level", "n_errors", "rms_before", "scale"))
  expect_true(all(vc$scale >= 1))
  expect_true(any(vc$scale > 1))
  expect_equal(vc$scale, pmax(1, vc$rms_before^2))
  # means unchanged, variances multiplied by the level's factor
  z <- data.frame(x1 = c(0.2, 0.55, 0.9), x2 = c(0.7, 0.3, 0.45))
  a <- predict(p$em, z, site = "site1")
  b <- predict(em2, z, site = "site1")
  expect_equal(b$mean, a$mean)
  scale <- vc$scale[match(p$em$params$level, vc$level)]
  expect_equal(b$var, sweep(a$var, 2, scale, `*`))
  expect_equal(em2$params$variance_scale, scale)
  # at the same runs, the studentised errors of every widened level now have mean square 1
  s2 <- summary(em2, new_runs = check)$by_level
  widened <- s2$level %in% vc$level[vc$scale > 1]
  expect_equal(s2$heldout_rms[widened], rep(1, sum(widened)))
  expect_message(print(em2), "Predictive variances widened at")
})

test_that("rescaled emulators are better calibrated at other held-out runs", {
  p <- rough_problem()
  em2 <- rescale_emulators(p$em, p$runs_of(p$held(11, 25)))
  other <- p$runs_of(p$held(12, 40))
  ms <- function(em) {
    h <- heldout_residuals(em, other)
    mean(h$residual[is.finite(h$residual)]^2)
  }
  before <- ms(p$em)
  after <- ms(em2)
  expect_gt(before, 2)
  # closer to 1 on the log scale, and no longer far above it
  expect_lt(abs(log(after)), abs(log(before)))
  expect_lt(after, 2)
})

test_that("a calibration with rescaled emulators has a wider posterior", {
  ex <- example_problem()
  em <- ex$emulators
  em$banks$site1$lambda <- em$banks$site1$lambda / 25
  wide <- suppressWarnings(calibrate(em, ex$field, ex$iu, chains = 1, seed = 3,
                                     sampler = sampler_control(n_draws = 100, n_inner = 10, quiet = TRUE)))
  narrow <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 3,
                                       sampler = sampler_control(n_draws = 100, n_inner = 10, quiet = TRUE)))
  sd_of <- function(fit) apply(as.matrix(fit$draws)[, fit$inputs], 2, stats::sd)
  expect_true(all(sd_of(wide) > sd_of(narrow)))
})

test_that("rescale_emulators refuses runs it cannot use", {
  p <- rough_problem()
  expect_error(rescale_emulators(p$em, data.frame(x1 = 0.5, x2 = 0.5)), class = "wavevalid_error_input")
  expect_error(rescale_emulators(p$em, p$runs_of(p$em$design[1:3, , drop = FALSE] |> as.data.frame())),
               class = "wavevalid_error_input")
  check <- p$runs_of(p$held(11, 25))
  em2 <- rescale_emulators(p$em, check)
  expect_error(rescale_emulators(em2, check), class = "wavevalid_error_input")
  expect_error(rescale_emulators(p$em, check, min_errors = 0), class = "wavevalid_error_input")
  expect_warning(few <- rescale_emulators(p$em, p$runs_of(p$held(11, 3)), min_errors = 5),
                 class = "wavevalid_warning_rescale")
  expect_true(all(few$variance_check$scale[few$variance_check$n_errors < 5] == 1))
  expect_snapshot(rescale_emulators(em2, check), error = TRUE)
})
