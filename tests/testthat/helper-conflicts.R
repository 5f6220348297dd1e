# example_problem()'s model, (1 + x / 2) sin(2 pi t) + u1 * bump(0.6), with
# reality at inputs `u`, `x` plus `extra` (a curve on the grid); u1's prior
# normal(0.3, sd 0.1) on [0, 1].
conflict_problem <- function(u, x = 0.55, extra = 0, seed = 4) {
  ex <- example_problem()
  t <- ex$field$t
  truth <- (1 + 0.5 * x) * sin(2 * pi * t) + u * exp(-((t - 0.6) / 0.08)^2) + extra
  withr::with_seed(seed, {
    reps <- t(replicate(4, truth + stats::rnorm(length(t), sd = 0.03)))
  })
  ex$field <- field_runs(reps, t, x_nom = c(x1 = 0.5), site = "site1")
  ex$iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), lower = c(0, 0), upper = c(1, 1),
                  prior = c("normal", "normal"), prior_mean = c(0.3, NA), prior_sd = c(0.1, NA))
  ex
}

conflict_fit <- function(ex, seed = 1) {
  suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = seed,
                             sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)),
                   classes = c("wavevalid_warning_mixing", "wavevalid_warning_boundary"))
}
