tb <- testbed_suspension(seed = 11, hidden = "tire_liftoff")
grid <- 65 * (0:4095) / 4096
sites <- c("site1", "site2")
noise_sd <- 0.03

# Design row at the true inputs of condition A, optionally with a mechanism on.
truth_design <- function(tb, mechanism = NULL, strength = 1) {
  d <- as.data.frame(t(c(tb$truth$u, 0.5 + tb$truth$delta)))
  if (!is.null(mechanism)) d[[paste0("s_", mechanism)]] <- strength
  d
}

test_that("the same seed gives identical data and another seed differs", {
  again <- testbed_suspension(seed = 11, hidden = "tire_liftoff")
  expect_identical(again, tb)
  other <- testbed_suspension(seed = 12, hidden = "tire_liftoff")
  expect_false(isTRUE(all.equal(other$A$runs$design, tb$A$runs$design)))
  expect_false(isTRUE(all.equal(other$truth$u, tb$truth$u)))
  expect_false(isTRUE(all.equal(other$truth$reality, tb$truth$reality)))
  expect_false(isTRUE(all.equal(other$A$field$curves, tb$A$field$curves)))
})

test_that("building a test bed leaves the caller's random stream alone", {
  withr::local_seed(5)
  before <- .Random.seed
  testbed_suspension(seed = 3)
  expect_identical(.Random.seed, before)
})

test_that("the test bed has the documented layout", {
  expect_s3_class(tb, c("wv_testbed_suspension", "wv_testbed"), exact = TRUE)
  expect_named(tb, c("iu", "A", "B", "added_mass", "truth", "windows"))
  expect_s3_class(tb$iu, "wv_iu")
  expect_identical(tb$iu$name, c("u1", "u2", paste0("x", 1:7)))
  expect_equal(tb$iu$lower, c(0.125, 0.125, 0.1667, 0.1667, 0.2083, 0.1923, 0.3529, 0.1471, 0.1923))
  expect_equal(tb$iu$upper, c(0.875, 0.875, 0.8333, 0.8333, 0.7917, 0.8077, 0.6471, 0.8529, 0.8077))
  expect_equal(tb$iu$prior_sd[3:9], (tb$iu$upper - tb$iu$lower)[3:9] / 6)
  expect_identical(tb$windows, list(c(6, 11), c(37, 41)))
  n_runs <- c(A = 66L, B = 65L, added_mass = 2L)
  n_rep <- c(A = 7L, B = 8L, added_mass = 1L)
  for (cd in names(n_runs)) {
    expect_s3_class(tb[[cd]]$runs, "wv_runs")
    expect_s3_class(tb[[cd]]$field, "wv_field")
    expect_identical(names(tb[[cd]]$runs$design), tb$iu$name)
    expect_identical(nrow(tb[[cd]]$runs$design), n_runs[[cd]])
    expect_identical(tb[[cd]]$runs$t, grid)
    expect_identical(tb[[cd]]$field$t, grid)
    expect_named(tb[[cd]]$runs$curves, sites)
    expect_named(tb[[cd]]$field$curves, sites)
    for (s in sites) {
      expect_identical(dim(tb[[cd]]$runs$curves[[s]]), c(n_runs[[cd]], 4096L))
      expect_identical(dim(tb[[cd]]$field$curves[[s]]), c(n_rep[[cd]], 4096L))
      expect_true(all(is.finite(tb[[cd]]$runs$curves[[s]])))
    }
  }
  expect_named(tb$truth$u, c("u1", "u2"))
  expect_named(tb$truth$delta, paste0("x", 1:7))
  expect_true(all(tb$truth$u >= 0.125 & tb$truth$u <= 0.875))
  x_star <- 0.5 + tb$truth$delta
  expect_true(all(x_star >= tb$iu$lower[3:9] & x_star <= tb$iu$upper[3:9]))
  for (what in c("reality", "reality_B", "reality_added_mass")) {
    expect_named(tb$truth[[what]], sites)
    expect_identical(lengths(tb$truth[[what]]), c(site1 = 4096L, site2 = 4096L))
  }
  expect_equal(tb$A$field$x_nom, setNames(rep(0.5, 7), paste0("x", 1:7)))
  expect_equal(tb$B$field$x_nom, tb$truth$x_nom_B)
  expect_equal(tb$added_mass$field$x_nom[["x1"]], 0.5 + tb$added_mass$delta[["x1"]])
})

