test_that("where_fails finds the interval where the missing bump acts", {
  d <- diag_setup()
  wf <- where_fails(d$fit)
  expect_s3_class(wf, "wv_fails")
  expect_named(wf, c("kind", "site", "start", "end", "size", "credible", "integrated_abs_bias", "share_of_signal",
                     "sign", "inputs", "event", "peak_abs_bias", "scale"))
  expect_gt(nrow(wf), 0L)
  top <- wf[1, ]
  expect_identical(top$kind, "interval")
  expect_true(top$start <= 0.3 && top$end >= 0.2)
  expect_equal(top$sign, "reality above model")
  expect_true(all(diff(wf$size) <= 0))
  expect_identical(wf$peak_abs_bias, wf$size)
  lv <- attr(wf, "wavelet_levels")
  expect_equal(sum(lv$share), 1)
  expect_s3_class(attr(wf, "boundary"), "data.frame")
  # the bias plot: the intervals found shaded, the band, zero, the mean
  pf <- plot_drawn(autoplot(wf))
  iv <- wf[wf$kind == "interval", ]
  expect_identical(pf$geoms[1], "GeomRect")
  expect_identical(nrow(pf$data[[1]]), nrow(iv))
  expect_equal(sort(pf$data[[1]]$xmin), sort(iv$start))
  expect_equal(sort(pf$data[[1]]$xmax), sort(iv$end))
  expect_identical(utils::tail(pf$geoms, 3), c("GeomRibbon", "GeomHline", "GeomLine"))
  ribbon <- pf$data[[length(pf$geoms) - 2L]]
  expect_true(all(ribbon$ymin <= ribbon$ymax))
  expect_true(all(pf$data[[length(pf$geoms) - 1L]]$yintercept == 0))
  expect_match(pf$labels$title, "^Where the model fails: intervals where the ")
  # the levels plot: a bar per level and site, its height the level's share of the bias energy
  pl <- plot_drawn(autoplot(wf, type = "levels"))
  expect_identical(pl$geoms, "GeomCol")
  expect_identical(nrow(pl$data[[1]]), nrow(lv))
  expect_equal(pl$data[[1]]$y, lv$share)
  expect_identical(pl$labels$title, "Which time scales carry the bias")
})

test_that("where_fails with a tolerance reports only where the band lies beyond it", {
  d <- diag_setup()
  wf0 <- where_fails(d$fit)
  expect_identical(attr(where_fails(d$fit, tolerance = 0), "tolerance"), c(site1 = 0))
  expect_equal(as.data.frame(unclass(where_fails(d$fit, tolerance = c(site1 = 0)))),
               as.data.frame(unclass(wf0)))
  # just below the largest distance of the band from zero: only its peak is flagged
  b0 <- attr(wf0, "bias")
  tol <- 0.9 * max(pmax(b0$lower_curve, -b0$upper_curve))
  wf <- where_fails(d$fit, tolerance = tol)
  wf <- wf[wf$kind == "interval", ]
  wf0 <- wf0[wf0$kind == "interval", ]
  expect_gt(nrow(wf), 0L)
  expect_lt(sum(wf$end - wf$start), sum(wf0$end - wf0$start))
  # the missing bump is still found
  expect_true(wf$start[1] <= 0.3 && wf$end[1] >= 0.2)
  b <- attr(wf, "bias")
  dt <- diff(d$t[1:2])
  for (k in seq_len(nrow(wf))) {
    idx <- b$t >= wf$start[k] - dt / 2 & b$t < wf$end[k] - dt / 2
    beyond <- b$lower_curve[idx] > tol | b$upper_curve[idx] < -tol
    expect_true(all(beyond))
    # each interval lies inside one of the intervals without tolerance
    expect_true(any(wf0$start <= wf$start[k] + 1e-12 & wf0$end >= wf$end[k] - 1e-12))
  }
  big <- max(abs(c(b$lower_curve, b$upper_curve))) + 1
  expect_identical(nrow(where_fails(d$fit, tolerance = big)), 0L)
  expect_output(print(wf), "beyond the tolerance")
  # the credible bias is the smallest tolerance that flags nothing
  cr <- attr(wf0, "credible")
  mc <- attr(wf0, "misfit")
  expect_equal(cr$credible_bias, max(pmax(b0$lower_curve, -b0$upper_curve, 0),
                                     ifelse(mc$rejected, abs(mc$misfit) - mc$crit * mc$se, 0)))
  expect_identical(nrow(where_fails(d$fit, tolerance = cr$credible_bias * (1 + 1e-9))), 0L)
  expect_gt(nrow(where_fails(d$fit, tolerance = cr$credible_bias * (1 - 1e-6))), 0L)
  expect_true(cr$t >= 0.2 && cr$t <= 0.3)
  expect_output(print(wf0), "credibly at least")
  expect_output(print(summary(wf0)), "Largest credible bias by site: site1")
  expect_match(autoplot(wf)$labels$title, "beyond the tolerance")
  expect_s3_class(autoplot(wf), "ggplot")
  expect_error(where_fails(d$fit, tolerance = -0.1), class = "wavevalid_error_input")
  expect_error(where_fails(d$fit, tolerance = NA_real_), class = "wavevalid_error_input")
  expect_error(where_fails(d$fit, tolerance = c(0.1, 0.2)), class = "wavevalid_error_input")
  expect_error(where_fails(d$fit, tolerance = c(site2 = 0.1)), class = "wavevalid_error_input")
  expect_error(where_fails(d$fit, tolerance = "0.1"), class = "wavevalid_error_input")
})

