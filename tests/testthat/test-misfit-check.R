# example_problem()'s emulators (the model (1 + x/2) sin(2 pi t) + u bump(0.6)) with field data made here.
misfit_fit <- function(extra, sd) {
  ex <- example_problem()
  t <- ex$field$t
  truth <- (1 + 0.5 * 0.55) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2) + extra(t)
  reps <- withr::with_seed(3, t(replicate(6, truth + stats::rnorm(length(t), sd = sd(t)))))
  field <- field_runs(reps, t, x_nom = c(x1 = 0.5), site = "site1")
  suppressWarnings(calibrate(ex$emulators, field, ex$iu, chains = 2, seed = 1,
                             sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)),
                   classes = c("wavevalid_warning_mixing", "wavevalid_warning_boundary"))
}
# a spread ten times larger early in the record than late, as units rather than repeats give
spread <- function(t) ifelse(t < 0.5, 0.1, 0.01)

test_that("a right model is not rejected, and each point's error follows the replicates' spread", {
  fit <- misfit_fit(function(t) 0 * t, spread)
  chk <- misfit_check(fit)
  expect_s3_class(chk, "wv_misfit_check")
  expect_false(any(chk$rejected))
  expect_gt(attr(chk, "p_value"), 0.1)
  expect_identical(unname(attr(chk, "noise")), "replicates")
  t <- fit$field$t
  # the standard error follows the replicates' spread along the record: against a fit whose spread is the
  # late one everywhere, it grows where the spread does, by more than where it does not (the retained
  # coarse coefficients span the record and carry some of the early spread late)
  flat <- misfit_check(misfit_fit(function(t) 0 * t, function(t) 0.01 + 0 * t))
  early <- t < 0.4
  late <- t > 0.6
  grow_early <- stats::median(chk$se[early] / flat$se[early])
  grow_late <- stats::median(chk$se[late] / flat$se[late])
  expect_gt(grow_early, 1.8)
  expect_gt(grow_early, 1.3 * grow_late)
  expect_equal(chk$z, chk$misfit / chk$se)
  # with replicates, their own scatter: not the per-coefficient noise variances of the fit
  loud <- fit
  loud$sigma2$site1 <- 100 * loud$sigma2$site1
  expect_equal(misfit_check(loud)$se, chk$se)
  one <- fit
  one$n_rep$site1 <- 1L
  expect_identical(unname(attr(misfit_check(one), "noise")), "learned")
  expect_false(isTRUE(all.equal(misfit_check(one)$se, chk$se)))
  expect_output(print(chk), "Not rejected")
  expect_false("misfit" %in% where_fails(fit)$kind)
  p <- ggplot2::ggplot_build(autoplot(chk))
  expect_equal(nrow(p$data[[3]]), length(t))
})

test_that("a small smooth misfit where the spread is small is rejected there and is a finding", {
  late <- function(t) 0.08 * exp(-((t - 0.85) / 0.06)^2)
  fit <- misfit_fit(late, spread)
  chk <- misfit_check(fit)
  expect_lt(attr(chk, "p_value"), 0.05)
  hit <- chk$t[chk$rejected]
  expect_gt(length(hit), 0L)
  expect_true(all(hit > 0.6))
  # the misfit there is what was added, within its error
  k <- which.max(abs(chk$z))
  expect_lt(abs(chk$misfit[k] - late(chk$t[k])), 3 * chk$se[k] + 0.02)
  wf <- where_fails(fit)
  ms <- wf[wf$kind == "misfit", ]
  if (nrow(ms)) {
    expect_true(all(ms$start > 0.6))
    expect_identical(ms$sign[1], "reality above model")
  } else {
    # the bias's band found it first: the same stretch, not a second finding
    expect_true(any(wf$kind == "interval" & wf$end > 0.75 & wf$start < 0.95))
  }
  expect_output(print(chk), "Rejected")
  # the same misfit under the early spread everywhere: each point's own error hides nothing the spread does not
  wide <- misfit_check(misfit_fit(late, function(t) 0.1 + 0 * t))
  expect_gt(attr(wide, "p_value"), attr(chk, "p_value"))
})

