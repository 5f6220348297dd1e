# The example problem of the diagnosis tests: reality has a bump at t = 0.25
# that the model lacks. The fit, and three candidate curves on its grid.
diag_setup <- function(bias = bias_control()) {
  ex <- example_calibration_inputs()
  t <- ex$field$t
  truth <- (1 + 0.5 * 0.55) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2) +
    0.3 * exp(-((t - 0.25) / 0.05)^2)
  ex$field$curves$site1 <- withr::with_seed(7, t(replicate(4, truth + rnorm(length(t), sd = 0.03))))
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 11, bias = bias,
                                    sampler = sampler_control(n_draws = 150, n_inner = 20, quiet = TRUE)))
  list(ex = ex, fit = fit, t = t,
       candidates = list(bump = exp(-((t - 0.25) / 0.05)^2),
                         late_bump = exp(-((t - 0.8) / 0.05)^2),
                         wiggle = sin(6 * pi * t)))
}

# The diagnosis on the suspension test bed with mechanism `hidden` hidden,
# short chains (testbed_validation()): the test bed, the fit, where_fails()
# and explain_bias() of the four mechanisms' signatures at the posterior mean
# inputs (`explain` without the shift candidates, `all` with them). Fits are
# kept by hidden mechanism and test-bed seed, in each test process
# (test-diagnose.R and test-diagnose-revalidation.R each fit their own).
testbed_fits <- new.env()
testbed_diagnosis <- function(hidden, seed = 1L) {
  key <- paste(hidden, seed)
  if (!is.null(testbed_fits[[key]])) return(testbed_fits[[key]])
  withr::local_options(list(wavevalid.quiet = TRUE))
  v <- testbed_validation(hidden, seed)
  tb <- v$tb
  fit <- v$fit
  z_hat <- colMeans(as.matrix(fit$draws))[fit$inputs]
  ex <- as.data.frame(unclass(explain_bias(fit, testbed_signatures(z_hat), n_draws = 50, seed = 1)))
  out <- list(tb = tb, fit = fit, fails = where_fails(fit), explain = ex[!startsWith(ex$candidate, "shift:"), ],
              all = ex)
  assign(key, out, envir = testbed_fits)
  out
}
