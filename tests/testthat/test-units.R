# Replicates declared as units: field_runs(units = ), kept through registration and site subsets.

test_that("field_runs() takes the unit of each replicate as a vector, a list by site or a column", {
  t <- seq(0, 1, length.out = 64)
  Y <- withr::with_seed(1, t(replicate(6, sin(2 * pi * t) + stats::rnorm(64, sd = 0.1))))
  f <- field_runs(Y, t, units = rep(c("a", "b", "c"), each = 2))
  expect_identical(f$units, list(site1 = rep(c("a", "b", "c"), each = 2)))
  expect_output(print(f), "6 replicates of 3 units")
  two <- field_runs(list(front = Y, rear = Y[1:4, ]), t,
                    units = list(rear = c(1, 1, 2, 2), front = rep(1:3, 2)))
  expect_identical(two$units, list(front = as.character(rep(1:3, 2)), rear = c("1", "1", "2", "2")))
  long <- data.frame(time = rep(t, 6), y = as.vector(t(Y)), test = rep(6:1, each = 64),
                     subject = rep(c("S1", "S2", "S3"), each = 128))
  fl <- field_runs(long, t = "time", y = "y", replicate = "test", units = "subject")
  # the replicates in sorted order of their ids (test 1 first: subject S3's)
  expect_identical(fl$units$site1, rep(c("S3", "S2", "S1"), each = 2))
  expect_null(field_runs(Y, t)$units)
})

test_that("units that cannot be read are classed errors that say how to give them", {
  t <- seq(0, 1, length.out = 64)
  Y <- withr::with_seed(1, t(replicate(6, sin(2 * pi * t) + stats::rnorm(64, sd = 0.1))))
  expect_error(field_runs(Y, t, units = 1:5), "unit of each replicate", class = "wavevalid_error_input")
  expect_error(field_runs(Y, t, units = c(1:5, NA)), class = "wavevalid_error_input")
  expect_error(field_runs(Y, t, units = rep(1, 6)), "leave `units` out", class = "wavevalid_error_input")
  expect_error(field_runs(list(a = Y, b = Y[1:3, ]), t, units = rep(1:2, 3)),
               "same number of replicates", class = "wavevalid_error_input")
  long <- data.frame(time = rep(t, 6), y = as.vector(t(Y)), test = rep(1:6, each = 64),
                     subject = rep(c("S1", "S2"), 192))
  expect_error(field_runs(long, t = "time", y = "y", replicate = "test", units = "subject"),
               "one unit", class = "wavevalid_error_column")
  expect_error(field_runs(long, t = "time", y = "y", units = "subject"), "replicate",
               class = "wavevalid_error_column")
  expect_error(field_runs(long, t = "time", y = "y", replicate = "test", units = "subj"),
               class = "wavevalid_error_column")
})

test_that("the units stay with their curves through registration and a subset of sites", {
  ex <- example_problem()
  t <- ex$field$t
  d <- as.data.frame(ex$emulators$design)
  event <- function(u) 1.3 * sin(2 * pi * t) + 0.6 * exp(-((t - 0.6 - 0.04 * (u - 0.5)) / 0.08)^2)
  runs <- model_runs(d, t(vapply(d$u1, event, numeric(length(t)))), t, site = "site1")
  field <- ex$field
  field$units <- list(site1 = c("a", "a", "b", "b"))
  reg <- register_curves(field, runs, list(c(0.45, 0.95)))
  expect_identical(reg$units, field$units)
  expect_identical(subset_field_sites(reg, "site1")$units, field$units)
})
