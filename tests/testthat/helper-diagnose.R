# The example problem of the diagnosis tests: reality has a bump at t = 0.25
# that the model lacks. The fit, and three candidate curves on its grid.
diag_setup <- function() {
  ex <- wavevalid:::example_calibration_inputs()
  t <- ex$field$t
  truth <- (1 + 0.5 * 0.55) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2) +
    0.3 * exp(-((t - 0.25) / 0.05)^2)
  ex$field$curves$site1 <- withr::with_seed(7, t(replicate(4, truth + rnorm(length(t), sd = 0.03))))
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, n_draws = 150, n_inner = 20, chains = 2,
                                    seed = 11, quiet = TRUE))
  list(ex = ex, fit = fit, t = t,
       candidates = list(bump = exp(-((t - 0.25) / 0.05)^2),
                         late_bump = exp(-((t - 0.8) / 0.05)^2),
                         wiggle = sin(6 * pi * t)))
}
