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
  f0 <- testbed_unwarped_field(tb, 3)
  expect_s3_class(f0, "wv_field")
  expect_identical(f0$t, tb$A$field$t)
  expect_identical(lapply(f0$curves, dim), lapply(tb$A$field$curves, dim))
  # each replicate is reality plus the test bed's AR(1) noise, the draws of testbed_noise() at the seed
  # in turn (site by site, replicate by replicate), and the caller's random numbers are left as they were
  n_t <- length(f0$t)
  noise <- withr::with_seed(3, lapply(f0$curves, function(y) t(replicate(nrow(y), testbed_noise(n_t)))))
  for (s in names(f0$curves)) {
    expect_equal(f0$curves[[s]], sweep(noise[[s]], 2L, tb$truth$reality[[s]], `+`), tolerance = 1e-12)
  }
  before <- withr::with_seed(9, {
    testbed_unwarped_field(tb, 3)
    stats::runif(1)
  })
  expect_identical(before, withr::with_seed(9, stats::runif(1)))
  # a warp moves reality, the same for every replicate, and leaves the noise: reality at the times of the
  # monotone spline through the knots
  w <- tb$truth$warps
  w <- w[w$condition == "A" & w$replicate == 1, ]
  fw <- testbed_unwarped_field(tb, 3, w)
  at <- stats::splinefun(w$t, w$w, method = "monoH.FC")(f0$t)
  for (s in names(f0$curves)) {
    moved <- stats::splinefun(f0$t, tb$truth$reality[[s]], method = "fmm")(pmin(pmax(at, f0$t[1]), f0$t[n_t]))
    expect_equal(fw$curves[[s]] - f0$curves[[s]],
                 matrix(moved - tb$truth$reality[[s]], nrow(f0$curves[[s]]), n_t, byrow = TRUE), tolerance = 1e-10)
    expect_gt(max(abs(moved - tb$truth$reality[[s]])), 0.01)
  }
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
