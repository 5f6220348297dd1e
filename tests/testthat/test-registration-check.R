# The coarse levels' shared bias variance, and the registration's own error
# measured on model runs.

test_that("pool_levels = \"coarse\" pools the record-wide levels until the group holds more than four coefficients", {
  ex <- example_problem()
  basis <- ex$emulators$basis
  lv <- coarse_levels(basis)
  n <- table(basis$level)
  expect_true(all(intersect(record_wide_levels(basis), basis$level) %in% lv))
  expect_gt(sum(n[as.character(lv)]), 4)
  # one level fewer would hold four or fewer
  expect_lte(sum(n[as.character(lv[-length(lv)])]), 4)
  expect_identical(bias_control()$pool_levels, "coarse")
  fit <- calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1,
                   sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE))
  expect_identical(fit$settings$pool_levels, lv)
  pooled <- fit$bias_group$site1[basis$level %in% lv]
  expect_length(unique(pooled), 1L)
  expect_identical(unique(pooled), sprintf("site1:%d-%d", min(lv), max(lv)))
  # the method's prior keeps one variance per level
  fit0 <- calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1, bias = bias_control(pool_levels = NULL),
                    sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE))
  expect_length(unique(fit0$bias_group$site1[basis$level %in% lv]), length(lv))
})

test_that("register_curves(check_runs = ) registers the runs nearest the field like a replicate", {
  tb <- testbed_suspension(seed = 1, hidden = "none")
  runs <- tb$A$runs
  field <- register_curves(tb$A$field, runs, tb$windows, knots_every = 2, check_runs = 3)
  plain <- register_curves(tb$A$field, runs, tb$windows, knots_every = 2)
  expect_null(plain$registration_check)
  expect_identical(field$curves, plain$curves)
  chk <- field$registration_check
  expect_named(chk, names(field$curves))
  expect_identical(dim(chk$site1), c(3L, length(field$t)))
  # the nearest run, registered on its own, less itself
  d <- Reduce(`+`, lapply(names(field$curves), function(s) {
    rowMeans(sweep(runs$curves[[s]], 2L, colMeans(field$curves[[s]]))^2)
  }))
  k <- which.min(d)
  one <- field_runs(lapply(runs$curves, function(m) m[k, , drop = FALSE]), runs$t)
  reg1 <- suppressWarnings(register_curves(one, runs, tb$windows, knots_every = 2))
  expect_equal(chk$site2[1, ], reg1$curves$site2[1, ] - runs$curves$site2[k, ])
  # what registering changes in a curve of the model is far above the noise of the field mean
  expect_gt(sqrt(mean(chk$site1^2)), 0.03 / sqrt(nrow(field$curves$site1)))
})

test_that("registration_variance = \"check\" adds the mean square of the runs' registration error to the field mean", {
  tb <- testbed_suspension(seed = 1, hidden = "none")
  runs <- tb$A$runs
  field <- register_curves(tb$A$field, runs, tb$windows, knots_every = 2, check_runs = 2)
  em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, field)))
  smp <- sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE)
  fit <- suppressWarnings(calibrate(em, field, tb$iu, chains = 1, seed = 1, sampler = smp,
                                    bias = bias_control(registration_variance = "check")))
  # the runs' changes regressed on the shifts' directions: the shifts' prior
  # variances are the mean squares of the fitted shifts, what they leave is
  # orthogonal to the directions and its mean square goes on every coefficient
  sh <- fit$registration_shifts
  K <- length(sh$variance)
  expect_gt(K, 0)
  expect_true(all(sh$variance > 0))
  expect_identical(dim(sh$draws), c(20L, K))
  st <- registration_shift_structure(field, em$basis)
  E <- lapply(names(field$curves), function(s) field$registration_check[[s]] %*% em$basis$Psi)
  Es <- do.call(cbind, E)
  Us <- do.call(rbind, st$U)
  delta <- t(qr.coef(qr(Us), t(Es)))
  expect_equal(sh$variance, colMeans(delta^2))
  R <- Es - delta %*% t(Us)
  expect_lt(max(abs(R %*% Us)), 1e-8 * max(abs(Es %*% Us)))
  for (j in seq_along(E)) {
    s <- names(field$curves)[j]
    Rj <- E[[j]] - delta %*% t(st$U[[s]])
    expect_equal(fit$registration_var[[s]], rep(mean(Rj^2), ncol(E[[j]])))
  }
  # the shifts take a part of what registering changed (over the sites: a
  # landmark the sites share moves both; about half here, with knots every 2
  # time units between the landmarks)
  expect_lt(mean(R^2), 0.75 * mean(Es^2))
  expect_output(print(fit), "registration's own error .* shifts of the landmarks")
  # the field mean's variance holds it: bands of the bias are wider than without
  fit0 <- suppressWarnings(calibrate(em, field, tb$iu, chains = 1, seed = 1, sampler = smp,
                                     bias = bias_control(registration_variance = FALSE)))
  expect_null(fit0$registration_var)
  expect_output(print(fit0), "nothing added to the variance of the field mean .*registration_variance = FALSE")
  w <- function(f) mean(bias(f)$upper - bias(f)$lower)
  expect_gt(w(fit), w(fit0))
  # the default takes the measure when the field carries it, and draws as "check" does
  fit_auto <- suppressWarnings(calibrate(em, field, tb$iu, chains = 1, seed = 1, sampler = smp))
  expect_identical(fit_auto$registration_var, fit$registration_var)
  expect_identical(as.matrix(fit_auto$draws), as.matrix(fit$draws))
  plain <- register_curves(tb$A$field, runs, tb$windows, knots_every = 2)
  # ... and adds nothing, saying so, when it does not
  fit_plain <- suppressWarnings(calibrate(em, plain, tb$iu, chains = 1, seed = 1, sampler = smp))
  expect_null(fit_plain$registration_var)
  expect_output(print(fit_plain), "the field carries no check")
  expect_error(calibrate(em, plain, tb$iu, chains = 1, seed = 1, sampler = smp,
                         bias = bias_control(registration_variance = "check")),
               class = "wavevalid_error_registration")
  expect_error(bias_control(registration_variance = "yes"), class = "wavevalid_error")
})
