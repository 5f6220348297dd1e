# Counts the calls of the namespace functions `what` made while `code` runs.
count_calls <- function(code, what = c("fit_emulators", "register_curves", "calibrate")) {
  ns <- asNamespace("wavevalid")
  counter <- new.env()
  for (f in what) {
    counter[[f]] <- 0L
    suppressMessages(trace(f, tracer = bquote(assign(.(f), get(.(f), envir = .(counter)) + 1L, envir = .(counter))), where = ns,
                           print = FALSE))
  }
  on.exit(for (f in what) suppressMessages(untrace(f, where = ns)), add = TRUE)
  value <- tryCatch(code, error = function(e) e)
  list(value = value, calls = unlist(mget(what, envir = counter)))
}

preflight_problem <- function() {
  t <- seq(0, 1, length.out = 128)
  design <- data.frame(u = seq(0, 1, length.out = 8), x = rev(seq(0, 1, length.out = 8)))
  model <- function(u, x) plogis((t - 0.4 - 0.1 * u) / 0.02) * (1 + 0.2 * x)
  runs <- model_runs(design, t(mapply(model, design$u, design$x)), t)
  field <- field_runs(rbind(model(0.5, 0.5) + 0.01 * sin(40 * t)), t)
  iu <- iu_map(c("u", "x"), c("calibration", "variation"), c(0, 0), c(1, 1))
  list(t = t, runs = runs, field = field, iu = iu)
}

test_that("the checks and their figures on a sound problem", {
  pp <- preflight_problem()
  pf <- preflight(pp$runs, pp$field, pp$iu, sigma2 = 1e-4)
  expect_s3_class(pf, "wv_preflight")
  expect_identical(pf$check, c("grid", "basis", "noise", "inputs"))
  expect_identical(pf$status, rep("ok", 4))
  expect_s3_class(attr(pf, "basis"), "wv_basis")
  expect_match(pf$figure[2], "relative L2 error runs median")
  expect_match(pf$figure[3], "fixed by sigma2 = 1e-04")
  expect_output(print(pf), "4 ok")
  pw <- preflight(pp$runs, pp$field, pp$iu, sigma2 = 1e-4, windows = list(c(0.2, 0.8)))
  expect_identical(pw$status[pw$check == "windows"], "ok")
  # the counter sees the fits of a validation that passes
  ok <- count_calls(suppressWarnings(validate(pp$runs, pp$field, pp$iu, chains = 1, seed = 1,
                                              bias = bias_control(sigma2 = 1e-4),
                                              sampler = sampler_control(n_draws = 10, n_inner = 2, burnin = 10, quiet = TRUE))))
  expect_s3_class(ok$value, "wv_fit")
  expect_identical(unname(ok$calls), c(1L, 0L, 1L))
})

test_that("one replicate without sigma2: the pre-flight warns, and validate() learns the noise", {
  pp <- preflight_problem()
  pf <- preflight(pp$runs, pp$field, pp$iu)
  expect_identical(pf$status[pf$check == "noise"], "warning")
  expect_match(pf$figure[pf$check == "noise"], "learned in the posterior")
  expect_match(pf$fix[pf$check == "noise"], "sigma2")
  expect_warning(enforce_preflight(pf), class = "wavevalid_warning_noise")
  fit <- suppressWarnings(suppressMessages(validate(pp$runs, pp$field, pp$iu, chains = 1, seed = 1,
                                                    sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE))))
  expect_s3_class(fit, "wv_fit")
  expect_identical(unname(fit$noise_setting), "learned")
  # a bad sigma2 stops before anything is registered or fitted
  out <- count_calls(validate(pp$runs, pp$field, pp$iu, windows = list(c(0.2, 0.8)),
                              bias = bias_control(sigma2 = -1), sampler = sampler_control(quiet = TRUE)))
  expect_s3_class(out$value, "wavevalid_error_input")
  expect_identical(unname(out$calls), c(0L, 0L, 0L))
  # the same problem with sigma2 passes every check
  expect_true(all(preflight(pp$runs, pp$field, pp$iu, sigma2 = "finest")$status == "ok"))
})

