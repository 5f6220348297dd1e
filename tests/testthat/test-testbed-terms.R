# Added terms of the test beds' simulators and their state histories.

# The physical parameters at the nominal coded inputs (0.5 for every input).
susp_nominal <- testbed_physical(matrix(0.5, 1, 9, dimnames = list(NULL, testbed_iu()$name)))
dose_nominal <- dosing_physical(matrix(0.5, 1, 6, dimnames = list(NULL, dosing_iu()$name)))

# The largest error of a term's table (linear interpolation, as the
# simulators do) against its function over [lo, hi], on a grid 50 times
# finer than the table.
table_error <- function(term, lo, hi) {
  x <- seq(lo, hi, length.out = 50 * term$n_table)
  max(abs(stats::approx(term$x, term$y, x)$y - term$fun(x)))
}

max_gap <- function(a, b) max(vapply(names(a$curves), function(s) max(abs(a$curves[[s]] - b$curves[[s]])), 0))

test_that("the progressive bump stop written as a term of the compression reproduces the mechanism", {
  # kbs and the clearance are the same at both axles in the model
  expect_identical(susp_nominal[1, "kbsf"], susp_nominal[1, "kbsr"])
  expect_identical(susp_nominal[1, "gapf"], susp_nominal[1, "gapr"])
  kbs <- susp_nominal[1, "kbsf"]
  gap <- susp_nominal[1, "gapf"]
  bump <- function(n) testbed_term("compression", function(d) kbs * pmax(d - gap, 0)^2 / 0.03 / 1000, n_table = n)
  mech <- simulate_suspension(data.frame(s_progressive_bumpstop = 1), mechanism = "progressive_bumpstop",
                              states = TRUE)
  st <- attr(mech, "states")
  visited <- range(st$compression_front, st$compression_rear)
  # the table's error enters the strut load directly (kN) and moves the car a
  # little: measured, the loads differ by 0.9 to 1 times it; allowed 3 times
  gaps <- vapply(c(4001, 8001), function(n) {
    term <- bump(n)
    eps <- table_error(term, visited[1], visited[2])
    gap_n <- max_gap(simulate_suspension(data.frame(s_term = 1), term = term), mech)
    expect_lt(gap_n, 3 * eps)
    gap_n
  }, numeric(1))
  # a table twice as fine: the gap is interpolation error, falling as h^2
  expect_lt(gaps[2], gaps[1] / 3)
  expect_gt(gaps[1], 0)
})

test_that("strut friction as a term of the velocity and lift-off as a term of the tire force reproduce the mechanisms", {
  mech <- simulate_suspension(data.frame(s_strut_friction = 1), mechanism = "strut_friction", states = TRUE)
  st <- attr(mech, "states")
  visited <- range(st$velocity_front, st$velocity_rear)
  # the friction bends within 0.01 m/s of rest: a fine table over the default range
  friction <- testbed_term("velocity", function(v) 400 * v / sqrt(v^2 + 0.01^2) / 1000, n_table = 40001)
  eps <- table_error(friction, visited[1], visited[2])
  # measured: 3 times the table's error (the friction acts all along the road); allowed 5 times
  expect_lt(max_gap(simulate_suspension(data.frame(s_term = 1), term = friction), mech), 5 * eps)
  expect_lt(eps, 1e-3)
  # the tire's pull cancelled: the kink at 0 is a point of the default table, so the table is exact
  liftoff <- testbed_term("tire", function(f) pmax(-f, 0))
  expect_lt(table_error(liftoff, -70, 90), 1e-12)
  mech <- simulate_suspension(data.frame(s_tire_liftoff = 1), mechanism = "tire_liftoff")
  expect_lt(max_gap(simulate_suspension(data.frame(s_term = 1), term = liftoff), mech), 1e-10)
})

test_that("saturable elimination as a term of the concentration reproduces the mechanism", {
  cl <- dose_nominal[1, "cl"]
  v <- dose_nominal[1, "v"]
  sat <- testbed_term("concentration", function(C) -cl * C^2 / (10 + C))
  mech <- simulate_dosing(data.frame(s_saturable_elimination = 1), mechanism = "saturable_elimination",
                          states = TRUE)
  visited <- range(attr(mech, "states")$concentration)
  eps <- table_error(sat, visited[1], visited[2])
  # a rate error of at most eps mg/h moves at most eps * 48 mg over the 48
  # hours (the compartments only lose drug, the total elimination rising with
  # C), so C by at most eps * 48 / V
  tol <- eps * 48 / v
  expect_lt(max_gap(simulate_dosing(data.frame(s_term = 1), term = sat), mech), tol)
  expect_lt(tol, 1e-4)
})

