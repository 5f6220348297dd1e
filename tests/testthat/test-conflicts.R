test_that("an input that absorbs what the model lacks is a conflict, and held to its prior the misfit shows where it is", {
  # reality's bump is 0.9 high, six prior sd of u1 above its prior mean: the model reaches it only there
  ex <- suppressMessages(conflict_problem(u = 0.9))
  fit <- conflict_fit(ex)
  cf <- input_conflicts(fit)
  expect_true(cf$conflict[cf$input == "u1"])
  expect_true(cf$far[cf$input == "u1"])
  expect_identical(cf$side[cf$input == "u1"], "upper")
  expect_gt(cf$prior_sds[cf$input == "u1"], 3)
  expect_false(cf$conflict[cf$input == "x1"])
  expect_true(any(grepl("In conflict with their prior", capture.output(print(fit)), fixed = TRUE)))
  wf <- where_fails(fit)
  hd <- attr(wf, "held")
  expect_identical(hd$inputs, "u1")
  # reality is the fit's, draw for draw; the model's inputs are u1 from its prior, x1 from the posterior
  hf <- hd$fit
  expect_equal(hf$wM$site1 + hf$wb$site1, fit$wM$site1 + fit$wb$site1)
  expect_equal(as.matrix(hf$draws)[, "x1"], as.matrix(fit$draws)[, "x1"])
  expect_lt(abs(mean(as.matrix(hf$draws)[, "u1"]) - 0.3), 0.03)
  # the held bias places the bump u1 covered, and the pull moves the model most there
  hw <- hd$fails[hd$fails$kind == "interval", ]
  expect_gt(nrow(hw), 0)
  # the leading interval (by size) holds the bump
  expect_true(hw$start[1] <= 0.6 && hw$end[1] >= 0.6)
  expect_true(hd$pull$start <= 0.6 && hd$pull$end >= 0.6)
  expect_gt(hd$bias_rms_local[["held"]], 2 * hd$bias_rms_local[["fitted"]])
  df <- as.data.frame(wf)
  expect_true(all(df$covered_by[df$scale == "held"] == "u1"))
  expect_true(all(is.na(df$covered_by[df$scale != "held"])))
  out <- capture.output(print(wf))
  expect_true(any(grepl("u1 in its prior's upper tail", out, fixed = TRUE)))
  expect_true(any(grepl("With u1 held to the prior, the localised bias's band excludes zero", out, fixed = TRUE)))
  # u1 and the misfit it covered are the findings, placed at the bump; the print leads with the largest
  expect_setequal(wf$kind, c("input", "covered"))
  expect_true(all(wf$inputs == "u1"))
  top_two <- wf[c(which(wf$kind == "input"), which(wf$kind == "covered")[1]), ]
  expect_true(all(top_two$start <= 0.6 & top_two$end >= 0.6))
  expect_equal(sort(wf$size[wf$kind == "covered"], decreasing = TRUE), hw$size)
  # (a first line on unmixed chains, when the short chains give an R-hat above 1.1, comes before it)
  out <- out[!startsWith(out, "The chains did not mix")]
  expect_match(out[1], "^Top finding \\(1 of [0-9]+\\), (a misfit covered by|an input in conflict with its prior,) u1, site1 \\[|^Top finding \\(1 of [0-9]+\\), an input in conflict with its prior, u1: its pull moves the model most at site1 \\[")
  expect_s3_class(autoplot(wf), "ggplot")
  # the re-read fit is a fit: its own where_fails() says what it holds, and holds nothing more
  wh <- where_fails(hf)
  expect_false(attr(wh, "conflicts")$conflict[attr(wh, "conflicts")$input == "u1"])
  expect_null(attr(wh, "held"))
  expect_true(any(grepl("This fit holds u1 to its prior", capture.output(print(wh)), fixed = TRUE)))
  expect_true(any(grepl("Held to their prior: u1 (the bias read again", capture.output(print(hf)), fixed = TRUE)))
  # no holding on request
  expect_null(attr(where_fails(fit, hold = FALSE), "held"))
})

