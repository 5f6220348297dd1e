# where_fails() as one table of findings ranked by size, the sentence that
# leads the prints, and explain_bias() of one finding.

# u1 mimics reality's higher bump at 0.6 and reality has a bump at 0.25 the
# model lacks: covered misfit, record-wide part and intervals in one table
mixed_fit <- function() {
  t <- example_problem()$field$t
  ex <- suppressMessages(conflict_problem(u = 0.9, extra = 0.3 * exp(-((t - 0.25) / 0.05)^2)))
  conflict_fit(ex)
}

test_that("the findings of every kind are ranked by size, largest first", {
  wf <- where_fails(mixed_fit())
  expect_true(all(c("covered", "input", "record-wide", "interval") %in% wf$kind))
  expect_true(all(diff(wf$size) <= 0))
  expect_identical(wf$peak_abs_bias, wf$size)
  expect_identical(unname(wf$scale), unname(c(interval = "local", `record-wide` = "record", covered = "held",
                                              input = "held")[wf$kind]))
  # every kind keeps its own size: the record-wide part's peak, the intervals'
  # and the covered intervals' peaks of the localised bias
  rw <- attr(wf, "record_wide")
  expect_equal(wf$size[wf$kind == "record-wide"], rw$peak_abs_bias[rw$credible])
  expect_equal(wf$credible[wf$kind == "record-wide"], rw$credible_bias[rw$credible])
  held <- attr(wf, "held")$fails
  expect_equal(sort(wf$size[wf$kind == "covered"]), sort(held$size[held$kind == "interval"]))
  expect_true(all(wf$inputs[wf$kind %in% c("covered", "input")] == "u1"))
  expect_true(all(is.na(wf$inputs[!wf$kind %in% c("covered", "input")])))
  # the input itself is a finding beside the misfit it covered: where its pull moves the model most
  pull <- attr(wf, "held")$pull
  k <- which.max(abs(pull$shift))
  expect_equal(wf$size[wf$kind == "input"], abs(pull$shift[k]))
  expect_equal(c(wf$start[wf$kind == "input"], wf$end[wf$kind == "input"]), c(pull$start[k], pull$end[k]))
  # the credible size is the largest distance of the band from zero over the finding
  b <- attr(wf, "bias")
  gap <- pmax(b$lower_curve, -b$upper_curve, 0)
  iv <- wf[wf$kind == "interval", ]
  for (k in seq_len(nrow(iv))) {
    inside <- b$t >= iv$start[k] - 1e-9 & b$t < iv$end[k] - 1e-9
    expect_equal(iv$credible[k], max(gap[inside]))
    expect_equal(iv$size[k], max(abs(b$mean[inside])))
  }
  # the print leads with the first row and ranks the table the same way
  out <- capture.output(print(wf))
  expect_match(out[1], sprintf("^Top finding \\(1 of %d\\), ", nrow(wf)))
  phrase <- c(covered = "a misfit covered by u1", interval = "an interval", `record-wide` = "a record-wide bias",
              input = "an input in conflict with its prior, u1")
  expect_match(out[1], phrase[[wf$kind[1]]], fixed = TRUE)
  expect_match(out[1], sprintf("%s [%s, %s]", wf$site[1], signif(wf$start[1], 4), signif(wf$end[1], 4)), fixed = TRUE)
  expect_identical(top_finding(wf), out[1])
})

test_that("an input in conflict whose held reading flags no interval is a finding at its pull", {
  fit <- conflict_fit(suppressMessages(conflict_problem(u = 0.9)))
  # a tolerance above every credible bias leaves the input alone
  wf <- where_fails(fit, tolerance = 10)
  expect_identical(wf$kind, "input")
  pull <- attr(wf, "held")$pull
  expect_identical(wf$inputs, "u1")
  expect_identical(wf$site, pull$site)
  expect_equal(c(wf$start, wf$end), c(pull$start, pull$end))
  expect_equal(wf$size, abs(pull$shift))
  expect_identical(wf$scale, "held")
  expect_match(top_finding(wf), "an input in conflict with its prior, u1: its pull moves the model most at .*; held to its prior, the bias band still holds zero")
  # not read again: the input is still a finding, without a place
  nh <- finding_rows(where_fails(fit, hold = FALSE), "input")
  expect_identical(nh$kind, "input")
  expect_true(is.na(nh$site))
  expect_match(top_finding(nh), "u1, not read again held to it")
  expect_error(explain_bias(fit, finding = nh), class = "wavevalid_error_input")
})

