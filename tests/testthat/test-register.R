# Two events, each a dip then a peak, over a slow wave.
rms <- function(x) sqrt(mean(x^2))
event_curve <- function(t, at = c(5, 14), amp = c(1, 0.7)) {
  y <- 0.05 * sin(2 * pi * t / 9)
  for (e in seq_along(at)) {
    s <- t - at[e]
    y <- y - amp[e] * (s > 0) * exp(-0.8 * pmax(s, 0)) * sin(2 * pi * 0.8 * pmax(s, 0))
  }
  y
}

grid <- function(n = 1024) 20 * (0:(n - 1)) / n
windows <- list(c(4, 8), c(13, 17))

# Replicate seen through a known warp: measured time t maps to reference time
# h(t), piecewise linear through (before, after); y_r(t) = ref(h(t)).
warped <- function(f, t, before, after) f(stats::approx(before, after, xout = t)$y)

test_that("registration recovers a known piecewise-linear warp", {
  t <- grid()
  ref <- event_curve(t)
  ref_lm <- curve_landmarks(ref, t, windows, c("min", "max"))
  shifts <- c(0.3, 0.5, -0.4, -0.2)
  before <- c(0, ref_lm$t + shifts, 20)
  after <- c(0, ref_lm$t, 20)
  reps <- rbind(warped(event_curve, t, before, after), event_curve(t), warped(event_curve, t, before, after))
  reps[3, ] <- warped(event_curve, t, c(0, ref_lm$t - shifts, 20), after)
  field <- field_runs(reps, t)
  reg <- register_curves(field, list(site1 = ref), windows)

  expect_s3_class(reg, "wv_field")
  expect_s3_class(reg$warps, "wv_warps")
  w <- reg$warps
  expect_equal(nrow(w), 3 * 4)
  step <- diff(t)[1]
  expect_true(all(abs(w$t_before[w$replicate == 1] - (ref_lm$t + shifts)) <= step + 1e-9))
  expect_true(all(abs(w$t_before[w$replicate == 3] - (ref_lm$t - shifts)) <= step + 1e-9))
  expect_equal(w$t_after[w$replicate == 1], ref_lm$t)
  expect_equal(w$feature[1:4], c("min", "max", "min", "max"))
  # the unwarped replicate is left alone
  expect_equal(reg$curves$site1[2, ], ref)
  # registered curves match the reference far better than the raw ones
  for (r in c(1, 3)) {
    raw <- rms(reps[r, ] - ref)
    after_reg <- rms(reg$curves$site1[r, ] - ref)
    expect_lt(after_reg, 0.01 * diff(range(ref)))
    expect_lt(after_reg, raw / 5)
  }
  expect_output(print(reg), "registered")
})

test_that("one warp per replicate is applied to every site; landmark_site = NULL registers each site", {
  t <- grid()
  ref1 <- event_curve(t)
  ref2 <- event_curve(t, amp = c(0.5, 1.2)) + 0.1
  lm <- curve_landmarks(ref1, t, windows, c("min", "max"))
  before <- c(0, lm$t + c(0.4, 0.4, -0.3, -0.3), 20)
  after <- c(0, lm$t, 20)
  f2 <- function(x) event_curve(x, amp = c(0.5, 1.2)) + 0.1
  field <- field_runs(list(a = rbind(warped(event_curve, t, before, after), ref1),
                           b = rbind(warped(f2, t, before, after), ref2)), t)
  reg <- register_curves(field, list(a = ref1, b = ref2), windows)
  expect_equal(unique(reg$warps$site), "a")
  expect_equal(attr(reg$warps, "landmark_site"), "a")
  expect_lt(rms(reg$curves$b[1, ] - ref2), 0.01 * diff(range(ref2)))

  # landmarks on site b give the same warp here (same time jitter)
  reg_b <- register_curves(field, list(a = ref1, b = ref2), windows, landmark_site = "b")
  expect_equal(unique(reg_b$warps$site), "b")
  expect_lt(rms(reg_b$curves$a[1, ] - ref1), 0.01 * diff(range(ref1)))

  reg_each <- register_curves(field, list(a = ref1, b = ref2), windows, landmark_site = NULL)
  expect_setequal(unique(reg_each$warps$site), c("a", "b"))
  expect_true(is.na(attr(reg_each$warps, "landmark_site")))
  expect_s3_class(autoplot(reg_each$warps), "ggplot")
  expect_s3_class(summary(reg$warps), "summary_wv_warps")
})

