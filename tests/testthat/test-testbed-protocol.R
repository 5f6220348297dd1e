test_that("testbed_noise() is the test bed's AR(1) field noise", {
  e <- withr::with_seed(1, testbed_noise(20000))
  expect_identical(e, withr::with_seed(1, ar1_noise(20000)))
  expect_lt(abs(stats::sd(e) - 0.03), 0.005)
  expect_lt(abs(stats::cor(e[-1], e[-20000]) - 0.95), 0.02)
  e2 <- withr::with_seed(1, testbed_noise(20000, sd = 0.04, phi = 0.9))
  expect_lt(abs(stats::cor(e2[-1], e2[-20000]) - 0.9), 0.02)
  expect_error(testbed_noise(0), class = "wavevalid_error_input")
  expect_error(testbed_noise(10, phi = 2), class = "wavevalid_error_input")
})

test_that("testbed_unwarped_field() is the field without time warps, a warp given as knots", {
  tb <- load_testbed()
  expect_identical(testbed_unwarped_field(tb, 3), unwarped_field(tb, 3))
  w <- tb$truth$warps
  w <- w[w$condition == "A" & w$replicate == 1, ]
  expect_identical(testbed_unwarped_field(tb, 3, w), unwarped_field(tb, 3, w[c("t", "w")]))
  expect_error(testbed_unwarped_field(tb, 3, warp = list(1)), class = "wavevalid_error_input")
  expect_error(testbed_unwarped_field(tb$A$field, 3), class = "wavevalid_error_input")
})

test_that("testbed_beds() names each test bed's constructor, simulator, mechanisms and landmarks", {
  beds <- testbed_beds()
  expect_named(beds, c("suspension", "dosing"))
  expect_identical(beds$suspension$mechanisms(), testbed_mechanisms())
  expect_identical(beds$dosing$mechanisms(), dosing_mechanisms())
  expect_identical(beds$suspension$features, c("min", "max"))
  expect_identical(beds$dosing$features, "rise")
  expect_identical(beds$dosing$simulate, simulate_dosing)
})