test_that("where_fails reports an offset of the record as one record-wide finding, not as intervals", {
  ex <- example_problem()
  t <- ex$field$t
  truth <- (1 + 0.5 * 0.55) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2) + 0.3
  ex$field$curves$site1 <- withr::with_seed(7, t(replicate(4, truth + rnorm(length(t), sd = 0.03))))
  fit <- function(...) suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 11,
                                                  bias = bias_control(...),
                                                  sampler = sampler_control(n_draws = 150, n_inner = 20, quiet = TRUE)))
  f <- fit()
  wf <- where_fails(f)
  lv <- attr(wf, "wavelet_levels")
  expect_gt(lv$significant[lv$level == 0], 0)
  # the offset is the record-wide finding, about 0.3 and credible; the
  # localised part flags nothing
  rw <- attr(wf, "record_wide")
  expect_identical(rw$levels, "0-2")
  expect_true(rw$credible)
  expect_equal(rw$offset, 0.3, tolerance = 0.15)
  expect_true(rw$offset_lower > 0)
  expect_identical(sum(wf$kind == "interval"), 0L)
  # one table of the findings: the record-wide part spans the record
  df <- as.data.frame(wf)
  expect_identical(df$kind, "record-wide")
  expect_identical(df$scale, "record")
  expect_equal(df$size, rw$peak_abs_bias)
  expect_equal(df$credible, rw$credible_bias)
  expect_identical(df$sign, "reality above model")
  expect_equal(df$end - df$start, 1, tolerance = 0.01)
  expect_identical(unique(as.data.frame(where_fails(f, scales = "whole"))$scale), "local")
  expect_output(print(wf), "Record-wide part \\(levels 0-2")
  expect_match(capture.output(print(wf))[1], "^Top finding \\(1 of 1\\), a record-wide bias")
  # the note on a free level-0 bias comes with the method's prior by level only
  expect_false(any(grepl("mean of the record \\(level 0\\)", capture.output(print(wf)))))
  expect_output(print(where_fails(fit(pool_levels = NULL))), "mean of the record \\(level 0\\) is credibly off at site1")
  # the record-wide part and the localised part add up to the whole bias
  whole <- attr(wf, "bias_whole")
  wide <- bias_part(f, f$basis$level %in% 0:2, 0.9)
  expect_equal(whole$mean, wide$mean + attr(wf, "bias")$mean, tolerance = 1e-10)
  # read whole, the record is flagged end to end, by about the offset
  wf_whole <- where_fails(f, scales = "whole")
  expect_equal(sum(wf_whole$end - wf_whole$start), 1, tolerance = 0.05)
  expect_equal(attr(wf_whole, "credible")$credible_bias, 0.3, tolerance = 0.1)
  expect_null(attr(wf_whole, "record_wide"))
  expect_s3_class(autoplot(wf), "ggplot")
  # pooled, the hint is not repeated
  expect_false(any(grepl("mean of the record", capture.output(print(where_fails(fit(pool_levels = 0:3)))))))
  expect_error(where_fails(f, scales = "parts"), class = "wavevalid_error_input")
})

