# The terms with memory of term_library(): a first-order filter, a delay and a
# running integral of a channel, exact on the curves' own grid, and a planted
# filtered term proposed in its family.

test_that("the filter, the delay and the running integral are exact for curves linear between grid points", {
  t <- sort(c(0, 10, withr::with_seed(1, stats::runif(200, 0, 10))))
  b <- 0.7
  # a unit step at the start: b times the filter is 1 - exp(-b t)
  expect_equal(b * memory_filter(rep(1, length(t)), t, b), 1 - exp(-b * t), tolerance = 1e-10)
  # a ramp: t / b - (1 - exp(-b t)) / b^2
  expect_equal(memory_filter(t, t, b), t / b - (1 - exp(-b * t)) / b^2, tolerance = 1e-10)
  # a slow filter of a constant is its running integral nearly; the integral of 3 is 3 t, of t is t^2 / 2
  expect_equal(memory_filter(rep(3, length(t)), t, 1e-6), 3 * t, tolerance = 1e-5)
  expect_equal(memory_integral(rep(3, length(t)), t), 3 * t, tolerance = 1e-12)
  expect_equal(memory_integral(2 * t, t)[length(t)], 100, tolerance = 1e-12)
  # a delay by 7 grid steps on a regular grid shifts the curve by 7 points, its first value held before
  tr <- seq(0, 1, length.out = 101)
  u <- sin(5 * tr) + tr^2
  d <- memory_delay(u, tr, 0.07)
  expect_equal(d[-(1:7)], u[1:94], tolerance = 1e-12)
  expect_equal(d[1:7], rep(u[1], 7), tolerance = 1e-12)
  # between grid points, linear interpolation
  expect_equal(memory_delay(tr, tr, 0.015)[50], tr[50] - 0.015, tolerance = 1e-12)
})

test_that("the library holds the terms with memory of each channel, named readably", {
  fit <- example_fit()
  t <- fit$basis$t
  lib <- term_library(fit)
  len <- diff(range(t))
  tm <- lib$terms
  y <- lib$channels$curves$output$site1
  expect_true(all(c("filter", "delay", "integral") %in% tm$family))
  # on the output only, not on its time derivative
  expect_identical(unique(tm$channel[tm$memory]), "output")
  expect_setequal(tm$term[tm$family == "filter"],
                  sprintf("filter(output; tau = %s)",
                          vapply(len * c(1 / 16, 1 / 4, 1), function(v) format(signif(v, 3)), "")))
  k <- which(tm$term == sprintf("filter(output; tau = %s)", format(signif(len / 4, 3))))
  expect_identical(tm$label[k], sprintf("first-order filter of output, time constant %s (0.25 of the record)",
                                        format(signif(len / 4, 3))))
  expect_equal(lib$values[[tm$term[k]]]$site1, memory_filter(y, t, 4 / len))
  expect_equal(lib$values[["integral(output)"]]$site1, memory_integral(y, t))
  j <- which(tm$family == "delay")[1]
  expect_match(tm$label[j], "^delay of output by .* \\(1/32 of the record\\)$")
  expect_equal(lib$values[[tm$term[j]]]$site1, memory_delay(y, t, len / 32))
  # the products of a filter or the integral with the channel, in the product family, and their operators
  pi_term <- "product(integral(output), output)"
  expect_identical(tm$family[tm$term == pi_term], "product")
  expect_identical(tm$channel[tm$term == pi_term], "output")
  expect_equal(lib$values[[pi_term]]$site1, memory_integral(y, t) * y)
  expect_equal(lib$ops[[pi_term]](y, t), memory_integral(y, t) * y)
  expect_null(lib$funs[[pi_term]])
  # without memory, none of them
  lib0 <- term_library(fit, memory = FALSE)
  expect_false(any(lib0$terms$memory))
  expect_identical(nrow(lib$terms) - nrow(lib0$terms), sum(tm$memory))
  expect_error(term_library(fit, memory = NA), class = "wavevalid_error_input")
})

