# The same draws, bit for bit: a reorganisation of the code must not move a
# number. The record (helper-golden.R) holds the example fit's draws and the
# draws, bias, noise and findings of a fit on each test bed.
test_that("the example fit and both test beds draw what they drew, to the bit", {
  skip_on_cran()
  want <- readRDS(test_path("fixtures", "golden.rds"))
  got <- golden_record()
  for (bed in names(want)) expect_identical(got[[bed]], want[[bed]], label = bed)
})