test_that("misfit_check() refuses bad arguments before any computation", {
  fit <- example_fit()
  expect_error(misfit_check(1), class = "wavevalid_error_input")
  expect_error(misfit_check(fit, level = 2), class = "wavevalid_error_input")
  expect_error(misfit_check(fit, n_sim = 10), class = "wavevalid_error_input")
})

test_that("preflight() and the fit's print say when the replicates' spread changes tenfold along the record", {
  ex <- example_problem()
  t <- ex$field$t
  truth <- (1 + 0.5 * 0.55) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2)
  make <- function(sd) field_runs(withr::with_seed(3, t(replicate(6, truth + stats::rnorm(length(t), sd = sd)))), t,
                                  x_nom = c(x1 = 0.5), site = "site1")
  runs <- model_runs(as.data.frame(ex$emulators$design), ex$emulators$banks$site1$y %*% t(ex$emulators$basis$Psi), t)
  varying <- make(ifelse(t < 0.5, 0.2, 0.005))
  sp <- spread_along_record(varying)
  expect_gt(sp$ratio, 10)
  expect_lt(sp$at_largest, 0.5)
  expect_gt(sp$at_smallest, 0.5)
  pf <- preflight(runs, varying, ex$iu)
  expect_match(pf$figure[pf$check == "noise"], "spread changes [0-9.]+-fold along the record at site1")
  expect_null(spread_text(spread_along_record(make(0.03 + 0 * t))))
  fit <- suppressWarnings(calibrate(ex$emulators, varying, ex$iu, chains = 1, seed = 1,
                                    sampler = sampler_control(n_draws = 50, n_inner = 5, quiet = TRUE)))
  expect_true(any(grepl("registered replicates' spread changes", capture.output(print(fit)), fixed = TRUE)))
})

# Six units (their own x1, the map's variation input), three repeats each, on example_problem()'s emulators.
units_fit <- function(extra, declare = TRUE, seed = 3) {
  ex <- example_problem()
  t <- ex$field$t
  x <- withr::with_seed(seed, stats::rnorm(6, 0.5, 0.15))
  unit <- rep(1:6, each = 3)
  reps <- withr::with_seed(seed + 1, t(vapply(unit, function(i) {
    (1 + 0.5 * x[i]) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2) + extra(t) +
      stats::rnorm(length(t), sd = 0.01)
  }, numeric(length(t)))))
  field <- field_runs(reps, t, x_nom = c(x1 = 0.5), units = if (declare) unit)
  suppressWarnings(calibrate(ex$emulators, field, ex$iu, chains = 2, seed = 1,
                             sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)),
                   classes = c("wavevalid_warning_mixing", "wavevalid_warning_boundary"))
}

test_that("replicates declared as units are judged net of what each unit's own inputs explain", {
  right <- misfit_check(units_fit(function(t) 0 * t))
  expect_identical(unname(attr(right, "noise")), "units")
  expect_false(any(right$rejected))
  expect_gt(attr(right, "p_value"), 0.1)
  expect_output(print(right), "6 units' means, net of what their own x1 explain")
  # the units' spread along x1's direction is not the error of the population's misfit
  as_repeats <- misfit_check(units_fit(function(t) 0 * t, declare = FALSE))
  expect_lt(stats::median(right$se), 0.5 * stats::median(as_repeats$se))
  drift <- function(t) 0.02 * (t - 0.5)
  units <- misfit_check(units_fit(drift))
  repeats <- misfit_check(units_fit(drift, declare = FALSE))
  expect_lt(attr(units, "p_value"), 0.01)
  expect_gt(sum(units$rejected), 2 * sum(repeats$rejected))
})