test_that("a posterior piled at a bound is a conflict, a partial pile is not", {
  fit <- example_fit()
  X <- as.matrix(fit$draws)
  n <- nrow(X)
  with_draws <- function(u) {
    f <- fit
    X[, "u1"] <- u
    f$draws <- coda::mcmc.list(lapply(unique(f$chain), function(k) coda::mcmc(X[f$chain == k, , drop = FALSE])))
    input_conflicts(f)
  }
  # u1 uniform on [0, 1]: 60% of the draws within 2% of the upper bound
  piled <- with_draws(ifelse(seq_len(n) %% 5 < 3, 0.99, 0.9))
  expect_true(piled$piled[piled$input == "u1"])
  expect_true(piled$conflict[piled$input == "u1"])
  partial <- with_draws(ifelse(seq_len(n) %% 5 < 2, 0.99, 0.9))
  expect_false(partial$conflict[partial$input == "u1"])
  # draws of a normal truncated at the upper bound 1 (evenly spaced in probability, in a shuffled order)
  set.seed(3)
  truncated <- function(centre, sd) {
    p <- stats::pnorm(1, centre, sd) * (seq_len(n) - 0.5) / n
    sample(stats::qnorm(p, centre, sd))
  }
  # pressed on the bound: centred 5 sd beyond it
  pressed <- with_draws(truncated(1.05, 0.01))
  expect_true(pressed$piled[pressed$input == "u1"])
  expect_equal(pressed$beyond_bound_sd[pressed$input == "u1"], 5, tolerance = 0.1)
  expect_match(conflict_text(pressed), "u1 piled at its upper bound", fixed = TRUE)
  # a right model's posterior near the bound: centred 0.01 inside it, sd 0.02; more than half of it
  # within 2% of the range from the bound, but no further beyond than chance
  near <- with_draws(truncated(0.99, 0.02))
  expect_gt(near$share_at_bound[near$input == "u1"], 0.5)
  expect_false(near$piled[near$input == "u1"])
  expect_false(near$conflict[near$input == "u1"])
  expect_equal(near$beyond_bound_sd[near$input == "u1"], -0.5, tolerance = 0.1)
  # on either side of the threshold z = qnorm(1 - 0.05 / (2 * 2)) = 2.24 sd (two inputs): a centre
  # 1.5 sd beyond the bound is within chance, 3 sd beyond is a pile; both hold nearly all their
  # draws within 2% of the range from the bound
  z <- stats::qnorm(1 - 0.05 / 4)
  expect_equal(z, 2.24, tolerance = 0.01)
  chance <- with_draws(truncated(1.015, 0.01))
  expect_gt(chance$share_at_bound[chance$input == "u1"], 0.9)
  expect_equal(chance$beyond_bound_sd[chance$input == "u1"], 1.5, tolerance = 0.1)
  expect_false(chance$piled[chance$input == "u1"])
  beyond <- with_draws(truncated(1.03, 0.01))
  expect_gt(beyond$share_at_bound[beyond$input == "u1"], 0.9)
  expect_equal(beyond$beyond_bound_sd[beyond$input == "u1"], 3, tolerance = 0.1)
  expect_true(beyond$piled[beyond$input == "u1"])
  expect_true(beyond$conflict[beyond$input == "u1"])
})

test_that("bound_overshoot() reads the centre of a truncated normal from its draws", {
  set.seed(4)
  for (a in c(-1, 0, 1, 3)) {
    x <- stats::qnorm(stats::pnorm(a) + (1 - stats::pnorm(a)) * (seq_len(2e4) - 0.5) / 2e4)
    expect_lt(abs(bound_overshoot(x - a) - a), 0.05)
  }
  # draws falling away exponentially: the centre far beyond; all at the bound: beyond the cap
  expect_gt(bound_overshoot(stats::rexp(2e4)), 6)
  expect_identical(bound_overshoot(rep(0, 10)), 10)
})

test_that("hold_inputs() calibrates again with the inputs at strata of their prior", {
  ex <- suppressMessages(conflict_problem(u = 0.9))
  fit <- conflict_fit(ex)
  held <- hold_inputs(fit, strata = 3, quiet = TRUE)
  expect_identical(held$held$inputs, "u1")
  # u1 ~ normal(0.3, 0.1) truncated to [0, 1]: its quantiles 1/6, 1/2, 5/6
  q <- stats::qnorm(c(1, 3, 5) / 6, 0.3, 0.1)
  expect_equal(unname(held$held$values[, "u1"]), q, tolerance = 0.01)
  expect_equal(sort(unique(round(as.matrix(held$draws)[, "u1"], 2))), round(q, 2))
  expect_identical(nrow(as.matrix(held$draws)), 3L * 150L)
  expect_true(any(grepl("This fit holds u1 to its prior", capture.output(print(where_fails(held))), fixed = TRUE)))
})