test_that("a wv_runs reference means the mean of the runs per site", {
  t <- grid(256)
  runs <- model_runs(data.frame(a = 1:3),
                     rbind(event_curve(t), event_curve(t, amp = c(1.2, 0.6)), event_curve(t, amp = c(0.8, 0.8))), t)
  field <- field_runs(rbind(event_curve(t, at = c(5.3, 13.8)), event_curve(t, at = c(4.8, 14.2))), t)
  a <- register_curves(field, runs, windows)
  b <- register_curves(field, list(site1 = colMeans(runs$curves$site1)), windows)
  expect_equal(a$curves, b$curves)
  expect_equal(as.data.frame(a$warps), as.data.frame(b$warps))
})

test_that("model runs are registered like replicates and keep their design", {
  t <- grid(512)
  ref <- event_curve(t)
  # each run's events come late by its input a: the warp must undo exactly that
  a <- c(0.3, -0.2, 0.1)
  curves <- t(vapply(a, function(s) event_curve(t, at = c(5, 14) + s), numeric(length(t))))
  runs <- model_runs(data.frame(a = a, b = c(1, 2, 3)), curves, t)
  reg <- register_curves(runs, list(site1 = ref), windows, knots_every = 2)
  expect_s3_class(reg, "wv_runs")
  expect_s3_class(reg$warps, "wv_warps")
  expect_identical(reg$design, runs$design)
  expect_equal(reg$t, runs$t)
  expect_equal(sort(unique(reg$warps$replicate)), 1:3)
  # the same warps and curves as the runs registered as field replicates
  as_field <- register_curves(field_runs(curves, t), list(site1 = ref), windows, knots_every = 2)
  expect_equal(reg$curves, as_field$curves)
  expect_equal(as.data.frame(reg$warps), as.data.frame(as_field$warps))
  # the landmarks move back by each run's shift (to within a grid step)
  w <- reg$warps[!is.na(reg$warps$window), ]
  step <- diff(t)[1]
  expect_true(all(abs(w$t_before - w$t_after - a[w$replicate]) <= step + 1e-9))
  for (k in 1:3) {
    expect_lt(rms(reg$curves$site1[k, ] - ref), rms(curves[k, ] - ref) / 5)
  }
  expect_output(print(reg), "registered")
  # registered runs are not combined with others; bad objects and arguments are refused
  expect_error(c(reg, runs), "Registered", class = "wavevalid_error_input")
  expect_error(register_curves(curves, list(site1 = ref), windows), class = "wavevalid_error_input")
  expect_error(register_curves(runs, list(site1 = ref), windows, knot_every = 2), "knot_every",
               class = "wavevalid_error_input")
})

test_that("only one feature per window can be used", {
  t <- grid()
  ref <- event_curve(t)
  field <- field_runs(rbind(event_curve(t, at = c(5.2, 14.3))), t)
  reg <- register_curves(field, list(site1 = ref), windows, features = "max")
  expect_equal(reg$warps$feature, c("max", "max"))
  expect_true(all(abs(reg$warps$t_before - reg$warps$t_after - c(0.2, 0.3)) <= diff(t)[1] + 1e-9))
})