test_that("without a missing effect the whole-curve band flags (almost) nothing, the pointwise band flags chance intervals", {
  ex <- example_problem()
  t <- ex$field$t
  truth <- (1 + 0.5 * 0.55) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2)
  steps <- function(wf) {
    wf <- wf[wf$kind == "interval", ]
    sum(round((wf$end - wf$start) / diff(t[1:2])))
  }
  flagged <- vapply(1:20, function(r) {
    ex$field$curves$site1 <- withr::with_seed(100 + r, t(replicate(4, truth + rnorm(length(t), sd = 0.03))))
    fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = r,
                                      sampler = sampler_control(n_draws = 100, n_inner = 10, quiet = TRUE)))
    c(simultaneous = steps(where_fails(fit)), pointwise = steps(where_fails(fit, band = "pointwise")))
  }, numeric(2))
  # a 90% whole-curve band misses a zero bias curve somewhere in about 10% of
  # the fits; the pointwise band at about 10% of all points
  expect_lte(mean(flagged["simultaneous", ] > 0), 0.3)
  expect_gt(sum(flagged["pointwise", ]), 2 * sum(flagged["simultaneous", ]))
  expect_identical(attr(where_fails(fit = suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu,
                                                                     chains = 1, seed = 1,
                                                                     sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE))), band = "pointwise"), "band"), "pointwise")
})

test_that("explain_bias ranks the true mechanism first and the decoys low", {
  d <- diag_setup()
  ex <- explain_bias(d$fit, d$candidates, seed = 1)
  expect_s3_class(ex, "wv_explain")
  expect_named(ex, c("candidate", "inclusion_prob", "amplitude", "amplitude_lower", "amplitude_upper",
                     "share_explained", "share_of_bias"))
  expect_equal(ex$candidate[1], "bump")
  expect_gte(ex$inclusion_prob[1], 0.9)
  expect_true(all(ex$inclusion_prob[ex$candidate %in% c("late_bump", "wiggle")] < 0.5))
  # the bump enters reality with amplitude 0.3; the bias prior shrinks it towards zero
  expect_true(ex$amplitude_lower[1] < 0.3 && ex$amplitude_upper[1] > 0.15)
  expect_true(any(grepl("^shift:", ex$candidate)))
  expect_identical(explain_bias(d$fit, d$candidates, seed = 1), ex)
  # the plot: zero, the posterior mean bias and the leading candidates' effects, a line each
  cur <- attr(ex, "curves")
  pe <- plot_drawn(autoplot(ex))
  expect_identical(pe$geoms, c("GeomHline", "GeomLine"))
  expect_identical(nrow(pe$data[[2]]), nrow(cur))
  expect_identical(length(unique(pe$data[[2]]$colour)), length(unique(cur$curve)))
  expect_true("posterior mean bias" %in% cur$curve)
  expect_true(any(startsWith(as.character(cur$curve), "bump")))
  expect_equal(sort(pe$data[[2]]$y), sort(cur$value))
  expect_identical(pe$labels$title, "Posterior mean bias and the leading candidate effects, scaled")
})

test_that("explain_bias says how much of each candidate a parameter shift spans", {
  # the shift directions at the inputs the method's prior calibrates (the pooled
  # coarse levels move them, and the directions with them)
  d <- diag_setup(bias_control(pool_levels = NULL))
  t <- d$t
  # the example model scales sin(2 pi t) by x1 and a peak at t = 0.6 by u1
  sine <- sin(2 * pi * t)
  peak <- exp(-((t - 0.6) / 0.08)^2)
  cand <- c(d$candidates, list(sine = sine, peak = peak, both = sine + 2 * peak))
  ex <- explain_bias(d$fit, cand, seed = 1)
  ab <- attr(ex, "absorbed")
  expect_named(ab, c("candidate", "absorbed", "inputs"))
  expect_identical(ab$candidate, names(cand))
  a <- stats::setNames(ab$absorbed, ab$candidate)
  by <- stats::setNames(ab$inputs, ab$candidate)
  expect_gt(a[["sine"]], 0.99)
  expect_identical(by[["sine"]], "x1")
  expect_gt(a[["peak"]], 0.99)
  expect_identical(by[["peak"]], "u1")
  expect_gt(a[["both"]], 0.99)
  expect_setequal(strsplit(by[["both"]], ", ")[[1]], c("u1", "x1"))
  # sin(6 pi t) is orthogonal to both directions
  expect_lt(a[["wiggle"]], 0.1)
  out <- utils::capture.output(print(ex))
  expect_true(any(grepl("of the signature of sine is what moving x1 would do", out, fixed = TRUE)))
  expect_false(any(grepl("signature of wiggle", out, fixed = TRUE)))
  expect_null(attr(explain_bias(d$fit, d$candidates, shifts = FALSE, seed = 1), "absorbed"))
})