test_that("a bad grid and a basis too coarse are refused before any fit", {
  pp <- preflight_problem()
  # a grid that is not dyadic, as an object not built by model_runs()
  odd <- new_wv_runs(pp$runs$design, pp$t[1:100], lapply(pp$runs$curves, function(m) m[, 1:100]))
  odd_field <- new_wv_field(pp$t[1:100], lapply(pp$field$curves, function(m) m[, 1:100, drop = FALSE]))
  out <- count_calls(validate(odd, odd_field, pp$iu, bias = bias_control(sigma2 = 1e-4),
                              sampler = sampler_control(quiet = TRUE)))
  expect_s3_class(out$value, "wavevalid_error_grid")
  expect_identical(unname(out$calls), c(0L, 0L, 0L))
  pf <- preflight(odd, odd_field, pp$iu, sigma2 = 1e-4)
  expect_identical(pf$status[1:2], c("error", "skipped"))
  expect_match(pf$fix[1], "model_runs")
  # decreasing times and a field on another grid
  back <- new_wv_runs(pp$runs$design, rev(pp$t), pp$runs$curves)
  expect_identical(preflight(back, pp$field, pp$iu, sigma2 = 1)$status[1], "error")
  other <- new_wv_field(pp$t + 0.5, pp$field$curves)
  expect_identical(preflight(pp$runs, other, pp$iu, sigma2 = 1)$status[1], "error")
  holed <- pp$field
  holed$curves$site1[1, 5] <- NA
  expect_identical(preflight(pp$runs, holed, pp$iu, sigma2 = 1)$status[1], "error")

  # the report's rule on a sharp rise: 10 coefficients miss 1% many times over
  coarse <- list(retain = "report", whole_levels = 0:2, fraction = 0.01)
  pf <- preflight(pp$runs, pp$field, pp$iu, sigma2 = 1e-4, basis_args = coarse)
  expect_identical(pf$status[pf$check == "basis"], "error")
  med <- stats::median(attr(pf, "basis")$error$rel_l2[attr(pf, "basis")$error$source == "run"])
  expect_gt(med, 0.05)
  out <- count_calls(validate(pp$runs, pp$field, pp$iu, basis_args = coarse,
                              bias = bias_control(sigma2 = 1e-4), sampler = sampler_control(quiet = TRUE)))
  expect_s3_class(out$value, "wavevalid_error_basis")
  expect_identical(unname(out$calls), c(0L, 0L, 0L))
  # a basis that misses the tolerance only for some runs warns
  mild <- preflight(pp$runs, pp$field, pp$iu, sigma2 = 1e-4, tolerance = c(runs = med / 2))
  expect_identical(mild$status[mild$check == "basis"], "ok")
  mild <- preflight(pp$runs, pp$field, pp$iu, sigma2 = 1e-4, tolerance = c(runs = med / 2),
                    basis_args = list(retain = "report", whole_levels = 0:2, fraction = 0.01))
  expect_identical(mild$status[mild$check == "basis"], "warning")
})

test_that("an input of the runs that the I/U map lacks stops validate() before any fit", {
  pp <- preflight_problem()
  short <- iu_map("u", "calibration", 0, 1)
  pf <- preflight(pp$runs, pp$field, short, sigma2 = 1)
  expect_identical(pf$status[pf$check == "inputs"], "error")
  expect_match(pf$figure[pf$check == "inputs"], "the design's input x is not in the I/U map")
  expect_match(pf$fix[pf$check == "inputs"], "iu_add()", fixed = TRUE)
  out <- count_calls(validate(pp$runs, pp$field, short, bias = bias_control(sigma2 = 1),
                              sampler = sampler_control(quiet = TRUE)))
  expect_s3_class(out$value, "wavevalid_error_inputs")
  expect_match(conditionMessage(out$value), "x is not in the I/U map")
  expect_identical(unname(out$calls), c(0L, 0L, 0L))
})

