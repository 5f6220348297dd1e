# A pulse whose height and time both move with u1: the registered field
# tells u1 by the height, and the landmarks keep the timing.
timing_problem <- function(lag, seed = 1) {
  withr::with_seed(seed, {
    t <- seq(0, 1, length.out = 129)[-129]
    pulse <- function(u, shift = 0) (1 + u) * exp(-((t - 0.4 - 0.1 * u - shift) / 0.04)^2) + 0.3 * sin(2 * pi * t)
    iu <- iu_map("u1", "calibration", lower = 0, upper = 1, nominal = 0.5)
    design <- data.frame(u1 = (0:29 + stats::runif(30)) / 30)
    runs <- model_runs(design, list(site1 = t(vapply(design$u1, pulse, numeric(length(t))))), t)
    jitter <- stats::rnorm(6, sd = 0.01)
    reps <- t(vapply(jitter, function(j) pulse(0.5, lag + j) + stats::rnorm(length(t), sd = 0.02), numeric(length(t))))
    field <- field_runs(list(site1 = reps), t)
    list(runs = runs, field = field, iu = iu, windows = list(c(0.3, 0.65)))
  })
}

timing_fit <- function(lag) {
  p <- timing_problem(lag)
  suppressWarnings(validate(p$runs, p$field, p$iu, windows = p$windows, features = "max",
                            sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE), chains = 1,
                            seed = 1))
}

test_that("a lag of the field's event is a timing finding, its shift inside the interval", {
  fit <- timing_fit(lag = 0.03)
  wf <- where_fails(fit)
  tm <- attr(wf, "timing")
  expect_equal(nrow(tm), 1L)
  expect_true(tm$flagged)
  expect_gt(tm$shift, 0)
  expect_true(tm$lower <= 0.03 && tm$upper >= 0.03)
  # the model's time at the calibrated inputs is where u1 (told by the height) puts it
  expect_equal(tm$model, 0.45, tolerance = 0.02)
  expect_equal(wf$kind[1], "timing")
  expect_match(top_finding(wf), "later by")
  # the row names its landmark, and the sentence reads that landmark's times
  expect_equal(wf$event[1], sprintf("%s in window %s", tm$feature, tm$window))
  expect_match(top_finding(wf), sprintf("its %s in window %s comes at", tm$feature, tm$window), fixed = TRUE)
  expect_true(all(is.na(wf$event[wf$kind != "timing"])))
  expect_gt(wf$size[1], wf$credible[1])
  expect_error(explain_bias(fit, list(a = rep(1, length(fit$basis$t))), finding = wf[1, ]),
               class = "wavevalid_error_finding")
  expect_output(print(wf), "Events' timing")
  expect_equal(summary(wf)$kinds[["timing"]], 1L)
})

test_that("without a lag the events' timing holds zero and is no finding", {
  fit <- timing_fit(lag = 0)
  wf <- where_fails(fit)
  tm <- attr(wf, "timing")
  expect_false(any(tm$flagged))
  expect_true(all(tm$lower <= 0 & tm$upper >= 0))
  expect_false(any(wf$kind == "timing"))
})

test_that("a timing shift is the field's mean time less the model's, with the sampling error of the replicates", {
  set.seed(2)
  D <- data.frame(u1 = stats::runif(40))
  tr <- 1 + 0.2 * D$u1 + stats::rnorm(40, sd = 0.001)
  P <- data.frame(u1 = stats::rnorm(4000, 0.5, 0.01))
  L <- c(1.15, 1.16, 1.14, 1.15)
  s <- timing_shift(L, tr, D, P)
  expect_equal(s$field, 1.15)
  expect_equal(s$model, 1.1, tolerance = 1e-3)
  expect_equal(s$shift, 0.05, tolerance = 0.02)
  # the spread: the replicates' sampling error (t on 3 df) and the draws' spread of the model time
  expected_sd <- sqrt(stats::var(L) / 4 * 3 + (0.2 * 0.01)^2)
  expect_equal(stats::sd(s$draws), expected_sd, tolerance = 0.1)
  # a run without the landmark is left out, not read as zero
  tr[3] <- NA
  expect_equal(timing_shift(L, tr, D, P)$model, 1.1, tolerance = 1e-3)
})

test_that("a fit not registered by validate() has no timing reading", {
  expect_null(timing_table(example_fit()))
  expect_null(attr(where_fails(example_fit()), "timing"))
})