test_that("explain_bias gives a mechanism no credit for the opposite of its signature unless told its sign is free", {
  d <- diag_setup()
  cand <- list(flipped = -d$candidates$bump, late_bump = d$candidates$late_bump)
  pos <- explain_bias(d$fit, cand, seed = 1)
  free <- explain_bias(d$fit, cand, positive = FALSE, seed = 1)
  expect_lt(pos$inclusion_prob[pos$candidate == "flipped"], 0.1)
  expect_gt(free$inclusion_prob[free$candidate == "flipped"], 0.9)
  expect_lt(free$amplitude[free$candidate == "flipped"], 0)
  expect_identical(attr(pos, "positive"), c("flipped", "late_bump"))
  expect_identical(attr(free, "positive"), character())
  expect_output(print(pos), "constrained to be non-negative: flipped, late_bump", fixed = TRUE)
  expect_false(any(grepl("non-negative", utils::capture.output(print(free)))))
  both <- explain_bias(d$fit, cand, positive = c(FALSE, TRUE), seed = 1)
  expect_equal(both$inclusion_prob[both$candidate == "flipped"],
               free$inclusion_prob[free$candidate == "flipped"], tolerance = 0.05)
})

test_that("explain_bias refuses bad candidates and shares the inclusion of twins", {
  d <- diag_setup()
  expect_error(explain_bias(d$fit, list(a = rep(1, 10))), class = "wavevalid_error_input")
  expect_error(explain_bias(d$fit, list(d$candidates$bump)), class = "wavevalid_error_input")
  expect_error(explain_bias(d$fit, list(z = numeric(length(d$t)))), class = "wavevalid_error_input")
  expect_error(explain_bias(d$fit, list(a = c(NA, d$candidates$bump[-1]))), class = "wavevalid_error_input")
  expect_error(explain_bias(d$fit, "bump"), class = "wavevalid_error_input")
  expect_error(explain_bias(d$fit, d$candidates, positive = c(TRUE, FALSE)), class = "wavevalid_error_input")
  expect_error(explain_bias(d$fit, d$candidates, positive = NA), class = "wavevalid_error_input")
  expect_error(explain_bias(d$fit, d$candidates, positive = "yes"), class = "wavevalid_error_input")
  expect_snapshot(explain_bias(d$fit, list(a = rep(1, 10))), error = TRUE)
  twins <- explain_bias(d$fit, list(bump = d$candidates$bump, twin = d$candidates$bump), shifts = FALSE, seed = 1)
  p <- stats::setNames(twins$inclusion_prob, twins$candidate)
  expect_equal(unname(p["bump"]), unname(p["twin"]), tolerance = 1e-8)
  single <- explain_bias(d$fit, list(bump = d$candidates$bump), shifts = FALSE, seed = 1)
  expect_equal(unname(p["bump"] + p["twin"]), single$inclusion_prob, tolerance = 1e-8)
  expect_gt(single$inclusion_prob, 0.5)
})