test_that("the print, summary() of a fit and top_finding() lead with the first row, or say there is none", {
  fit <- example_fit()
  wf <- where_fails(fit)
  first <- top_finding(wf)
  # the example's reality has a bump at t = 0.25 the model lacks; the bias's band, its coarse levels pooled,
  # misses it, the field mean against the calibrated model point by point does not
  expect_identical(wf$kind[1], "misfit")
  expect_true(wf$start[1] <= 0.25 && wf$end[1] >= 0.25)
  expect_match(first, sprintf("^Top finding \\(1 of %d\\), a misfit that the shrinkage of the bias left out, site1 \\[%s, %s\\]: the field mean lies beyond the model at the calibrated inputs by up to %s, credibly at least %s",
                              nrow(wf), format(signif(wf$start[1], 4)), format(signif(wf$end[1], 4)),
                              signif(wf$size[1], 3), signif(wf$credible[1], 3)))
  expect_identical(capture.output(print(wf))[1], first)
  expect_identical(capture.output(print(summary(fit)))[1], first)
  expect_identical(capture.output(print(summary(wf)))[1], first)
  expect_identical(top_finding(fit), first)
  none <- where_fails(fit, tolerance = 1)
  expect_identical(nrow(none), 0L)
  expect_match(capture.output(print(none))[1], "^No finding: the 90% whole-curve band of the bias lies beyond the tolerance nowhere")
  expect_match(top_finding(where_fails(fit, scales = "whole", tolerance = 1)), "^No finding")
  expect_error(top_finding(data.frame()), class = "wavevalid_error_input")
})

test_that("on the example the intervals, their columns and flagged_share() keep their numbers", {
  # the example fit as it was made before the coarse levels were pooled by default
  ex <- example_problem(1)
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 1,
                                    bias = bias_control(pool_levels = NULL),
                                    sampler = sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE)))
  wf <- where_fails(fit)
  iv <- as.data.frame(wf)[wf$kind == "interval", ]
  iv <- iv[order(-iv$integrated_abs_bias), c("site", "start", "end", "peak_abs_bias", "integrated_abs_bias",
                                              "share_of_signal", "sign")]
  rownames(iv) <- NULL
  # the table where_fails() gave before it held findings of every kind
  before <- data.frame(site = c("site1", "site1"), start = c(0.25, 0.125), end = c(0.28125, 0.15625),
                       peak_abs_bias = c(0.0242163492191544, 0.0116439187450755),
                       integrated_abs_bias = c(0.000756760913098577, 0.000363872460783609),
                       share_of_signal = c(0.0179489493097337, 0.0127129591801856),
                       sign = c("reality above model", "reality below model"), stringsAsFactors = FALSE)
  expect_equal(iv, before, tolerance = 1e-10)
  t <- fit$field$t
  bump <- list(site1 = 0.3 * exp(-((t - 0.25) / 0.05)^2))
  expect_equal(c(flagged_share(wf, bump)), c(site1 = 0.2))
  expect_equal(c(flagged_share(wf, bump, of = "flags")), c(site1 = 0.5))
  # a record-wide row does not count as a flag of the intervals
  with_record <- wf
  with_record[nrow(wf) + 1L, ] <- wf[1, ]
  with_record$kind[nrow(with_record)] <- "record-wide"
  with_record$start[nrow(with_record)] <- 0
  with_record$end[nrow(with_record)] <- 1
  expect_equal(c(flagged_share(with_record, bump)), c(site1 = 0.2))
  expect_identical(testbed_where_verdict(with_record, "none")$longest, testbed_where_verdict(wf, "none")$longest)
})