test_that("an input of the I/U map that the runs lack stops validate() before any fit", {
  pp <- preflight_problem()
  # the runs without x: x would only follow its prior
  runs_u <- new_wv_runs(pp$runs$design["u"], pp$runs$t, pp$runs$curves)
  pf <- preflight(runs_u, pp$field, pp$iu, sigma2 = 1)
  expect_identical(pf$status[pf$check == "inputs"], "error")
  expect_match(pf$figure[pf$check == "inputs"], "the I/U map's input x is not in the design of the runs")
  expect_match(pf$fix[pf$check == "inputs"], 'iu[iu$name != "x", ]', fixed = TRUE)
  out <- count_calls(validate(runs_u, pp$field, pp$iu, bias = bias_control(sigma2 = 1),
                              sampler = sampler_control(quiet = TRUE)))
  expect_s3_class(out$value, "wavevalid_error_inputs")
  expect_match(conditionMessage(out$value), "x is not in the design of the runs")
  expect_identical(unname(out$calls), c(0L, 0L, 0L))
  # both ways at once, several inputs: one error names them all
  iu3 <- iu_add(pp$iu, c("w", "v"), lower = c(0, 0), upper = c(1, 1))
  runs_z <- new_wv_runs(cbind(pp$runs$design["u"], z = pp$runs$design$x), pp$runs$t, pp$runs$curves)
  pf <- preflight(runs_z, pp$field, iu3, sigma2 = 1)
  expect_match(pf$figure[pf$check == "inputs"], "inputs x, w, v are not in the design of the runs; the design's input z")
  expect_match(pf$fix[pf$check == "inputs"], 'iu[!iu$name %in% c("x", "w", "v"), ]', fixed = TRUE)
  # the fix the error gives: the map subset to the runs' inputs passes
  dropped <- pp$iu[pp$iu$name != "x", ]
  expect_s3_class(dropped, "wv_iu")
  expect_identical(preflight(runs_u, pp$field, dropped, sigma2 = 1)$status[4], "ok")
})

test_that("calibrate() wants the emulators' inputs and the I/U map's to be the same", {
  ex <- example_problem()
  more <- iu_add(ex$iu, "w", lower = 0, upper = 1)
  err <- expect_error(calibrate(ex$emulators, ex$field, more, chains = 1, seed = 1,
                                sampler = sampler_control(n_draws = 10, n_inner = 2, quiet = TRUE)),
                      class = "wavevalid_error_inputs")
  expect_match(conditionMessage(err), "w is not in the inputs of the emulators")
  expect_match(conditionMessage(err), 'iu[iu$name != "w", ]', fixed = TRUE)
  less <- ex$iu[ex$iu$name != "x1", ]
  err <- expect_error(calibrate(ex$emulators, ex$field, less, chains = 1, seed = 1,
                                sampler = sampler_control(n_draws = 10, n_inner = 2, quiet = TRUE)),
                      class = "wavevalid_error_inputs")
  expect_s3_class(err, "wavevalid_error_input")
  expect_match(conditionMessage(err), "x1 is not in the I/U map")
})

test_that("the I/U ranges are checked against the design's", {
  pp <- preflight_problem()
  wide <- iu_map(c("u", "x"), c("calibration", "variation"), c(0, -0.5), c(1, 1))
  pf <- preflight(pp$runs, pp$field, wide, sigma2 = 1)
  expect_identical(pf$status[pf$check == "inputs"], "warning")
  expect_match(pf$figure[pf$check == "inputs"], "beyond the design for x")
  expect_warning(enforce_preflight(pf), class = "wavevalid_warning_inputs")
  bad_windows <- preflight(pp$runs, pp$field, pp$iu, sigma2 = 1, windows = list(c(0.8, 0.2)))
  expect_identical(bad_windows$status[bad_windows$check == "windows"], "error")
})

test_that("the flyer plate passes every check: its repeated measurements identify the noise of its one curve", {
  fl <- load_flyer()
  pf <- preflight(fl$runs, fl$field, fl$iu)
  expect_identical(pf$status, c("ok", "ok", "ok", "ok"))
  expect_match(pf$figure[pf$check == "noise"], "repeated measurements at one time stamp (34 df)", fixed = TRUE)
  expect_match(pf$figure[pf$check == "noise"], "scale from the measured curve on its own time stamps", fixed = TRUE)
  # the same curve without its repeated measurements: one curve tells noise from bias weakly
  single <- fl$field
  single$noise$velocity$df <- 0
  expect_identical(preflight(fl$runs, single, fl$iu)$status, c("ok", "ok", "warning", "ok"))
  expect_identical(preflight(fl$runs, fl$field, fl$iu, sigma2 = 1e-8)$status, rep("ok", 4))
  rep_pf <- preflight(fl$runs, fl$field, fl$iu, sigma2 = 1e-8, basis_args = list(retain = "report"))
  expect_identical(rep_pf$status[rep_pf$check == "basis"], "error")
})
