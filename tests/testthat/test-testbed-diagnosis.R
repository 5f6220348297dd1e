test_that("the test-bed verdicts judge flags and explanations by the criteria", {
  d <- diag_setup()
  fails <- where_fails(d$fit)
  t <- d$t
  bump <- list(site1 = exp(-((t - 0.25) / 0.05)^2))
  v <- testbed_where_verdict(fails, "bump", bump)
  on <- flagged_share(fails, bump, of = "flags")
  expect_equal(v$recall, c(flagged_share(fails, bump)))
  expect_equal(v$base, attr(on, "acting"))
  expect_true(v$where_ok)
  expect_true(v$localised)
  # flags over the whole record cover the bump but do not lie on it
  everything <- fails
  everything$start[] <- min(t)
  everything$end[] <- max(t) + diff(t[1:2])
  v_all <- testbed_where_verdict(everything, "bump", bump)
  expect_true(v_all$where_ok)
  expect_false(v_all$localised)
  expect_equal(v_all$longest, length(t))
  # an effect over most of the grid: localised takes half the room above base
  wide <- list(site1 = as.numeric(t < 0.8))
  v_wide <- testbed_where_verdict(everything, "wide", wide)
  expect_false(v_wide$localised)
  on_wide <- everything
  on_wide$end[] <- 0.8
  expect_true(testbed_where_verdict(on_wide, "wide", wide)$localised)
  expect_false(testbed_where_verdict(everything, "none")$where_ok)
  expect_true(testbed_where_verdict(fails[0, ], "none")$where_ok)
  expect_error(testbed_where_verdict(fails, "bump"), class = "wavevalid_error_input")

  ex <- function(cand, p) structure(data.frame(candidate = cand, inclusion_prob = p), class = c("wv_explain", "data.frame"))
  judge <- testbed_explain_verdict
  expect_true(judge(ex(c("a", "shift:u1", "b"), c(0.95, 0.7, 0.1)), "a")$ok)
  expect_false(judge(ex(c("a", "b"), c(0.85, 0.1)), "a")$ok)
  expect_false(judge(ex(c("a", "b"), c(0.95, 0.6)), "a")$ok)
  expect_false(judge(ex(c("b", "a"), c(0.95, 0.94)), "a")$ok)
  expect_false(judge(ex(c("shift:u1", "a"), c(0.7, 0.1)), "none")$ok)
  expect_true(judge(ex(c("shift:u1", "a"), c(0.4, 0.1)), "none")$ok)
  expect_identical(judge(ex(c("shift:u1", "a", "b"), c(0.7, 0.6, 0.1)), "b")$top, "a")
  expect_error(judge(ex("a", 0.9), "c"), class = "wavevalid_error_input")
  expect_error(judge(data.frame(candidate = "a", inclusion_prob = 1), "a"), class = "wavevalid_error_input")
})