test_that("condition A is a Latin hypercube on the I/U ranges plus the centre", {
  d <- as.matrix(tb$A$runs$design)
  expect_equal(unname(d[66, ]), rep(0.5, 9))
  cube <- sweep(sweep(d[1:65, ], 2, tb$iu$lower), 2, tb$iu$upper - tb$iu$lower, "/")
  for (j in 1:9) expect_setequal(floor(cube[, j] * 65), 0:64)
  # The maximin search beats a typical random Latin hypercube.
  withr::local_seed(1)
  random <- replicate(20, min(dist(vapply(1:9, function(j) (sample.int(65) - runif(65)) / 65, numeric(65)))))
  expect_gt(min(dist(cube)), max(random))
})

test_that("condition B uses the same unit-cube design around new nominals", {
  lo <- tb$iu$lower
  w <- tb$iu$upper - lo
  nom_B <- c(u1 = 0.5, u2 = 0.5, tb$truth$x_nom_B)
  cube_A <- sweep(sweep(as.matrix(tb$A$runs$design[1:65, ]), 2, lo), 2, w, "/")
  cube_B <- sweep(sweep(as.matrix(tb$B$runs$design), 2, lo + nom_B - 0.5), 2, w, "/")
  expect_equal(unname(cube_B), unname(cube_A))
  expect_false(isTRUE(all.equal(tb$truth$delta_B, tb$truth$delta)))
  expect_false(isTRUE(all.equal(tb$truth$reality_B, tb$truth$reality)))
})

test_that("the added-mass pair differs only in x1 and raises the static load", {
  d <- tb$added_mass$runs$design
  expect_equal(unlist(d[2, ]) - unlist(d[1, ]), c(u1 = 0, u2 = 0, x1 = 0.15, x2 = 0, x3 = 0, x4 = 0,
                                                  x5 = 0, x6 = 0, x7 = 0))
  expect_equal(unlist(d[1, ]), setNames(rep(0.5, 9), tb$iu$name))
  # At t = 0 the car is at rest: the strut loads are the static axle loads.
  mass <- 1150 * (1 + 0.6 * c(0, 0.15))
  c_runs <- tb$added_mass$runs$curves
  expect_equal(c_runs$site1[, 1], mass * 9.81 * 1.5 / 2.7 / 1000)
  expect_equal(c_runs$site2[, 1], mass * 9.81 * 1.2 / 2.7 / 1000)
  expect_equal(tb$added_mass$runs$curves$site1[1, ], tb$A$runs$curves$site1[66, ])
})

test_that("RK4 with four sub-steps is converged well below the measurement noise", {
  coded <- as.matrix(truth_design(tb))
  p <- testbed_physical(coded)
  s <- hidden_strength("tire_liftoff", testbed_mechanisms())
  coarse <- suspension_simulate_cpp(p, s, grid, 4L)
  fine <- suspension_simulate_cpp(p, s, grid, 16L)
  for (site in sites) expect_lt(max(abs(coarse[[site]] - fine[[site]])), noise_sd / 3)
})

test_that("the mechanism switched on at strength 1 reproduces reality", {
  on <- simulate_suspension(truth_design(tb, "tire_liftoff"), mechanism = "tire_liftoff")
  for (s in sites) expect_identical(on$curves[[s]][1, ], tb$truth$reality[[s]])
  off <- simulate_suspension(truth_design(tb))
  expect_gt(max(abs(off$curves$site1[1, ] - tb$truth$reality$site1)), 1)
  half <- simulate_suspension(truth_design(tb, "tire_liftoff", 0.5), mechanism = "tire_liftoff")
  gap_half <- max(abs(half$curves$site1[1, ] - tb$truth$reality$site1))
  expect_gt(gap_half, 0.1)
  expect_lt(gap_half, max(abs(off$curves$site1[1, ] - tb$truth$reality$site1)))
})

