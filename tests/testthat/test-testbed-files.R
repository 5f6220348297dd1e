test_that("the test bed files round-trip through write_testbed() and load_testbed()", {
  shipped <- load_testbed()
  dir <- withr::local_tempdir()
  files <- write_testbed(shipped, dir)
  expect_setequal(basename(files), testbed_files())
  expect_identical(load_testbed(dir), shipped)
  # one row per curve: keys, then the values at the 4096 grid points
  head <- names(utils::read.csv(file.path(dir, "testbed_field.csv.xz"), nrows = 1L))
  expect_identical(head, c("condition", "replicate", "site", paste0("y", 1:4096)))
})

test_that("curve files in another layout give a classed error", {
  dir <- withr::local_tempdir()
  file.copy(file.path(system.file("extdata", package = "wavevalid"), testbed_files()), dir)
  # one row per value, as (condition, run, site, t, y)
  long <- data.frame(condition = "A", run = 1L, site = "site1", t = testbed_grid()[1:3], y = 1:3)
  utils::write.csv(long, file.path(dir, "testbed_runs.csv.xz"), row.names = FALSE)
  expect_error(load_testbed(dir), class = "wavevalid_error_input")
  expect_error(load_testbed(dir), "does not hold test bed curves")
})