test_that("bad windows and mismatched grids are refused", {
  t <- grid()
  ref <- list(site1 = event_curve(t))
  field <- field_runs(rbind(event_curve(t, at = c(5.2, 14.3))), t)
  cls <- "wavevalid_error_input"
  expect_error(register_curves(field, ref, list(c(8, 4))), class = cls)
  expect_error(register_curves(field, ref, list(c(4, 8, 9))), class = cls)
  expect_error(register_curves(field, ref, list(c(-1, 8))), class = cls)
  expect_error(register_curves(field, ref, list(c(15, 25))), class = cls)
  expect_error(register_curves(field, ref, list(c(4, 10), c(9, 15))), class = cls)
  expect_error(register_curves(field, ref, list(c(13, 17), c(4, 8))), class = cls)
  # reference on another grid, or missing a site
  expect_error(register_curves(field, list(site1 = ref$site1[-1]), windows), class = cls)
  runs_other <- model_runs(data.frame(a = 1:2), rbind(ref$site1, ref$site1), t * 1.01)
  expect_error(register_curves(field, runs_other, windows), class = cls)
  expect_error(register_curves(field, list(other = ref$site1), windows), class = cls)
  expect_error(register_curves(field, ref, windows, landmark_site = "nope"), class = cls)
  expect_error(register_curves(field, ref, windows, features = "peak"), class = cls)
})

test_that("landmark_site = \"all\": one warp through the landmarks of every site, events the first site does not mark", {
  t <- grid(2048)
  fa <- function(x) event_curve(x, at = c(5, 14))
  fb <- function(x) event_curve(x, at = c(6.5, 15.5), amp = c(0.8, 0.9))
  lm_a <- curve_landmarks(fa(t), t, windows, c("min", "max"), refine = TRUE)
  lm_b <- curve_landmarks(fb(t), t, windows, c("min", "max"), refine = TRUE)
  after <- sort(c(0, lm_a$t, lm_b$t, 20))
  # the replicate's clock runs early at site a's events and late at site b's
  shift <- ifelse(after %in% lm_a$t, 0.25, ifelse(after %in% lm_b$t, -0.2, 0))
  before <- after + shift
  field <- field_runs(list(a = rbind(warped(fa, t, before, after), fa(t)),
                           b = rbind(warped(fb, t, before, after), fb(t))), t)
  ref <- list(a = fa(t), b = fb(t))
  both <- register_curves(field, ref, windows, landmark_site = "all", refine = TRUE)
  expect_identical(attr(both$warps, "landmark_site"), "all")
  expect_setequal(unique(both$warps$site), c("a", "b"))
  w1 <- both$warps[both$warps$replicate == 1, ]
  expect_equal(nrow(w1), 8L)
  expect_equal(sort(w1$t_before), sort(before[-c(1, length(before))]), tolerance = 2 * diff(t[1:2]))
  one <- register_curves(field, ref, windows, landmark_site = "a", refine = TRUE)
  err <- function(reg, s) rms(reg$curves[[s]][1, ] - ref[[s]])
  # site b's events are pinned where site b sees them
  expect_lt(err(both, "b"), 0.02 * diff(range(ref$b)))
  expect_gt(err(one, "b"), 5 * err(both, "b"))
  expect_lt(err(both, "a"), 0.02 * diff(range(ref$a)))
  # the untouched replicate stays as it is, and the warps plot one line per replicate
  expect_equal(both$curves$b[2, ], fb(t), tolerance = 1e-6)
  expect_output(print(both$warps), "landmarks found on every site")
  p <- ggplot2::ggplot_build(autoplot(both$warps))
  expect_equal(length(unique(p$data[[3]]$group)), 2L)
  # one site: the same as that site's own landmarks
  f1 <- field_runs(list(a = field$curves$a), t)
  expect_equal(register_curves(f1, ref["a"], windows, landmark_site = "all")$curves,
               register_curves(f1, ref["a"], windows)$curves)
})

