# The story every print() and summary() tells, on one small problem.

print_problem <- function() {
  set.seed(21)
  t <- seq(0, 8, length.out = 129)[-129]
  model <- function(u, x) {
    (1 + 0.4 * x) * exp(-((t - 2 - 0.3 * u) / 0.3)^2) - 0.6 * exp(-((t - 5.5) / 0.4)^2) + 0.2 * u * sin(t)
  }
  design <- data.frame(u1 = (0:13 + runif(14)) / 14, x1 = (sample(14) - runif(14)) / 14)
  runs <- model_runs(design, t(mapply(model, design$u1, design$x1)), t)
  truth <- model(0.4, 0.55) + 0.15 * exp(-((t - 4) / 0.25)^2)
  reps <- t(replicate(4, truth + as.numeric(stats::filter(rnorm(128, sd = 0.01), 0.6, "recursive"))))
  field <- field_runs(reps, t, x_nom = c(x1 = 0.5))
  iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), c(0, 0), c(1, 1))
  list(t = t, runs = runs, field = field, iu = iu)
}

test_that("print and summary of every class are stable", {
  pp <- print_problem()
  reg <- register_curves(pp$field, pp$runs, list(c(1, 3), c(4.8, 6.5)))
  basis <- wavelet_basis(pp$runs, reg)
  rc <- reconstruction_check(basis, pp$runs, reg)
  ep <- error_processes(basis, reg, seed = 1)
  em <- suppressWarnings(fit_emulators(pp$runs, basis))
  fit <- suppressWarnings(calibrate(em, reg, pp$iu, chains = 1, seed = 1,
                                    sampler = sampler_control(n_draws = 60, n_inner = 5, quiet = TRUE)))
  pr <- predict(fit, type = "field_run", seed = 1)
  wf <- where_fails(fit)
  ex <- explain_bias(fit, list(bump = exp(-((pp$t - 4) / 0.25)^2), wave = cos(pp$t)), positive = c(TRUE, FALSE),
                     seed = 1)
  cmp <- compare_validations(fit, fit)
  objects <- list(iu = pp$iu, runs = pp$runs, field = reg, warps = reg$warps, basis = basis,
                  reconstruction = rc, error_processes = ep, emulators = em, fit = fit,
                  prediction = pr, fails = wf, explain = ex, comparison = cmp)
  for (nm in names(objects)) {
    x <- objects[[nm]]
    expect_snapshot(print(x), transform = function(s) {
      gsub("[0-9]+\\.[0-9]+ s\\b", "<time> s", sub("^Sampling took .*", "Sampling took <time>", s))
    })
    expect_snapshot(print(summary(x)))
  }
})