test_that("with the model right no input is in conflict and nothing is held", {
  ex <- suppressMessages(conflict_problem(u = 0.35))
  fit <- conflict_fit(ex)
  wf <- where_fails(fit)
  expect_false(any(attr(wf, "conflicts")$conflict))
  expect_null(attr(wf, "held"))
  out <- capture.output(print(wf))
  expect_false(any(grepl("Inputs in conflict|an input in conflict", out)))
  expect_false(any(wf$kind %in% c("input", "covered")))
})

test_that("a variation pulled far into its prior's tail is a conflict", {
  # x1 ~ N(0.5, 1/6) on [0, 1]; reality's sine is that of x1 = 0.5 times 1.45, beyond x1's range
  ex <- suppressMessages(conflict_problem(u = 0.3, x = 1.4))
  fit <- conflict_fit(ex)
  cf <- input_conflicts(fit)
  k <- cf$input == "x1"
  expect_true(cf$conflict[k])
  expect_gt(cf$prior_sds[k], 2)
  expect_lt(cf$prior_tail[k], 0.05 / 4)
})

test_that("hold_inputs() refuses what it cannot hold, before any calibration", {
  fit <- example_fit()
  calls <- 0L
  trace("calibrate", function() calls <<- calls + 1L, where = asNamespace("wavevalid"), print = FALSE)
  on.exit(untrace("calibrate", where = asNamespace("wavevalid")), add = TRUE)
  expect_error(hold_inputs(fit, inputs = "nope"), class = "wavevalid_error_input")
  expect_error(hold_inputs(fit, inputs = character()), class = "wavevalid_error_input")
  expect_error(hold_inputs(fit, inputs = "u1", strata = 0), class = "wavevalid_error_input")
  expect_error(hold_inputs(list(), inputs = "u1"), class = "wavevalid_error_input")
  expect_identical(calls, 0L)
})

test_that("compare_validations() reports the conflicts, the model alone at the held-out data and a verdict", {
  ex <- suppressMessages(conflict_problem(u = 0.9))
  before <- conflict_fit(ex)
  # the model with what it lacked: its bump three times as high (its emulators refitted)
  ex2 <- ex
  em <- ex$emulators
  t <- ex$field$t
  model2 <- function(z) (1 + 0.5 * z[2]) * sin(2 * pi * t) + 3 * z[1] * exp(-((t - 0.6) / 0.08)^2)
  Y <- t(apply(em$design, 1, model2)) %*% em$basis$Psi
  bank <- bank_fixed_hyper(em$design, Y, beta = c(2, 2), alpha = c(0, 0))
  ex2$emulators$banks$site1 <- bank
  ex2$emulators$params$mu <- bank$mu
  after <- conflict_fit(ex2)
  holdout <- suppressMessages(conflict_problem(u = 0.9, seed = 5))$field
  cmp <- compare_validations(before, after, holdout = holdout)
  m <- stats::setNames(cmp$after, cmp$metric)
  b <- stats::setNames(cmp$before, cmp$metric)
  expect_identical(b[["inputs_in_conflict"]], 1)
  expect_identical(m[["inputs_in_conflict"]], 0)
  expect_true(all(c("holdout_rmse", "holdout_rmse_model") %in% cmp$metric))
  # the model alone: the pure-model prediction against the held-out replicates
  p <- as.data.frame(stats::predict(after, type = "field_run", seed = 1))
  expect_equal(m[["holdout_rmse_model"]], sqrt(mean(sweep(holdout$curves$site1, 2, p$model)^2)))
  pb <- as.data.frame(stats::predict(before, type = "field_run", seed = 1))
  expect_equal(b[["holdout_rmse_model"]], sqrt(mean(sweep(holdout$curves$site1, 2, pb$model)^2)))
  out <- capture.output(print(cmp))
  expect_true(any(grepl("before u1; after none (resolved)", out, fixed = TRUE)))
  expect_true(any(grepl("the model alone errs", out, fixed = TRUE)))
  expect_true(any(grepl("Without a held-out condition", capture.output(print(compare_validations(before, after))),
                        fixed = TRUE)))
})