test_that("landmarks in another order than the reference's are left out, with a warning, keeping those nearest", {
  t <- grid()
  ref <- list(site1 = event_curve(t))
  # a replicate whose peak comes before its dip: a warp through both would fold time
  flipped <- field_runs(rbind(event_curve(t, at = c(5.2, 14.3)), -event_curve(t, at = c(5.2, 14.3))), t)
  expect_warning(reg <- register_curves(flipped, ref, windows), class = "wavevalid_warning_landmarks")
  expect_snapshot(invisible(register_curves(flipped, ref, windows)))
  w <- as.data.frame(reg$warps)
  lo <- attr(reg$warps, "left_out")
  ref_lm <- curve_landmarks(ref$site1, t, windows, check_features(c("min", "max")))
  rep_lm <- curve_landmarks(flipped$curves$site1[2, ], t, windows,
                            check_features(c("min", "max")))
  # the first replicate keeps both landmarks of both windows
  expect_equal(nrow(w[w$replicate == 1, ]), 4L)
  for (k in unique(ref_lm$window)) {
    r <- ref_lm[ref_lm$window == k, ]
    p <- rep_lm[rep_lm$window == k, ]
    dist <- abs(p$t[match(r$feature, p$feature)] - r$t)
    kept <- w[w$replicate == 2 & w$window == k, ]
    # one landmark per window, the one nearer the reference's time; the other listed as left out
    expect_equal(kept$feature, r$feature[which.min(dist)])
    expect_equal(kept$t_after, r$t[which.min(dist)])
    expect_equal(lo$feature[lo$window == k], r$feature[which.max(dist)])
  }
  expect_true(all(lo$replicate == 2L))
  # the registered replicate has its kept landmarks on the reference's times
  y <- reg$curves$site1[2, ]
  for (k in unique(ref_lm$window)) {
    inw <- which(t >= windows[[k]][1] & t <= windows[[k]][2])
    kept <- w[w$replicate == 2 & w$window == k, ]
    at <- if (kept$feature == "max") t[inw][which.max(y[inw])] else t[inw][which.min(y[inw])]
    expect_lte(abs(at - kept$t_after), diff(t[1:2]) + 1e-9)
  }
  # subsetting the warps keeps the left-out landmarks of the replicates kept
  expect_null(attr(reg$warps[reg$warps$replicate == 1, ], "left_out"))
  expect_equal(nrow(attr(reg$warps[reg$warps$replicate == 2, ], "left_out")), nrow(lo))
})

test_that("the print of a fit on a field registered with landmarks left out says which", {
  ex <- example_calibration_inputs()
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1,
                                    sampler = sampler_control(n_draws = 20, n_inner = 2, quiet = TRUE)))
  expect_false(any(grepl("left out landmarks", utils::capture.output(print(fit)))))
  t <- grid()
  flipped <- field_runs(rbind(event_curve(t, at = c(5.2, 14.3)), -event_curve(t, at = c(5.2, 14.3))), t)
  reg <- suppressWarnings(register_curves(flipped, list(site1 = event_curve(t)), windows))
  fit$field$warps <- reg$warps
  out <- utils::capture.output(print(fit))
  expect_true(any(grepl("Registration left out landmarks", out) & grepl("the min of window 1 at 1 of 2 replicates", out)))
})

test_that("the order-keeping set of landmarks is the largest, then the nearest", {
  ol <- ordered_landmarks
  expect_equal(ol(c(1, 2, 3), c(1.1, 2.1, 3.1)), c(TRUE, TRUE, TRUE))
  # the third landmark jumped before the first two: dropping it alone restores the order
  expect_equal(ol(c(1, 2, 3), c(1.1, 2.1, 0.5)), c(TRUE, TRUE, FALSE))
  # two swapped: either one restores it; the one nearer its reference time stays
  expect_equal(ol(c(1, 2), c(2.05, 1.5)), c(FALSE, TRUE))
  expect_equal(ol(c(1, 2), c(1.2, 0.1)), c(TRUE, FALSE))
  # ties in the replicate's times are out of order too
  expect_equal(sum(ol(c(1, 2), c(1.5, 1.5))), 1L)
})

test_that("on the test bed, registration brings every landmark onto the reference and shrinks the spread", {
  tb <- testbed_suspension(seed = 1)
  reg <- register_curves(tb$A$field, tb$A$runs, tb$windows)
  t <- reg$t
  dt <- diff(t[1:2])
  ref <- colMeans(tb$A$runs$curves$site1)
  for (w in tb$windows) {
    inw <- which(t > w[1] & t < w[2])
    ref_lm <- t[inw][c(which.min(ref[inw]), which.max(ref[inw]))]
    for (r in seq_len(nrow(reg$curves$site1))) {
      y <- reg$curves$site1[r, ]
      lm <- t[inw][c(which.min(y[inw]), which.max(y[inw]))]
      expect_true(all(abs(lm - ref_lm) <= dt + 1e-9))
    }
    spread <- function(m) mean(apply(m[, inw], 2, stats::sd))
    expect_lt(spread(reg$curves$site1), 0.25 * spread(tb$A$field$curves$site1))
  }
})

