# Every exported function, called with wrong types, empty input, NA/Inf, wrong
# dimensions and out-of-range arguments, fails with a classed error of the
# package, never a crash or a bare R error.
expect_classed <- function(expr) {
  suppressWarnings(expect_error(expr, class = "wavevalid_error"))
}

test_that("containers refuse malformed input with classed errors", {
  t <- seq(0, 1, length.out = 16)
  m <- matrix(rnorm(48), 3, 16)
  bad_inputs <- list(NULL, "a", list(), matrix(numeric(), 0, 16), m[, 1:5], m * NA, numeric())
  for (b in bad_inputs) {
    expect_classed(model_runs(data.frame(a = 1:3), b, t))
    expect_classed(field_runs(b, t))
  }
  for (tt in list(NULL, "t", rev(t), c(t[-16], NA), c(t[-16], Inf), t[1:4], matrix(t, 4))) {
    expect_classed(model_runs(data.frame(a = 1:3), m, tt))
    expect_classed(field_runs(m, tt))
  }
  for (d in list(NULL, "a", data.frame(), data.frame(a = c(1, NA, 3)), data.frame(a = c(1, Inf, 2)), matrix(1:3))) {
    expect_classed(model_runs(d, m, t))
  }
  expect_classed(field_runs(m, t, site = c("a", "b")))
  expect_classed(iu_map(character(), character(), numeric(), numeric()))
  expect_classed(iu_map("a", "variation", "0", 1))
  expect_classed(iu_map(1, "variation", 0, 1))
  expect_classed(iu_map("a", "variation", 0, Inf))
})

test_that("pipeline verbs refuse objects of the wrong class with classed errors", {
  t <- seq(0, 1, length.out = 16)
  f <- field_runs(matrix(rnorm(48), 3, 16), t)
  not <- list(NULL, 1, "x", list(), data.frame(a = 1))
  for (x in not) {
    expect_classed(register_curves(x, f, list(c(0.2, 0.4))))
    expect_classed(wavelet_basis(x, f))
    expect_classed(fit_emulators(x, NULL))
    expect_classed(calibrate(x, f, NULL))
    expect_classed(bias(x))
    expect_classed(reality(x))
    expect_classed(model_prediction(x))
    expect_classed(where_fails(x))
    expect_classed(explain_bias(x, list()))
    expect_classed(compare_validations(x, x))
    expect_classed(validation_report(x))
  }
})

test_that("fit-based verbs refuse out-of-range arguments with classed errors", {
  ex <- example_problem()
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1,
                                    sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE)))
  for (lev in list(-1, 0, 1, 2, NA, "a", c(0.5, 0.9), NULL)) {
    expect_classed(bias(fit, level = lev))
    expect_classed(reality(fit, level = lev))
    expect_classed(where_fails(fit, level = lev))
    expect_classed(predict(fit, level = lev))
  }
  for (n in list(0, -5, 2.5, NA, "10", Inf)) {
    expect_classed(calibrate(ex$emulators, ex$field, ex$iu, sampler = sampler_control(n_draws = n)))
    expect_classed(calibrate(ex$emulators, ex$field, ex$iu, sampler = sampler_control(n_inner = n)))
    expect_classed(calibrate(ex$emulators, ex$field, ex$iu, chains = n))
  }
  expect_classed(calibrate(ex$emulators, ex$field, ex$iu, seed = "a"))
  expect_classed(explain_bias(fit, list(a = 1:3)))
  expect_classed(explain_bias(fit, list(), shifts = FALSE))
  expect_classed(explain_bias(fit, list(), max_size = 0))
  expect_classed(where_fails(fit, min_steps = 0))
  expect_classed(predict(fit, guard = -1))
  expect_classed(testbed_suspension(hidden = "gremlins"))
  expect_classed(testbed_signatures("u1"))
})

# A misspelt argument is an error that names it, never silently ignored (an
# argument that begins a formal's name is that argument, as in base R).
test_that("fit-based verbs refuse unknown arguments with classed errors that name them", {
  ex <- example_problem()
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1,
                                    sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE)))
  expect_error(where_fails(fit, tolerence = 0.1), "tolerence", class = "wavevalid_error_input")
  expect_error(explain_bias(fit, list(), ndraws = 10), "ndraws", class = "wavevalid_error_input")
  expect_error(calibrate(ex$emulators, ex$field, ex$iu, ndraws = 10), "ndraws", class = "wavevalid_error_input")
  expect_error(predict(fit, kind = "new_vehicle"), "kind", class = "wavevalid_error_input")
  expect_error(predict(ex$emulators, data.frame(u1 = 0.5), sites = "site1"), "sites",
               class = "wavevalid_error_input")
  expect_error(where_fails(fit, 0.9, "simultaneous", 1L, 0, 5), class = "wavevalid_error_input")
})

# A choice argument outside its choices is a classed error that lists them; a
# unique beginning of a choice picks it.
test_that("choice arguments refuse values outside their choices with classed errors", {
  ex <- example_problem()
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1,
                                    sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE)))
  expect_error(predict(fit, type = "new_run"), "new_vehicle", class = "wavevalid_error_input")
  expect_error(predict(fit, bias = "additiv3"), "multiplicative", class = "wavevalid_error_input")
  expect_error(predict(fit, type = c("reality", "field_run")), "type", class = "wavevalid_error_input")
  expect_error(where_fails(fit, band = "curve"), "simultaneous", class = "wavevalid_error_input")
  expect_error(where_fails(fit, band = NA), "band", class = "wavevalid_error_input")
  expect_error(calibrate(ex$emulators, ex$field, ex$iu, sampler = sampler_control(proposal = "gibbs")), "adaptive",
               class = "wavevalid_error_input")
  t <- seq(0, 1, length.out = 64)
  design <- data.frame(a = seq(0, 1, length.out = 8), b = c(3, 7, 1, 5, 8, 2, 6, 4) / 8)
  runs <- model_runs(design, t(apply(design, 1, function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t)), t)
  expect_error(fit_emulators(runs, wavelet_basis(runs), engine = "mlegp"), "dicekriging",
               class = "wavevalid_error_input")
  expect_error(autoplot(fit, type = "traces"), "trace", class = "wavevalid_error_input")
  expect_error(autoplot(where_fails(fit), type = "level"), NA)
  expect_identical(attr(where_fails(fit, band = "point"), "band"), "pointwise")
  expect_identical(attr(where_fails(fit), "band"), "simultaneous")
})