test_that("a term of strength 0 and the states leave the curves exactly as they were", {
  bump <- testbed_term("compression", function(d) 100 * pmax(d - 0.04, 0)^2)
  d <- data.frame(u1 = c(0.3, 0.6), x6 = c(0.4, 0.5))
  plain <- simulate_suspension(d)
  zero <- simulate_suspension(cbind(d, s_term = 0), term = bump)
  expect_identical(zero$curves, plain$curves)
  expect_identical(zero$design, cbind(d, s_term = 0))
  with_states <- simulate_suspension(cbind(d, s_term = c(0.5, -1)), term = bump, states = TRUE)
  without <- simulate_suspension(cbind(d, s_term = c(0.5, -1)), term = bump)
  expect_identical(with_states$curves, without$curves)
  expect_null(attr(without, "states"))
  expect_false(isTRUE(all.equal(with_states$curves, plain$curves)))
  # a term of strength 0 with a mechanism on is the mechanism alone
  dm <- cbind(d, s_strut_friction = 1)
  expect_identical(simulate_suspension(cbind(dm, s_term = 0), mechanism = "strut_friction", term = bump)$curves,
                   simulate_suspension(dm, mechanism = "strut_friction")$curves)

  sat <- testbed_term("central", function(a) a / 10)
  dd <- data.frame(u1 = c(0.3, 0.6))
  plain <- simulate_dosing(dd)
  expect_identical(simulate_dosing(cbind(dd, s_term = 0), term = sat)$curves, plain$curves)
  expect_identical(simulate_dosing(cbind(dd, s_term = 1), term = sat, states = TRUE)$curves,
                   simulate_dosing(cbind(dd, s_term = 1), term = sat)$curves)
})

test_that("a term and a mechanism act together: the term can undo the mechanism", {
  kbs <- susp_nominal[1, "kbsf"]
  gap <- susp_nominal[1, "gapf"]
  bump <- testbed_term("compression", function(d) kbs * pmax(d - gap, 0)^2 / 0.03 / 1000)
  both <- simulate_suspension(data.frame(s_progressive_bumpstop = 1, s_term = -1),
                              mechanism = "progressive_bumpstop", term = bump)
  plain <- simulate_suspension(data.frame(u1 = 0.5))
  mech <- simulate_suspension(data.frame(s_progressive_bumpstop = 1), mechanism = "progressive_bumpstop")
  expect_lt(max_gap(both, plain), 1e-3 * max_gap(mech, plain))
})

test_that("the dosing states are the model's amounts and the concentration is the output", {
  d <- data.frame(u1 = c(0.2, 0.5, 0.8), x1 = c(0.3, 0.5, 0.7), s_enterohepatic_recycling = 1, s_induction = 1)
  runs <- simulate_dosing(d, mechanism = c("enterohepatic_recycling", "induction"), states = TRUE)
  st <- attr(runs, "states")
  expect_named(st, c("gut", "central", "peripheral", "bile", "induction", "concentration"))
  for (m in st) expect_identical(dim(m), c(3L, 2048L))
  expect_identical(st$concentration, runs$curves$plasma)
  v <- dosing_physical(cbind(as.matrix(d[c("u1", "x1")]), u2 = 0.5, x2 = 0.5, x3 = 0.5, x4 = 0.5))[, "v"]
  expect_identical(st$central / v, st$concentration)
  expect_true(all(st$bile >= 0) && max(st$bile) > 1)
  expect_true(all(st$induction >= 0 & st$induction < 1))
  # the gut starts empty and fills at the doses
  expect_true(all(st$gut[, 1] == 0) && max(st$gut) > 100)
})

test_that("the suspension's velocities are the rates of its compressions", {
  runs <- simulate_suspension(data.frame(u1 = c(0.3, 0.7), x7 = c(0.6, 0.4)), states = TRUE)
  st <- attr(runs, "states")
  expect_named(st, c("compression_front", "compression_rear", "velocity_front", "velocity_rear",
                     "damper_front", "damper_rear", "tire_front", "tire_rear"))
  for (m in st) expect_identical(dim(m), c(2L, 4096L))
  # physical time is a quarter of course time (TIME_SCALE in suspension.h)
  h <- 0.25 * diff(runs$t[1:2])
  for (ax in c("front", "rear")) for (r in 1:2) {
    d <- st[[paste0("compression_", ax)]][r, ]
    v <- st[[paste0("velocity_", ax)]][r, ]
    k <- 3:(length(d) - 2)
    # Simpson's rule over two grid steps; its error h^5 / 90 |d^(5)|,
    # estimated from the fourth differences of v; measured: 1.4 times the
    # estimate, allowed 3 times
    simpson <- (d[k + 1] - d[k - 1]) - h / 3 * (v[k - 1] + 4 * v[k] + v[k + 1])
    d4 <- v[k - 2] - 4 * v[k - 1] + 6 * v[k] - 4 * v[k + 1] + v[k + 2]
    expect_lt(max(abs(simpson)), 3 * h * max(abs(d4)) / 90)
    expect_gt(max(abs(v)), 1)
  }
  # at the start the car is at rest: the tires carry the car and the wheels
  # on the road's first height, the dampers nothing
  p <- testbed_physical(cbind(u1 = c(0.3, 0.7), u2 = 0.5, x1 = 0.5, x2 = 0.5, x3 = 0.5, x4 = 0.5, x5 = 0.5,
                              x6 = 0.5, x7 = c(0.6, 0.4)))
  expect_equal(st$tire_front[, 1],
               (p[, "ms"] * 9.81 * 1.5 / 2.7 + p[, "muf"] * 9.81 + p[, "ktf"] * suspension_road_cpp(0)) / 1000)
  expect_equal(st$tire_rear[, 1],
               (p[, "ms"] * 9.81 * 1.2 / 2.7 + p[, "mur"] * 9.81 + p[, "ktr"] * suspension_road_cpp(-2.7)) / 1000)
  expect_identical(st$damper_front[, 1], c(0, 0))
})

