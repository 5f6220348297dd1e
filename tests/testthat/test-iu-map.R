test_that("iu_map builds the report's I/U map with range/6 prior sds", {
  iu <- iu_map(
    name = c("u1", "x1", "x5"),
    type = c("calibration", "variation", "variation"),
    lower = c(0.125, 0.1667, 0.3529), upper = c(0.875, 0.8333, 0.6471)
  )
  expect_s3_class(iu, "wv_iu")
  expect_equal(iu$nominal, c(0.5, 0.5, 0.5))
  expect_true(is.na(iu$prior_sd[1]))
  expect_equal(iu$prior_sd[3], (0.6471 - 0.3529) / 6)
  expect_snapshot(print(iu))
  expect_snapshot(print(summary(iu)))
})

test_that("iu_map rejects bad input with classed errors", {
  expect_error(iu_map(c("a", "b"), "variation", c(0, 0), c(1)), class = "wavevalid_error_input")
  expect_error(iu_map("a", "variation", 1, 1), class = "wavevalid_error_input")
  expect_error(iu_map("a", "variation", 2, 1), class = "wavevalid_error_input")
  expect_error(iu_map("a", "variation", 0, 1, nominal = 1.5), class = "wavevalid_error_input")
  expect_error(iu_map(c("a", "a"), "variation", c(0, 0), c(1, 1)), class = "wavevalid_error_input")
  expect_error(iu_map("a", "tuning", 0, 1), class = "wavevalid_error_input")
  expect_error(iu_map("a", "variation", 0, 1, prior_sd = -1), class = "wavevalid_error_input")
  expect_error(iu_map("a", "variation", NA, 1), class = "wavevalid_error_input")
  expect_snapshot(iu_map("a", "variation", 2, 1), error = TRUE)
})

test_that("prior draws follow the truncated normal and uniform priors", {
  withr::local_seed(1)
  iu <- iu_map(c("u", "x"), c("calibration", "variation"), c(0, 0.2), c(1, 0.8))
  d <- iu_prior_draws(iu, 20000)
  expect_true(all(d[, "u"] >= 0 & d[, "u"] <= 1))
  expect_true(all(d[, "x"] >= 0.2 & d[, "x"] <= 0.8))
  expect_equal(mean(d[, "u"]), 0.5, tolerance = 0.01)
  expect_equal(sd(d[, "x"]), 0.1 * sqrt(1 - 2 * 3 * dnorm(3) / (2 * pnorm(3) - 1)), tolerance = 0.02)
  # the density integrates to one
  v <- seq(0.2, 0.8, length.out = 2001)
  expect_equal(sum(iu_prior_density(iu, 2, v)) * diff(v[1:2]), 1, tolerance = 1e-3)
  # each input's prior density over its range, one panel each, integrating to one
  pd <- plot_drawn(autoplot(iu))
  expect_identical(pd$geoms, "GeomLine")
  expect_identical(pd$panels, 2L)
  expect_identical(nrow(pd$data[[1]]), 2L * 201L)
  area <- tapply(seq_len(nrow(pd$data[[1]])), pd$data[[1]]$PANEL, function(i) {
    x <- pd$data[[1]]$x[i]
    y <- pd$data[[1]]$y[i]
    sum(diff(x) * (y[-1] + y[-length(y)]) / 2)
  })
  expect_equal(unname(as.numeric(area)), c(1, 1), tolerance = 1e-3)
  expect_equal(range(pd$data[[1]]$x[pd$data[[1]]$PANEL == 2]), c(0.2, 0.8))
  expect_identical(pd$labels$title, "Prior of each input")
})

test_that("design_maximin() gives a reproducible Latin hypercube on the ranges, nominal last", {
  iu <- iu_map(c("u1", "x1", "x2"), c("calibration", "variation", "variation"),
               lower = c(0, 10, -1), upper = c(1, 20, 1), nominal = c(0.5, 15, 0))
  d <- design_maximin(iu, 21, seed = 4)
  expect_identical(dim(d), c(21L, 3L))
  expect_named(d, iu$name)
  expect_equal(unlist(d[21, ]), stats::setNames(iu$nominal, iu$name))
  # one point in each of the 20 strata of every input
  for (k in seq_len(3)) {
    strata <- floor((d[1:20, k] - iu$lower[k]) / (iu$upper[k] - iu$lower[k]) * 20)
    expect_setequal(strata, 0:19)
  }
  withr::local_seed(99)
  expect_identical(design_maximin(iu, 21, seed = 4), d)
  expect_false(identical(design_maximin(iu, 21, seed = 5), d))
  # better spread than a random Latin hypercube of the same size
  scaled <- function(x) sweep(sweep(as.matrix(x), 2, iu$lower), 2, iu$upper - iu$lower, `/`)
  random <- vapply(1:3, function(j) (sample.int(20) - stats::runif(20)) / 20, numeric(20))
  expect_gt(min(stats::dist(scaled(d[1:20, ]))), min(stats::dist(random)))
  expect_identical(nrow(design_maximin(iu, 10, nominal = FALSE, seed = 1)), 10L)
  expect_error(design_maximin(iu, 1), class = "wavevalid_error_input")
  expect_error(design_maximin(list(), 10), class = "wavevalid_error_input")
  expect_error(design_maximin(iu, 10, nominal = NA), class = "wavevalid_error_input")
})