test_that("strengths past reality's carry a mechanism further, up to its limit", {
  # the bump stop at 1.5 is stiffer than reality's; the lift-off stops at 1, where the tire's pull is gone
  base <- simulate_suspension(truth_design(tb))$curves$site1[1, ]
  gap <- function(m, s) max(abs(simulate_suspension(truth_design(tb, m, s), mechanism = m)$curves$site1[1, ] - base))
  expect_gt(gap("progressive_bumpstop", 1.5), 1.2 * gap("progressive_bumpstop", 1))
  expect_error(simulate_suspension(truth_design(tb, "progressive_bumpstop", 2.1), mechanism = "progressive_bumpstop"),
               "\\[0, 2\\]", class = "wavevalid_error")
  expect_error(simulate_suspension(truth_design(tb, "tire_liftoff", 1.1), mechanism = "tire_liftoff"),
               "\\[0, 1\\]", class = "wavevalid_error")
})

test_that("event mechanisms act only near the pothole and the bump", {
  base <- simulate_suspension(truth_design(tb))
  near <- (grid > 6 & grid < 13) | (grid > 37 & grid < 44)
  for (m in c("tire_liftoff", "digressive_damper", "progressive_bumpstop")) {
    on <- simulate_suspension(truth_design(tb, m), mechanism = m)
    for (s in sites) {
      d <- on$curves[[s]][1, ] - base$curves[[s]][1, ]
      expect_identical(max(abs(d[grid < 6])), 0, label = paste(m, s, "before the pothole"))
      expect_gt(max(abs(d[near])), 30 * noise_sd, label = paste(m, s, "near the events"))
      expect_lt(max(abs(d[!near])), 0.05 * max(abs(d[near])), label = paste(m, s, "away from the events"))
      expect_lt(sqrt(mean(d[!near]^2)), noise_sd, label = paste(m, s, "rms away from the events"))
    }
  }
})

test_that("strut friction acts all along the rough road", {
  base <- simulate_suspension(truth_design(tb))
  on <- simulate_suspension(truth_design(tb, "strut_friction"), mechanism = "strut_friction")
  for (s in sites) {
    d <- on$curves[[s]][1, ] - base$curves[[s]][1, ]
    for (span in list(c(1, 6), c(15, 35), c(45, 65))) {
      inside <- grid > span[1] & grid < span[2]
      expect_gt(sqrt(mean(d[inside]^2)), 5 * noise_sd, label = paste(s, "rms on", span[1], "to", span[2]))
    }
  }
})

test_that("field replicates are warped and noisy versions of reality", {
  t1 <- grid > 6 & grid < 8
  peak_real <- grid[t1][which.max(tb$truth$reality$site1[t1])]
  peaks <- apply(tb$A$field$curves$site1[, t1], 1, function(y) grid[t1][which.max(y)])
  expect_gt(diff(range(peaks)), 0.1)
  expect_lt(max(abs(peaks - peak_real)), 0.3)
  warps <- tb$truth$warps[tb$truth$warps$condition == "A", ]
  for (r in 1:7) {
    w <- warps[warps$replicate == r, c("t", "w")]
    res <- tb$A$field$curves$site1[r, ] - apply_warp(tb$truth$reality$site1, grid, w)
    expect_gt(sd(res), noise_sd / 2)
    expect_lt(sd(res), noise_sd * 2)
    expect_gt(cor(res[-1], res[-4096]), 0.8)
    expect_gt(sd(tb$A$field$curves$site1[r, ] - tb$truth$reality$site1), 3 * sd(res))
  }
  expect_gt(sd(tb$A$field$curves$site1[1, ] - tb$A$field$curves$site1[2, ]), noise_sd)
})

test_that("simulate_suspension fills inputs from nominals and checks its design", {
  d <- truth_design(tb)
  full <- simulate_suspension(d)
  part <- simulate_suspension(d["u1"], nominal = unlist(d[-1]))
  expect_equal(part$curves, full$curves)
  expect_identical(names(part$design), "u1")
  expect_error(simulate_suspension(data.frame(speed = 1)), class = "wavevalid_error_input")
  expect_error(simulate_suspension(d, mechanism = "strut_friction"), class = "wavevalid_error_input")
  expect_error(simulate_suspension(cbind(d, s_strut_friction = 1)), class = "wavevalid_error_input")
  expect_error(simulate_suspension(cbind(d, s_strut_friction = 2.5), mechanism = "strut_friction"),
               class = "wavevalid_error_input")
  expect_error(simulate_suspension(d, mechanism = "wind"), class = "wavevalid_error_input")
  expect_error(simulate_suspension(d, nominal = c(x9 = 0.5)), class = "wavevalid_error_input")
  expect_error(testbed_suspension(hidden = "wind"), class = "wavevalid_error_input")
  expect_error(testbed_suspension(hidden = c("none", "strut_friction")), class = "wavevalid_error_input")
  expect_error(testbed_suspension(seed = 1.5), class = "wavevalid_error_input")
  expect_snapshot(simulate_suspension(d, mechanism = "strut_friction"), error = TRUE)
})