test_that("a run that blows up loses its states with its curves", {
  # strong negative damping in the struts blows the second run up
  term <- testbed_term("velocity", function(v) v)
  d <- data.frame(u1 = c(0.3, 0.5, 0.7), s_term = c(0, -200, 1))
  expect_warning(runs <- simulate_suspension(d, term = term, states = TRUE), class = "wavevalid_warning_failed_runs")
  st <- attr(runs, "states")
  expect_identical(runs$design, data.frame(u1 = c(0.3, 0.7), s_term = c(0, 1)))
  kept <- attr(simulate_suspension(d[c(1, 3), ], term = term, states = TRUE), "states")
  expect_identical(st, kept)
  expect_true(all(vapply(st, function(m) nrow(m) == 2L && all(is.finite(m)), logical(1))))
})

test_that("the strength scales the tabulated term exactly", {
  f <- function(d) 30 * pmax(d - 0.03, 0) + 5 * d^2
  one <- testbed_term("compression", f)
  two <- testbed_term("compression", function(d) 2 * f(d))
  expect_identical(simulate_suspension(data.frame(s_term = c(2, -1)), term = one)$curves,
                   simulate_suspension(data.frame(s_term = c(1, -0.5)), term = two)$curves)
  g <- function(C) 0.5 * C + C^2 / 20
  expect_identical(simulate_dosing(data.frame(s_term = 2), term = testbed_term("concentration", g))$curves,
                   simulate_dosing(data.frame(s_term = 1), term = testbed_term("concentration", function(C) 2 * g(C)))$curves)
  # the damper term enters too, and changes the damper's force
  damper <- testbed_term("damper", function(f) 0.05 * f)
  runs <- simulate_suspension(data.frame(s_term = c(0, 1)), term = damper, states = TRUE)
  expect_gt(max(abs(diff(attr(runs, "states")$damper_front))), 0.1)
})

test_that("testbed_term() checks its arguments and prints", {
  cls <- "wavevalid_error_term"
  expect_error(testbed_term("wheel", identity), class = cls)
  expect_error(testbed_term(c("gut", "bile"), identity), class = cls)
  expect_error(testbed_term("gut", "identity"), class = cls)
  expect_error(testbed_term("gut", function(x) 1), class = cls)
  expect_error(testbed_term("gut", function(x) ifelse(x > 1000, NA_real_, x)), class = cls)
  expect_error(testbed_term("gut", function(x) stop("no")), class = cls)
  expect_error(testbed_term("gut", function(x) as.character(x)), class = cls)
  expect_error(testbed_term("gut", identity, range = c(1, 0)), class = cls)
  expect_error(testbed_term("gut", identity, range = c(0, Inf)), class = cls)
  expect_error(testbed_term("gut", identity, range = 1), class = cls)
  expect_error(testbed_term("gut", identity, n_table = 2), class = cls)
  expect_error(testbed_term("gut", identity, n_table = 10.5), class = cls)
  term <- testbed_term("compression", function(d) d^2, range = c(-0.1, 0.2), n_table = 3)
  expect_s3_class(term, "wv_testbed_term")
  expect_equal(term$x, c(-0.1, 0.05, 0.2))
  expect_identical(term$y, term$x^2)
  expect_output(print(term), "compression.*strut force")
  expect_output(print(term), "3 points over \\[-0.1, 0.2\\]")
  expect_identical(testbed_term("bile", identity)$range, c(-200, 2900))
})

test_that("the simulators check the term against their states and the strength column", {
  cls <- "wavevalid_error_term"
  gut <- testbed_term("gut", identity)
  comp <- testbed_term("compression", identity)
  expect_error(simulate_suspension(data.frame(s_term = 1), term = gut), "compression", class = cls)
  expect_error(simulate_dosing(data.frame(s_term = 1), term = comp), "concentration", class = cls)
  expect_error(simulate_dosing(data.frame(u1 = 0.5), term = gut), "s_term", class = cls)
  expect_error(simulate_dosing(data.frame(s_term = 1)), "s_term", class = cls)
  expect_error(simulate_dosing(data.frame(s_term = NA_real_), term = gut), class = cls)
  expect_error(simulate_dosing(data.frame(s_term = 1), term = identity), class = cls)
  expect_error(simulate_dosing(data.frame(u1 = 0.5), states = NA), class = "wavevalid_error_input")
})