# Small features between the events, as road roughness makes them.
rough_curve <- function(t) {
  event_curve(t) + 0.08 * sin(2 * pi * 1.7 * t) + 0.05 * sin(2 * pi * 2.9 * t + 1)
}

test_that("knots fitted between the windows undo a smooth jitter that landmarks leave", {
  t <- grid(2048)
  ref <- rough_curve(t)
  # smooth monotone jitter: 0 at the ends, bends between the events
  jitter <- function(tt, a) tt + a * sin(pi * tt / 20) + 0.5 * a * sin(3 * pi * tt / 20)
  set.seed(3)
  reps <- rbind(rough_curve(jitter(t, 0.12)), rough_curve(jitter(t, -0.1)), rough_curve(jitter(t, 0.07)))
  reps <- reps + matrix(stats::rnorm(length(reps), sd = 0.01), nrow(reps))
  field <- field_runs(reps, t)
  lm_only <- register_curves(field, list(site1 = ref), windows)
  fitted <- register_curves(field, list(site1 = ref), windows, knots_every = 1)
  outside <- !(t > 4 & t < 8) & !(t > 13 & t < 17)
  err <- function(reg) rms(sweep(reg$curves$site1, 2, ref)[, outside])
  expect_lt(err(fitted), 0.3 * err(lm_only))
  expect_lt(err(fitted), 0.03)
  w <- fitted$warps
  expect_true(all(w$feature %in% c("min", "max", "fitted")))
  expect_true(all(is.na(w$window[w$feature == "fitted"])))
  # every warp stays increasing
  for (r in 1:3) expect_true(all(diff(warp_knots(w, r)$before) > 0))
  expect_snapshot(print(fitted$warps[fitted$warps$replicate == 1 & fitted$warps$feature != "fitted", ]))
})

test_that("the data inside the windows never move the fitted knots", {
  t <- grid(2048)
  ref <- rough_curve(t)
  reps <- rbind(rough_curve(t + 0.05 * sin(pi * t / 20)), rough_curve(t - 0.04 * sin(pi * t / 20)))
  changed <- reps
  inside <- (t > 4.8 & t < 7.5) | (t > 13.8 & t < 16.5)
  # a different shape after the landmarks of each event (same landmarks), away
  # from the window ends by more than the jitter
  changed[, inside] <- changed[, inside] * 0.7
  a <- register_curves(field_runs(reps, t), list(site1 = ref), windows, knots_every = 1)
  b <- register_curves(field_runs(changed, t), list(site1 = ref), windows, knots_every = 1)
  fa <- a$warps[a$warps$feature == "fitted", ]
  fb <- b$warps[b$warps$feature == "fitted", ]
  expect_equal(fa$t_before, fb$t_before)
})