test_that("explain_bias weighs the versions of one effect once", {
  d <- diag_setup()
  t <- d$t
  cand <- list(bump_right = d$candidates$bump, bump_late = exp(-((t - 0.32) / 0.05)^2),
               late_bump = d$candidates$late_bump, wiggle = d$candidates$wiggle)
  ex <- explain_bias(d$fit, cand, effect = c("bump", "bump", "late_bump", "wiggle"), seed = 1)
  expect_setequal(ex$candidate[!startsWith(ex$candidate, "shift:")], c("bump", "late_bump", "wiggle"))
  expect_equal(ex$candidate[1], "bump")
  expect_gte(ex$inclusion_prob[1], 0.9)
  v <- attr(ex, "versions")
  expect_equal(v$candidate[1], "bump_right")
  expect_equal(sum(v$inclusion_prob[v$effect == "bump"]), ex$inclusion_prob[1], tolerance = 1e-12)
  expect_false(any(grepl("bump_right.*bump_late|bump_late.*bump_right", attr(ex, "subsets")$subset)))
  expect_output(print(ex), "Most probable version of each effect: bump_right")
  expect_s3_class(autoplot(ex), "ggplot")
  # a twin as a second version leaves the effect's inclusion as it was
  single <- explain_bias(d$fit, list(bump = d$candidates$bump), shifts = FALSE, seed = 1)
  twins <- explain_bias(d$fit, list(a = d$candidates$bump, b = d$candidates$bump), effect = c("bump", "bump"),
                        shifts = FALSE, seed = 1)
  expect_equal(twins$inclusion_prob, single$inclusion_prob, tolerance = 1e-10)
  expect_error(explain_bias(d$fit, cand, effect = "bump"), class = "wavevalid_error_input")
  expect_error(explain_bias(d$fit, cand, effect = c("bump", NA, "late_bump", "wiggle")),
               class = "wavevalid_error_input")
  expect_error(explain_bias(d$fit, cand, effect = c("bump", "bump", "shift:x1", "wiggle")),
               class = "wavevalid_error_input")
})

test_that("adding the missing effect makes the error fall", {
  skip_on_cran()
  d <- diag_setup()
  t <- d$t
  model <- function(u, x, s) (1 + 0.5 * x) * sin(2 * pi * t) + u * exp(-((t - 0.6) / 0.08)^2) +
    s * 0.5 * exp(-((t - 0.25) / 0.05)^2)
  withr::local_seed(21)
  K <- 24
  design <- data.frame(u1 = (sample(K) - runif(K)) / K, x1 = (sample(K) - runif(K)) / K,
                       s_bump = (sample(K) - runif(K)) / K)
  runs <- model_runs(design, t(apply(design, 1, function(z) model(z[1], z[2], z[3]))), t, site = "site1")
  iu_after <- iu_add(d$ex$iu, "s_bump", lower = 0, upper = 1)
  basis <- wavelet_basis(runs, d$ex$field, fraction = 1)
  em <- suppressWarnings(fit_emulators(runs, basis))
  after <- suppressWarnings(calibrate(em, d$ex$field, iu_after, chains = 2, seed = 12,
                                      sampler = sampler_control(n_draws = 150, n_inner = 20, quiet = TRUE)))
  cmp <- compare_validations(d$fit, after)
  expect_s3_class(cmp, "wv_comparison")
  expect_named(cmp, c("metric", "before", "after", "change"))
  expect_true(all(c("bias_rms", "bias_rms_local", "bias_rms_record", "bias_peak", "band_width", "model_rmse") %in%
                    cmp$metric))
  expect_lt(cmp$change[cmp$metric == "bias_rms"], -0.5)
  # the bias by scale: orthonormal parts of the posterior mean bias
  for (w in c("before", "after")) {
    v <- stats::setNames(cmp[[w]], cmp$metric)
    expect_equal(v[["bias_rms"]]^2, v[["bias_rms_local"]]^2 + v[["bias_rms_record"]]^2, tolerance = 1e-8)
    expect_gt(v[["bias_rms_local"]], 0)
  }
  wide <- d$fit$basis$level %in% record_wide_levels(d$fit$basis)
  rec <- attr(where_fails(d$fit), "record_wide")
  expect_equal(cmp$before[cmp$metric == "bias_rms_record"],
               sqrt(mean(drop(d$fit$basis$Psi[, wide] %*% colMeans(d$fit$wb$site1[, wide]))^2)))
  expect_equal(rec$offset, mean(drop(d$fit$basis$Psi[, wide] %*% colMeans(d$fit$wb$site1[, wide]))), tolerance = 1e-8)
  expect_lt(cmp$change[cmp$metric == "model_rmse"], 0)
  # held-out replicates of the same system
  withr::local_seed(22)
  truth <- (1 + 0.5 * 0.55) * sin(2 * pi * t) + 0.3 * exp(-((t - 0.6) / 0.08)^2) + 0.3 * exp(-((t - 0.25) / 0.05)^2)
  hold <- field_runs(t(replicate(3, truth + rnorm(length(t), sd = 0.03))), t, site = "site1")
  cmp2 <- compare_validations(d$fit, after, holdout = hold)
  expect_true(all(c("holdout_rmse", "holdout_coverage") %in% cmp2$metric))
  expect_lt(cmp2$after[cmp2$metric == "holdout_rmse"], cmp2$before[cmp2$metric == "holdout_rmse"])
  expect_s3_class(autoplot(cmp2), "ggplot")
  # each model's own registration of the held-out data: the metrics use the field given for each
  preds <- list(before = predict(d$fit, type = "field_run"), after = predict(after, type = "field_run"))
  base <- compare_validations(d$fit, after, holdout = c(list(field = hold), preds), seed = 1)
  same <- compare_validations(d$fit, after, holdout = c(list(field = list(before = hold, after = hold)), preds),
                              seed = 1)
  expect_identical(same, base)
  shifted <- hold
  shifted$curves$site1 <- shifted$curves$site1 + 1
  own <- compare_validations(d$fit, after, holdout = c(list(field = list(before = hold, after = shifted)), preds))
  expect_equal(own$before, base$before)
  expect_gt(own$after[own$metric == "holdout_rmse"], base$after[base$metric == "holdout_rmse"] + 0.5)
  expect_error(compare_validations(d$fit, after, holdout = c(list(field = list(before = hold)), preds)),
               class = "wavevalid_error_input")
  expect_error(compare_validations(d$fit, "after"), class = "wavevalid_error_input")
  # the print reads a grown bias whose localised part fell as a traded offset, and only then
  traded <- cmp
  traded$after[traded$metric == "bias_rms"] <- 2 * traded$before[traded$metric == "bias_rms"]
  traded$change <- traded$after / traded$before - 1
  expect_true(any(grepl("localised bias fell", utils::capture.output(print(traded)))))
  expect_false(any(grepl("localised bias fell", utils::capture.output(print(cmp)))))
})