test_that("several hidden mechanisms combine", {
  both <- testbed_suspension(seed = 11, hidden = c("tire_liftoff", "strut_friction"))
  d <- truth_design(tb, "tire_liftoff")
  d$s_strut_friction <- 1
  on <- simulate_suspension(d, mechanism = c("tire_liftoff", "strut_friction"))
  expect_identical(on$curves$site2[1, ], both$truth$reality$site2)
  expect_identical(both$A$runs, tb$A$runs)
})

test_that("print, summary and autoplot describe the test bed", {
  expect_snapshot(print(tb))
  expect_snapshot(summary(tb))
  expect_s3_class(autoplot(tb), "ggplot")
  expect_s3_class(autoplot(tb, "B", windows = NULL), "ggplot")
})

test_that("load_testbed() returns the shipped instance with the same layout", {
  shipped <- load_testbed()
  expect_s3_class(shipped, c("wv_testbed_suspension", "wv_testbed"), exact = TRUE)
  fresh <- testbed_suspension(seed = shipped$truth$seed, hidden = shipped$truth$hidden)
  expect_identical(shipped$truth$hidden, "progressive_bumpstop")
  expect_identical(names(shipped), names(fresh))
  for (cd in c("A", "B", "added_mass")) {
    expect_identical(names(shipped[[cd]]), names(fresh[[cd]]))
    expect_equal(shipped[[cd]]$runs, fresh[[cd]]$runs, tolerance = 1e-6)
    expect_equal(shipped[[cd]]$field, fresh[[cd]]$field, tolerance = 1e-6)
  }
  expect_equal(shipped$iu, fresh$iu)
  expect_equal(shipped$truth, fresh$truth, tolerance = 1e-6)
  expect_error(load_testbed(tempdir()), class = "wavevalid_error_input")
})

test_that("the unwarped field is reality plus the field noise, without time warps", {
  f <- unwarped_field(tb, seed = 3)
  expect_identical(unwarped_field(tb, seed = 3), f)
  expect_identical(dim(f$curves$site1), dim(tb$A$field$curves$site1))
  for (s in sites) {
    err <- sweep(f$curves[[s]], 2L, tb$truth$reality[[s]])
    # the noise of the replicates: sd 0.03, independent between replicates
    expect_lt(abs(sqrt(mean(err^2)) - noise_sd), 0.01)
    expect_lt(abs(stats::cor(err[1, ], err[2, ])), 0.2)
    # the warped replicates are much farther from reality near the events
    warped <- sweep(tb$A$field$curves[[s]], 2L, tb$truth$reality[[s]])
    expect_gt(sqrt(mean(warped^2)), 3 * sqrt(mean(err^2)))
  }
})

test_that("the field warped by one given warp differs from the unwarped one by the warp of reality", {
  w <- tb$truth$warps
  w <- w[w$condition == "A" & w$replicate == 1, c("t", "w")]
  f0 <- unwarped_field(tb, seed = 3)
  f1 <- unwarped_field(tb, seed = 3, warp = w)
  for (s in sites) {
    moved <- apply_warp(tb$truth$reality[[s]], f0$t, w) - tb$truth$reality[[s]]
    expect_gt(max(abs(moved)), 0.1)
    d <- f1$curves[[s]] - f0$curves[[s]]
    expect_equal(d, matrix(moved, nrow(d), length(moved), byrow = TRUE), tolerance = 1e-12)
  }
  identity <- data.frame(t = range(f0$t), w = range(f0$t))
  expect_equal(unwarped_field(tb, seed = 3, warp = identity), f0, tolerance = 1e-10)
})