test_that("a misfit spread over the record is found in the means of wide windows", {
  chk <- misfit_check(units_fit(function(t) 0.02 * (t - 0.5)))
  # rejected where no single point lies beyond the band: a window's mean does
  wide <- chk$rejected & abs(chk$z) < chk$crit
  expect_gt(sum(wide), 3L)
  expect_true(all(chk$scale[wide] > diff(chk$t[1:2])))
  expect_true(all(chk$excess[chk$rejected] > 0))
  expect_true(all(chk$excess[!chk$rejected] == 0))
  wf <- where_fails(units_fit(function(t) 0.02 * (t - 0.5)))
  expect_true("misfit" %in% wf$kind)
})

test_that("the unit means' least error is their measurement noise", {
  lev <- rep(0:3, c(1, 1, 2, 4))
  units <- rep(1:6, each = 12)
  W <- withr::with_seed(1, matrix(stats::rnorm(72 * 8, sd = 0.01), 72) +
                          matrix(stats::rnorm(6 * 8, sd = 1), 6)[units, ])
  # from the repeats about their unit's mean: the noise of a mean of 6 means of 12
  expect_equal(unit_noise_floor(W, units, lev), rep(0.01^2 / 12 / 6, 8), tolerance = 0.25)
  # one curve per unit: the level's mean of the unit means' scatter
  one <- W[!duplicated(units), ]
  between <- apply(one, 2, stats::var) / 6
  expect_equal(unit_noise_floor(one, 1:6, lev), stats::ave(between, lev))
})

test_that("units whose means agree by chance keep their measurement noise as the error", {
  ex <- example_problem()
  t <- ex$field$t
  truth <- (1 + 0.5 * 0.55) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2)
  # each unit's three repeats sum to three times the truth: the units' means agree exactly
  reps <- withr::with_seed(4, do.call(rbind, lapply(1:6, function(i) {
    e <- matrix(stats::rnorm(2 * length(t), sd = 0.05), 2)
    rbind(truth + e[1, ], truth + e[2, ], truth - e[1, ] - e[2, ])
  })))
  fit_of <- function(units) {
    suppressWarnings(calibrate(ex$emulators, field_runs(reps, t, x_nom = c(x1 = 0.5), units = units),
                               ex$iu, chains = 2, seed = 1,
                               sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)),
                     classes = c("wavevalid_warning_mixing", "wavevalid_warning_boundary"))
  }
  as_units <- misfit_check(fit_of(rep(1:6, each = 3)))
  as_repeats <- misfit_check(fit_of(NULL))
  # the repeats' noise, 0.05 / sqrt(18) a point, not the units' means' zero scatter
  expect_gt(stats::median(as_units$se), 0.8 * stats::median(as_repeats$se))
})

test_that("the windows' scan gives the numbers of its definition in R, to the bit", {
  scan_r <- function(m, Et) {
    n <- length(m)
    Cm <- c(0, cumsum(m))
    CE <- cbind(0, t(apply(Et, 1L, cumsum)))
    if (n == 1L) CE <- cbind(0, Et)
    zmax <- numeric(nrow(Et))
    observed <- 0
    windows <- lapply(2L^(0:floor(log2(n))), function(w) {
      st <- as.integer(unique(c(seq(1L, n - w + 1L, by = max(1L, w %/% 2L)), n - w + 1L)))
      mw <- (Cm[st + w] - Cm[st]) / w
      Ew <- (CE[, st + w, drop = FALSE] - CE[, st, drop = FALSE]) / w
      se <- pmax(sqrt(colMeans(Ew^2)), .Machine$double.eps)
      zmax <<- pmax(zmax, apply(abs(Ew) / rep(se, each = nrow(Ew)), 1L, max))
      z <- mw / se
      observed <<- max(observed, abs(z))
      list(width = as.integer(w), start = st, mean = mw, se = se, z = z)
    })
    list(windows = windows, zmax = zmax, observed = observed)
  }
  withr::local_seed(3)
  for (n in c(1L, 2L, 7L, 100L, 1024L)) {
    m <- stats::rnorm(n)
    Et <- matrix(stats::rnorm(50 * n), 50)
    expect_identical(misfit_scan(m, Et), scan_r(m, Et))
  }
})