test_that("on the test bed without a hidden mechanism (the test-bed protocol's short chains), nothing is flagged or explained", {
  skip_on_cran()
  d <- testbed_diagnosis("none")
  dt <- diff(d$fit$basis$t[1:2])
  # no credible record-wide offset or trend (the localised part's chance
  # excursions are measured in studies/diagnosis_defaults.R)
  expect_false(any(attr(d$fails, "record_wide")$credible))
  # the whole bias, read as in the method's report
  whole <- where_fails(d$fit, scales = "whole")
  whole <- whole[whole$kind == "interval", ]
  steps <- (whole$end - whole$start) / dt
  expect_true(all(steps <= 3), label = paste(round(steps), collapse = ", "))
  # nothing explained: no mechanism's signature, nor a shift of an input, reaches inclusion 0.5
  # (the claim the slow tier makes over three test beds), and each amplitude's interval holds 0
  expect_setequal(d$explain$candidate, testbed_mechanisms())
  expect_gt(sum(startsWith(d$all$candidate, "shift:")), 0L)
  expect_true(all(d$all$inclusion_prob < 0.5), label = paste(signif(d$all$inclusion_prob, 2), collapse = ", "))
  expect_true(all(d$all$amplitude_lower <= 0 & d$all$amplitude_upper >= 0))
})

# explain_bias over three test beds: no false claim, the true mechanism first.
# With nothing hidden no candidate (shifts included) reaches 0.5; with a
# mechanism hidden, no other mechanism does and the true one is ranked first
# among the mechanisms, with inclusion probability >= 0.9 at 7 of the 9 test
# beds (at the others its signature explains only a few per cent of a
# residual that is coherent over time, and its evidence is tempered). A hidden
# digressive damper is left out here: the calibration absorbs most of it into
# the damping coefficients, and the bump stop's signature competes with its
# own.
test_that("on three test beds, explain_bias ranks the hidden mechanism first and claims no other", {
  skip_unless_slow()
  for (seed in 1:3) {
    d <- testbed_diagnosis("none", seed)
    expect_true(all(d$all$inclusion_prob < 0.5), label = paste("none, seed", seed))
  }
  first <- NULL
  for (h in c("progressive_bumpstop", "tire_liftoff", "strut_friction")) {
    for (seed in 1:3) {
      d <- testbed_diagnosis(h, seed)
      lab <- paste0(h, ", seed ", seed)
      expect_identical(d$explain$candidate[1], h, label = lab)
      expect_true(all(d$explain$inclusion_prob[-1] < 0.5), label = lab)
      first <- c(first, d$explain$inclusion_prob[1])
    }
  }
  expect_gte(sum(first >= 0.9), 7)
})