test_that("knots fitted to the replicates' consensus are not misled by a shape the reference lacks", {
  t <- grid(2048)
  # reality rings on after each window, which the reference (the model) does
  # not; the events themselves, and so the landmarks, are the same
  ring <- function(tt) {
    y <- rough_curve(tt)
    for (at in c(8.3, 17.3)) y <- y + 0.4 * (tt > at) * exp(-0.5 * pmax(tt - at, 0)) * sin(2 * pi * 1.3 * pmax(tt - at, 0))
    y
  }
  jitter <- function(tt, a) tt + a * sin(pi * tt / 20) + 0.5 * a * sin(3 * pi * tt / 20)
  a <- c(0.12, -0.12, 0.07, -0.07)
  set.seed(4)
  reps <- t(vapply(a, function(ai) ring(jitter(t, ai)), numeric(length(t))))
  reps <- reps + matrix(stats::rnorm(length(reps), sd = 0.01), nrow(reps))
  field <- field_runs(reps, t)
  ref <- list(site1 = rough_curve(t))
  to_ref <- register_curves(field, ref, windows, knots_every = 1)
  to_reps <- register_curves(field, ref, windows, knots_every = 1, knots_to = "replicates")
  outside <- !(t > 4 & t < 8) & !(t > 13 & t < 17)
  err <- function(reg) rms(sweep(reg$curves$site1, 2, ring(t))[, outside])
  expect_lt(err(to_reps), 0.5 * err(to_ref))
  expect_lt(err(to_reps), 0.03)
  # the fitted knots undo the jitter: measured time jitter^-1(after)
  knot_err <- function(reg) {
    w <- reg$warps[reg$warps$feature == "fitted", ]
    truth <- vapply(seq_len(nrow(w)), function(i) {
      stats::uniroot(function(x) jitter(x, a[w$replicate[i]]) - w$t_after[i], c(-1, 21))$root
    }, numeric(1))
    rms(w$t_before - truth)
  }
  expect_lt(knot_err(to_reps), 0.5 * knot_err(to_ref))
  for (r in seq_along(a)) expect_true(all(diff(warp_knots(to_reps$warps, r)$before) > 0))
  # the landmarks are the same either way
  lm <- function(reg) reg$warps[reg$warps$feature != "fitted", ]
  expect_equal(lm(to_reps)$t_before, lm(to_ref)$t_before)
  expect_error(register_curves(field_runs(reps[1, , drop = FALSE], t), ref, windows, knots_every = 1,
                               knots_to = "replicates"), class = "wavevalid_error_input")
  expect_error(register_curves(field, ref, windows, knots_every = 1, knots_to = "model"),
               "knots_to", class = "wavevalid_error_input")
})

test_that("knots_every must be a sensible spacing", {
  t <- grid()
  field <- field_runs(rbind(event_curve(t)), t)
  ref <- list(site1 = event_curve(t))
  expect_error(register_curves(field, ref, windows, knots_every = 0), class = "wavevalid_error_input")
  expect_error(register_curves(field, ref, windows, knots_every = 50), class = "wavevalid_error_input")
  expect_error(register_curves(field, ref, windows, knots_every = "2"), class = "wavevalid_error_input")
})

test_that("landmarks are located between grid points", {
  t <- seq(0, 10, length.out = 256)
  peak <- function(at) exp(-((t - at) / 0.3)^2) - exp(-((t - at - 1) / 0.3)^2)
  field <- field_runs(rbind(peak(4.0137), peak(4.2311)), t)
  reg <- register_curves(field, list(site1 = peak(4.1)), windows = list(c(3, 6.5)), refine = TRUE)
  lm <- as.data.frame(unclass(reg$warps))
  # a Gaussian peak is nearly a parabola at its top: the vertex is within a
  # small fraction of the grid step (0.039) of the true location
  expect_equal(lm$t_after[lm$feature == "max"], rep(4.1, 2), tolerance = 2e-3 / 4.1)
  expect_equal(lm$t_before[lm$feature == "max"], c(4.0137, 4.2311), tolerance = 2e-3 / 4.1)
  expect_equal(lm$t_before[lm$feature == "min"], c(5.0137, 5.2311), tolerance = 2e-3 / 5)
  # the grid maximum alone would be off by up to half a step
  expect_gt(abs(t[which.max(peak(4.0137))] - 4.0137), 0.01)
  # registered curves line up with the reference far better than the grid allows
  expect_lt(max(abs(reg$curves$site1[1, ] - peak(4.1))), 0.02)
  on_grid <- register_curves(field, list(site1 = peak(4.1)), windows = list(c(3, 6.5)))
  expect_true(all(as.data.frame(unclass(on_grid$warps))$t_before %in% field$t))
  expect_gt(max(abs(on_grid$curves$site1[1, ] - peak(4.1))), 0.05)
  expect_error(register_curves(field, list(site1 = peak(4.1)), windows = list(c(3, 6.5)), refine = NA),
               class = "wavevalid_error_input")
})

