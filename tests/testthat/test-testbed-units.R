tb <- testbed_units(seed = 2, hidden = "natural_convection")
grid <- 600 * (0:255) / 256

# The temperature of a one-row wv_runs as a vector.
temp <- function(runs) runs$curves$site1[1, ]

# Design rows of the units of condition A at the true inputs.
units_design <- function(tb, x_nom = c(x1 = 0.5, x2 = 0.5), deltas = tb$truth$units_delta) {
  x <- sweep(deltas, 2, x_nom[colnames(deltas)], `+`)
  d <- data.frame(u1 = tb$truth$u[["u1"]], u2 = tb$truth$u[["u2"]], x)
  rownames(d) <- NULL
  d
}

test_that("the cooling test bed has the documented layout", {
  expect_s3_class(tb, c("wv_testbed_units", "wv_testbed"), exact = TRUE)
  expect_named(tb, c("iu", "A", "B", "truth", "windows"))
  expect_null(tb$windows)
  expect_identical(tb$iu$name, c("u1", "u2", "x1", "x2"))
  expect_identical(tb$iu$type, rep(c("calibration", "variation"), c(2, 2)))
  n_runs <- c(A = 60L, B = 40L)
  for (cd in names(n_runs)) {
    expect_s3_class(tb[[cd]]$runs, "wv_runs")
    expect_s3_class(tb[[cd]]$field, "wv_field")
    expect_identical(names(tb[[cd]]$runs$design), tb$iu$name)
    expect_identical(nrow(tb[[cd]]$runs$design), n_runs[[cd]])
    expect_identical(tb[[cd]]$runs$t, grid)
    expect_identical(tb[[cd]]$field$t, grid)
    expect_named(tb[[cd]]$runs$curves, "site1")
    expect_identical(dim(tb[[cd]]$field$curves$site1), c(24L, 256L))
    expect_true(all(is.finite(tb[[cd]]$runs$curves$site1)))
  }
  # the nominal run is the last of A; B's design sits on B's nominals
  expect_equal(unlist(tb$A$runs$design[60, ]), stats::setNames(rep(0.5, 4), tb$iu$name))
  expect_equal(tb$A$runs$curves$site1[60, ], temp(simulate_units(data.frame(u1 = 0.5))))
  expect_equal(tb$B$x_nom, c(x1 = 0.7, x2 = 0.65))
  expect_equal(colMeans(tb$B$runs$design[c("x1", "x2")]), tb$B$x_nom, tolerance = 0.02,
               ignore_attr = TRUE)
  expect_identical(dim(tb$truth$units_delta), c(6L, 2L))
  expect_identical(dimnames(tb$truth$units_delta), list(paste0("A", 1:6), c("x1", "x2")))
  expect_equal(tb$truth$delta, colMeans(tb$truth$units_delta))
  expect_equal(tb$truth$delta_B, colMeans(tb$truth$units_delta_B))
  expect_identical(dim(tb$truth$reality_units$site1), c(6L, 256L))
  expect_identical(tb$truth$hidden, "natural_convection")
  expect_identical(tb$truth$seed, 2L)
  expect_no_error(validate_wv_testbed(tb))
  expect_output(print(tb), "24 field replicates of 6 units")
  expect_output(print(summary(tb)), "units")
  expect_s3_class(autoplot(tb, "B"), "ggplot")
})

test_that("the field declares its units: n_units distinct, n_rep tests each", {
  small <- testbed_units(seed = 4, n_units = 5, n_rep = 3)
  for (cd in c("A", "B")) {
    u <- small[[cd]]$field$units$site1
    expect_length(u, nrow(small[[cd]]$field$curves$site1))
    expect_identical(as.vector(table(u)), rep(3L, 5))
    expect_identical(unique(u), paste0(cd, 1:5))
  }
  # the tests of a unit are its noise-free curve plus small noise
  res <- small$A$field$curves$site1 - small$truth$reality_units$site1[rep(1:5, each = 3), ]
  expect_lt(abs(sd(res) - 0.2), 0.05)
  expect_lt(max(abs(rowMeans(res))), 0.2)
})