# Each mechanism's signature simulated at the posterior mean inputs and at the
# nominal inputs, given as two versions of one effect, over the same three test
# beds and the digressive damper too: nothing claimed with nothing hidden (the
# versions share a prior mass; as separate candidates with their inclusion
# probabilities added, the damper reached 0.60 with nothing hidden on one of
# the 25 bench cases), the hidden mechanism first in 11 of the 12
# cases and at >= 0.9 in 9 (at seed 3 the bump stop, 0.76, is ahead of a
# hidden damper).
testbed_versions <- function(hidden, seed) {
  d <- testbed_diagnosis(hidden, seed)
  fit <- d$fit
  z_hat <- colMeans(as.matrix(fit$draws))[fit$inputs]
  nominal <- stats::setNames(d$tb$iu$nominal, d$tb$iu$name)[fit$inputs]
  sp <- testbed_signatures(z_hat)
  sn <- testbed_signatures(nominal)
  cand <- c(stats::setNames(sp, paste0(names(sp), "@calibrated")), stats::setNames(sn, paste0(names(sn), "@nominal")))
  ex <- explain_bias(fit, cand, effect = rep(names(sp), 2), n_draws = 50, seed = 1)
  as.data.frame(unclass(ex))
}

test_that("on three test beds, versions of each mechanism's signature find the hidden one, the damper too", {
  skip_unless_slow()
  for (seed in 1:3) {
    ex <- testbed_versions("none", seed)
    expect_true(all(ex$inclusion_prob < 0.5), label = paste("none, seed", seed))
  }
  res <- NULL
  for (h in testbed_mechanisms()) {
    for (seed in 1:3) {
      ex <- testbed_versions(h, seed)
      mech <- ex[!startsWith(ex$candidate, "shift:"), ]
      expect_setequal(mech$candidate, testbed_mechanisms())
      res <- rbind(res, data.frame(hidden = h, seed = seed, first = mech$candidate[1] == h,
                                   prob = mech$inclusion_prob[mech$candidate == h],
                                   decoy = max(mech$inclusion_prob[mech$candidate != h])))
    }
  }
  lab <- paste(utils::capture.output(print(res)), collapse = "\n")
  expect_gte(sum(res$first), 11L, label = lab)
  expect_gte(sum(res$first & res$prob >= 0.9), 9L, label = lab)
  expect_lte(sum(res$decoy >= 0.5), 1L, label = lab)
})

# Whether the flags cover where the mechanism acts, and whether they lie
# there. With the method's prior (one bias variance per level) the calibration
# of seed 1 trades the events against the mean of the record when a bump stop
# or a tire lift-off is hidden; where_fails() reports that offset as the
# record-wide part, and its localised intervals cover more than a fifth of
# where the mechanism acts at both sites. With levels 0 to 3 pooled
# (calibrate(pool_levels = 0:3)) the offset goes and the flags lie where the
# mechanism acts: at 4 to 15 times the rate of flags thrown at random for the
# bump stop and the lift-off. The strut friction acts over more than half the
# record, so its flags can score at most twice that rate.
test_that("on the test bed, the hidden mechanism is flagged where it acts, and only there once levels 0-3 are pooled", {
  skip_unless_slow()
  withr::local_options(list(wavevalid.quiet = TRUE))
  for (h in c("progressive_bumpstop", "tire_liftoff", "strut_friction")) {
    d <- testbed_diagnosis(h)
    truth <- c(d$tb$truth$u, 0.5 + d$tb$truth$delta)[d$fit$inputs]
    effect <- testbed_signatures(truth, h)[[1]]
    share <- flagged_share(d$fails, effect)
    expect_named(share, c("site1", "site2"))
    expect_true(all(share > 0.2), label = paste(h, paste(round(share, 2), collapse = ", ")))
    pooled <- where_fails(testbed_validation(h, 1L, pool_levels = 0:3)$fit)
    lv <- attr(pooled, "wavelet_levels")
    expect_true(all(lv$share[lv$level == 0] < 0.01), label = h)
    share <- flagged_share(pooled, effect)
    on <- flagged_share(pooled, effect, of = "flags")
    lab <- paste(h, paste(round(share, 2), collapse = ", "), paste(round(on / attr(on, "acting"), 1), collapse = ", "))
    expect_true(all(share > 0.2), label = lab)
    if (h == "strut_friction") {
      expect_true(all(on > attr(on, "acting")), label = lab)
    } else {
      expect_true(all(on > 3 * attr(on, "acting")), label = lab)
    }
  }
})