test_that("rows of the warps keep their class, columns short of it give a data frame", {
  t <- seq(0, 10, length.out = 256)
  peak <- function(at) exp(-((t - at) / 0.3)^2) - exp(-((t - at - 1) / 0.3)^2)
  field <- field_runs(rbind(peak(4.0137), peak(4.2311)), t)
  w <- register_curves(field, list(site1 = peak(4.1)), windows = list(c(3, 6.5)))$warps
  one <- w[w$replicate == 2, ]
  expect_s3_class(one, "wv_warps")
  expect_identical(attr(one, "windows"), attr(w, "windows"))
  expect_equal(nrow(one), 2L)
  expect_output(print(one), "warps of 1 replicate")
  cols <- w[, c("t_before", "t_after")]
  expect_false(inherits(cols, "wv_warps"))
  expect_s3_class(cols, "data.frame")
  expect_identical(w$t_after, as.data.frame(unclass(w))$t_after)
})

test_that("a shifted logistic rise is registered by its steepest point and by a level crossing", {
  t <- seq(0, 10, length.out = 512)
  h <- t[2] - t[1]
  rise <- function(at, amp = 1) amp * stats::plogis((t - at) / 0.25)
  ref <- rise(5)
  shifts <- c(-0.37, 0.123, 0.41)
  field <- field_runs(t(vapply(shifts, function(d) rise(5 + d, amp = 1.2), numeric(512))), t)
  win <- list(c(2.5, 8))
  near <- t > 3.5 & t < 6.5
  off <- function(m) max(abs(m[, near] / 1.2 - matrix(ref[near], nrow(m), sum(near), byrow = TRUE)))
  for (f in c("rise", "cross")) {
    fine <- register_curves(field, list(site1 = ref), win, features = f, refine = TRUE)
    w <- fine$warps
    expect_identical(w$feature, rep(f, 3))
    # the landmark of a rise centred at 5 + d is at 5 + d: the registration recovers the shift
    expect_lt(max(abs(w$t_before - w$t_after - shifts)), 0.02 * h)
    expect_lt(max(abs(w$t_after - 5)), 0.02 * h)
    # and the registered curves follow the reference around the event
    expect_lt(off(fine$curves$site1), off(field$curves$site1) / 10)
    grid <- register_curves(field, list(site1 = ref), win, features = f)$warps
    expect_true(all(abs(grid$t_before - (5 + shifts)) <= h))
    expect_true(all(grid$t_before %in% t))
  }
  # the level crossed: a fraction of each curve's range in the window, or a value
  inside <- t >= win[[1]][1] & t <= win[[1]][2]
  lv <- min(ref[inside]) + 0.25 * diff(range(ref[inside]))
  quarter <- register_curves(field, list(site1 = ref), win, features = "cross", cross_fraction = 0.25,
                             refine = TRUE)$warps
  expect_lt(abs(quarter$t_after[1] - (5 + 0.25 * stats::qlogis(lv))), 1e-3)
  expect_lt(max(abs(quarter$t_before - quarter$t_after - shifts)), 0.02 * h)
  level <- register_curves(field, list(site1 = ref), win, features = "cross", cross_value = 0.6,
                           refine = TRUE)$warps
  expect_lt(abs(level$t_after[1] - (5 + 0.25 * stats::qlogis(0.6))), 1e-3)
  expect_lt(max(abs(level$t_before - (5 + shifts))), 1e-3)
  expect_warning(old <- register_curves(field, list(site1 = ref), win, features = "cross", cross_level = 0.6,
                                        refine = TRUE)$warps, class = "wavevalid_warning_deprecated")
  expect_identical(old, level)
  # a fall is the rise of the negated curves; several features are ordered by time
  down <- field_runs(-field$curves$site1, t)
  both <- register_curves(down, list(site1 = -ref), win, features = c("fall", "cross"), cross_fraction = 0.25,
                          refine = TRUE)$warps
  expect_identical(both$feature[both$replicate == 1], c("fall", "cross"))
  expect_lt(max(abs(both$t_before[both$feature == "fall"] - 5 - shifts)), 0.02 * h)
  # a level the curves never cross, and bad arguments
  expect_error(register_curves(field, list(site1 = ref), win, features = "cross", cross_value = 3),
               class = "wavevalid_error_input")
  expect_error(register_curves(field, list(site1 = ref), win, features = "slope"), class = "wavevalid_error_input")
  expect_error(register_curves(field, list(site1 = ref), win, features = "cross", cross_fraction = 1),
               class = "wavevalid_error_input")
})