test_that("iu_add appends inputs as iu_map would build them", {
  iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), lower = c(0, 1), upper = c(1, 3), nominal = c(0.4, 2))
  got <- iu_add(iu, c("s_a", "x2"), type = c("calibration", "variation"), lower = c(0, -1), upper = c(2, 1))
  want <- iu_map(c("u1", "x1", "s_a", "x2"), c("calibration", "variation", "calibration", "variation"),
                 lower = c(0, 1, 0, -1), upper = c(1, 3, 2, 1), nominal = c(0.4, 2, 1, 0))
  expect_identical(got, want)
  expect_identical(got$prior_sd, c(NA, 1 / 3, NA, 1 / 3))
  expect_identical(iu_add(iu, "s", lower = 0, upper = 1)$type, c("calibration", "variation", "calibration"))
})

test_that("iu_add refuses bad input with classed errors", {
  iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), lower = c(0, 0), upper = c(1, 1))
  expect_error(iu_add(data.frame(name = "u1"), "s", lower = 0, upper = 1), class = "wavevalid_error_input")
  expect_error(iu_add(iu, "u1", lower = 0, upper = 1), class = "wavevalid_error_input")
  expect_error(iu_add(iu, "s"), class = "wavevalid_error_input")
  expect_error(iu_add(iu, c("s", "t"), lower = 0, upper = c(1, 1)), class = "wavevalid_error_input")
  expect_error(iu_add(iu, "s", lower = 1, upper = 0), class = "wavevalid_error_input")
  expect_error(iu_add(iu, 3, lower = 0, upper = 1), class = "wavevalid_error_input")
})

test_that("iu_hold() fixes the inputs at the values and leaves the others as they were", {
  iu <- iu_map(c("u1", "u2", "x1"), c("calibration", "calibration", "variation"), lower = c(0, 0, 1),
               upper = c(1, 2, 3), prior = c("normal", "uniform", "normal"))
  held <- iu_hold(iu, c(x1 = 2.5, u1 = 0))
  expect_s3_class(held, "wv_iu")
  k <- match(c("x1", "u1"), held$name)
  expect_identical(held$type[k], c("calibration", "calibration"))
  expect_identical(held$nominal[k], c(2.5, 0))
  expect_identical(held$prior[k], c("uniform", "uniform"))
  expect_true(all(held$lower[k] < c(2.5, 0) & held$upper[k] > c(2.5, 0)))
  expect_lt(max(held$upper[k] - held$lower[k]), 1e-6)
  expect_identical(as.data.frame(held)[2, ], as.data.frame(iu)[2, ])
  # the held inputs' prior draws are their values; the others are drawn as before
  d <- withr::with_seed(1, iu_prior_sample(held, 200))
  expect_lt(max(abs(d[, "x1"] - 2.5)), 1e-6)
  expect_lt(max(abs(d[, "u1"])), 1e-6)
  expect_gt(stats::sd(d[, "u2"]), 0.3)
})

test_that("iu_hold() refuses an unknown input, a value outside the range and what cannot be held", {
  iu <- iu_map(c("u1", "u2", "x1"), c("calibration", "calibration", "variation"), lower = c(0, 0, 1),
               upper = c(1, 2, 3))
  expect_error(iu_hold(iu, c(nope = 0.5)), class = "wavevalid_error_input")
  expect_error(iu_hold(iu, c(x1 = 3.5)), class = "wavevalid_error_input")
  expect_error(iu_hold(iu, c(u1 = -0.1)), class = "wavevalid_error_input")
  expect_error(iu_hold(iu, 0.5), class = "wavevalid_error_input")
  expect_error(iu_hold(iu, c(u1 = NA)), class = "wavevalid_error_input")
  expect_error(iu_hold(iu, c(u1 = 0.2, u1 = 0.3)), class = "wavevalid_error_input")
  expect_error(iu_hold(as.data.frame(iu), c(u1 = 0.5)), class = "wavevalid_error_input")
  cond <- iu_add(iu, "dose", type = "condition", lower = 200, upper = 600, nominal = 400)
  expect_error(iu_hold(cond, c(dose = 250)), class = "wavevalid_error_input")
  joint <- iu_prior_joint(iu, c("u1", "u2"), mean = c(0.5, 1), cov = diag(c(0.04, 0.09)))
  expect_error(iu_hold(joint, c(u1 = 0.5)), class = "wavevalid_error_input")
  expect_snapshot(iu_hold(iu, c(x1 = 3.5, u2 = 1)), error = TRUE)
})