test_that("explain_bias() of an interval regresses only the coefficients of its site that overlap it", {
  fit <- example_fit()
  t <- fit$field$t
  cand <- list(bump_early = exp(-((t - 0.25) / 0.05)^2), bump_late = exp(-((t - 0.75) / 0.05)^2))
  wf <- where_fails(fit)
  one <- explain_bias(fit, cand, seed = 1, finding = wf[1, ])
  expect_identical(unclass(explain_bias(fit, cand, seed = 1, finding = wf)), unclass(one))
  scope <- finding_scope(fit, wf[1, ])
  # the support of each coefficient kept overlaps the interval, of the others not
  inside <- t >= wf$start[1] - 1e-9 & t < wf$end[1] - 1e-9
  wide <- fit$basis$level %in% record_wide_levels(fit$basis)
  touches <- colSums(abs(fit$basis$Psi[inside, , drop = FALSE])) > 0
  kept <- touches & !wide
  expect_identical(scope$use, kept)
  # field data changed outside those coefficients change nothing, inside they do
  out <- fit
  out$wbar$site1[!kept] <- out$wbar$site1[!kept] + 5
  expect_equal(unclass(explain_bias(out, cand, seed = 1, finding = wf[1, ])), unclass(one))
  inn <- fit
  inn$wbar$site1[kept] <- inn$wbar$site1[kept] + 0.05
  expect_false(isTRUE(all.equal(explain_bias(inn, cand, seed = 1, finding = wf[1, ])$amplitude, one$amplitude)))
  # without a finding, the whole bias as before
  whole <- explain_bias(fit, cand, seed = 1)
  expect_null(attr(whole, "finding"))
  expect_false(isTRUE(all.equal(whole$inclusion_prob, one$inclusion_prob)))
  expect_match(capture.output(print(one))[2], sprintf("Explaining one finding of where_fails\\(\\): %s at site1", wf$kind[1]))
  # a record-wide finding regresses the record-wide levels
  rw <- wf[1, ]
  rw$kind <- "record-wide"
  expect_identical(finding_scope(fit, rw)$use, wide)
  expect_error(explain_bias(fit, cand, finding = data.frame(kind = "interval")), class = "wavevalid_error_input")
  expect_error(explain_bias(fit, list(same = fit), finding = wf), class = "wavevalid_error_input")
  elsewhere <- wf[1, ]
  elsewhere$site <- "site9"
  expect_error(explain_bias(fit, cand, finding = elsewhere), class = "wavevalid_error_input")
  expect_error(explain_bias(fit, cand, finding = where_fails(fit, tolerance = 1)), class = "wavevalid_error_input")
})

test_that("explain_bias() of a covered misfit or an input explains the held re-reading", {
  fit <- conflict_fit(suppressMessages(conflict_problem(u = 0.9)))
  t <- fit$basis$t
  cand <- list(bump = exp(-((t - 0.6) / 0.08)^2))
  wf <- where_fails(fit)
  k <- which(wf$kind == "covered")[1]
  expect_false(is.na(k))
  hf <- attr(wf, "held")$fit
  # covered: the held fit, restricted to the interval
  scope <- finding_scope(fit, wf[k, ])
  expect_identical(scope$fit, hf)
  got <- explain_bias(fit, cand, seed = 1, finding = wf[k, ])
  ref <- hf
  ref$wbar$site1[!scope$use] <- ref$wbar$site1[!scope$use] - 3
  expect_equal(unclass(explain_bias(ref, cand, seed = 1, finding = wf[k, ])), unclass(got))
  # input: the whole held fit, as explain_bias(attr(wf, "held")$fit) gives it
  inp <- where_fails(fit, tolerance = 10)
  a <- explain_bias(fit, cand, seed = 1, finding = inp)
  b <- explain_bias(hf, cand, seed = 1)
  attr(a, "finding") <- NULL
  expect_identical(unclass(a), unclass(b))
  # the bump is u1's own signature (the model is linear in u1): skipped, its
  # shift weighed in its place; what u1 covered is there to explain only in
  # the held reading
  expect_message(plain <- explain_bias(fit, cand, seed = 1), class = "wavevalid_message_spanned")
  expect_false("bump" %in% c(a$candidate, got$candidate, plain$candidate))
  u1 <- function(x) x$amplitude[x$candidate == "shift:u1"]
  expect_gt(u1(a), 5 * u1(plain))
  expect_gt(u1(got), 5 * u1(plain))
  expect_gt(a$amplitude_lower[a$candidate == "shift:u1"], 0)
})