test_that("a term with memory of a state acts on the output as it is even with a simulator", {
  fit <- example_fit()
  t <- fit$basis$t
  state <- cos(2 * pi * t)
  lib <- term_library(fit, states = list(s = state), outputs = FALSE, products = FALSE)
  hook <- function(channel, fun, strength) list(site1 = sin(2 * pi * t) + 2 * strength * fun(state))
  sig <- term_signatures(fit, lib, hook)
  mem <- lib$terms$memory
  expect_true(all(sig$kind[mem] == "direct"))
  expect_true(all(sig$kind[!mem] == "simulated"))
  expect_equal(sig$X[, mem], term_signatures(fit, lib, NULL)$X[, mem])
})

test_that("a planted filtered output is proposed as a filter, named in the print, and added to the runs", {
  t <- seq(0, 1, length.out = 128)
  model <- function(u, x) (1 + 0.5 * x) * sin(2 * pi * t) + u * exp(-((t - 0.6) / 0.08)^2)
  withr::with_seed(1, {
    design <- data.frame(u1 = (0:29 + stats::runif(30)) / 30, x1 = (sample(30) - stats::runif(30)) / 30)
    runs <- model_runs(design, t(mapply(model, design$u1, design$x1)), t, site = "site1")
    truth <- model(0.4, 0.5)
    # a compartment of time constant a quarter of the record fed by the output, at strength 2
    reality <- truth + 2 * memory_filter(truth, t, 4)
    reps <- t(replicate(3, reality + stats::rnorm(length(t), sd = 0.01)))
  })
  field <- field_runs(reps, t, x_nom = c(x1 = 0.5))
  iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), c(0, 0), c(1, 1), nominal = c(0.5, 0.5))
  fit <- suppressWarnings(validate(runs, field, iu, chains = 1, seed = 1,
                                   sampler = sampler_control(n_draws = 60, n_inner = 10, quiet = TRUE)))
  pr <- propose_terms(fit, term_library(fit), n_draws = 40, seed = 1)
  expect_identical(pr$family[1], "filter")
  expect_identical(pr$term[1], "filter(output; tau = 0.25)")
  expect_gt(pr$inclusion_prob[1], 0.9)
  expect_true(pr$strength_lower[1] <= 2 && pr$strength_upper[1] >= 2,
              label = sprintf("[%.3f, %.3f]", pr$strength_lower[1], pr$strength_upper[1]))
  expect_output(print(pr), "Proposed: filter(output; tau = 0.25) (first-order filter of output, time constant 0.25 (0.25 of the record))",
                fixed = TRUE)
  # the term added to the model's runs through its operator on each run's curve
  fit2 <- suppressMessages(add_term(fit, pr))
  X <- fit2$pipeline$runs$curves$site1
  d <- fit2$pipeline$runs$design
  on <- which(d$s_term != 0)[1]
  base <- fit$pipeline$runs$curves$site1[on - nrow(fit$pipeline$runs$design), ]
  # the time constant calibrated beside the strength, each run at its own
  expect_true("tau_term" %in% fit2$inputs)
  expect_equal(attr(fit2, "added_term")$rate$name, "tau_term")
  expect_gt(length(unique(d$tau_term[d$s_term != 0])), 10)
  expect_equal(X[on, ], base + d$s_term[on] * memory_filter(base, t, 1 / d$tau_term[on]))
  ci <- summary(fit2)$inputs
  expect_true(ci["tau_term", "q2.5"] <= 0.25 && ci["tau_term", "q97.5"] >= 0.25,
              label = sprintf("tau [%.3f, %.3f]", ci["tau_term", "q2.5"], ci["tau_term", "q97.5"]))
  expect_error(add_term(fit, pr, simulate = function(design, channel, fun) NULL), "memory",
               class = "wavevalid_error_input")
})