test_that("each unit has its own inputs and the units' spread shrinks more than tenfold", {
  deltas <- tb$truth$units_delta
  expect_gt(min(apply(deltas, 2, sd)), 0.03)
  # the unit's noise-free curve is the model at u* and its own inputs, mechanism on
  d <- units_design(tb)
  d$s_natural_convection <- 1
  expect_equal(tb$truth$reality_units$site1,
               simulate_units(d, mechanism = "natural_convection")$curves$site1,
               ignore_attr = TRUE)
  spread <- apply(tb$truth$reality_units$site1, 2, sd)
  early <- mean(spread[grid < 30])
  late <- mean(spread[grid > 540])
  expect_gt(early, 5)
  expect_gt(early / late, 10)
  # the field's replicates show it too (unit means over their tests)
  means <- rowsum(tb$A$field$curves$site1, tb$A$field$units$site1) / 4
  s <- apply(means, 2, sd)
  expect_gt(mean(s[grid < 30]) / mean(s[grid > 540]), 10)
  # every specimen approaches the ambient 295 K
  expect_true(all(abs(tb$truth$reality_units$site1[, 256] - 295) < 3))
})

test_that("nothing hidden makes reality the simulator at the true inputs; a mechanism changes it", {
  plain <- testbed_units(seed = 2)
  d <- data.frame(as.list(c(plain$truth$u, 0.5 + plain$truth$delta)))
  expect_identical(plain$truth$reality$site1, temp(simulate_units(d)))
  expect_identical(plain$truth$reality_units$site1,
                   simulate_units(units_design(plain))$curves$site1, ignore_attr = TRUE)
  expect_identical(plain$truth$units_delta, tb$truth$units_delta)
  for (m in units_mechanisms()) {
    on <- testbed_units(seed = 2, hidden = m)
    change <- on$truth$reality$site1 - plain$truth$reality$site1
    expect_gt(max(abs(change)), 1)
    expect_lt(max(abs(change)), 6)
    # smooth and largest after the first minute
    expect_lt(max(abs(change[grid < 60])), max(abs(change)) / 2)
    expect_false(isTRUE(all.equal(on$A$field$curves, plain$A$field$curves)))
  }
  sig <- units_signatures(c(u1 = 0.5, u2 = 0.5))
  expect_named(sig, units_mechanisms())
  expect_gt(min(sig$ambient_drift$site1[grid > 400]), 1)
})

test_that("the test bed depends only on the seed and leaves the caller's stream alone", {
  withr::local_seed(5)
  before <- .Random.seed
  again <- testbed_units(seed = 2, hidden = "natural_convection")
  expect_identical(.Random.seed, before)
  expect_identical(again, tb)
  other <- testbed_units(seed = 3, hidden = "natural_convection")
  expect_false(isTRUE(all.equal(other$truth$units_delta, tb$truth$units_delta)))
  expect_false(isTRUE(all.equal(other$A$field$curves, tb$A$field$curves)))
})

test_that("unknown mechanisms and bad arguments give classed errors", {
  expect_error(testbed_units(hidden = "convection"), class = "wavevalid_error")
  expect_error(testbed_units(hidden = "convection"), "Unknown hidden mechanism")
  expect_error(simulate_units(data.frame(s_radiation = 1), mechanism = "radiation"),
               class = "wavevalid_error")
  expect_error(testbed_units(n_units = 1), class = "wavevalid_error")
})

test_that("a temperature term is an extra heat loss; at strength 0 the model is unchanged", {
  stand <- testbed_term("temperature", function(T) 0.02 * (T - 295))
  runs <- simulate_units(data.frame(s_term = c(0, 1)), term = stand, states = TRUE)
  base <- temp(simulate_units(data.frame(u1 = 0.5)))
  expect_identical(runs$curves$site1[1, ], base)
  expect_true(all(runs$curves$site1[2, -1] < base[-1]))
  st <- attr(runs, "states")
  expect_named(st, c("temperature", "ambient", "convection", "radiation"))
  expect_identical(st$temperature, runs$curves$site1)
  expect_true(all(st$ambient == 295))
  expect_error(simulate_units(data.frame(s_term = 1),
                              term = testbed_term("velocity", function(v) v)),
               class = "wavevalid_error")
})