test_that("flagged_share counts the flagged points where an effect acts", {
  d <- diag_setup()
  fails <- where_fails(d$fit)
  t <- d$t
  bump <- exp(-((t - 0.25) / 0.05)^2)
  w <- fails[fails$site == "site1" & fails$kind == "interval", ]
  flagged <- Reduce(`|`, lapply(seq_len(nrow(w)), function(k) t >= w$start[k] & t < w$end[k]),
                    rep(FALSE, length(t)))
  expect_equal(c(flagged_share(fails, list(site1 = bump))), c(site1 = mean(flagged[bump > 0.1])))
  expect_gt(flagged_share(fails, list(site1 = bump)), 0.5)
  # the other side: the flags lie on the bump, far above the share of the
  # grid it covers
  on_bump <- flagged_share(fails, list(site1 = bump), of = "flags")
  expect_equal(c(on_bump), c(site1 = mean(bump[flagged] > 0.1)))
  expect_equal(attr(on_bump, "acting"), c(site1 = mean(bump > 0.1)))
  expect_gt(on_bump, 2 * attr(on_bump, "acting"))
  # flags over the whole record score the share of the grid the effect covers
  everything <- fails
  everything$start[] <- min(t)
  everything$end[] <- max(t) + diff(t[1:2])
  expect_equal(c(flagged_share(everything, list(site1 = bump), of = "flags")), c(site1 = mean(bump > 0.1)))
  nothing <- fails
  nothing$end <- nothing$start
  expect_true(is.na(flagged_share(nothing, list(site1 = bump), of = "flags")))
  expect_error(flagged_share(fails, list(site1 = bump), of = "precision"), class = "wavevalid_error_input")
  expect_true(is.na(flagged_share(fails, list(site1 = 0 * t))))
  expect_error(flagged_share(fails, list(site9 = bump)), class = "wavevalid_error_input")
  expect_error(flagged_share(fails, list(site1 = bump[-1])), class = "wavevalid_error_input")
  expect_error(flagged_share(d$fit, list(site1 = bump)), class = "wavevalid_error_input")
})

test_that("an input with 12% of its draws at a bound is flagged, one spread over its range is not", {
  withr::local_seed(31)
  n <- 1000
  piled <- c(runif(120, 0.99, 1), runif(n - 120, 0.2, 0.8))
  spread <- runif(n)
  iu <- iu_map(c("u1", "u2"), "calibration", c(0, 0), c(1, 1))
  fit <- list(draws = coda::mcmc.list(coda::mcmc(cbind(u1 = piled, u2 = spread))), inputs = c("u1", "u2"),
              prior_iu = iu, iu = iu, emulators = list(inputs = c("u1", "u2")), x_nom = NULL)
  flags <- boundary_flags(fit, c(u1 = 1, u2 = 1))$boundary
  expect_identical(flags$input, "u1")
  expect_identical(flags$bound, "upper")
  expect_equal(flags$posterior, 0.12)
  bc <- boundary_check(fit)
  expect_identical(bc$flagged, c(TRUE, FALSE))
  expect_true(piled_at_bound(0.19, 0.02))
  expect_false(piled_at_bound(0.09, 0.02))
  expect_false(piled_at_bound(0.3, 0.1))
  # a warning names it
  expect_warning(warn_fit_flags(list(flags = list(boundary = flags, rhat = character(0)))),
                 class = "wavevalid_warning_boundary")
})
