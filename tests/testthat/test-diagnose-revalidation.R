# Each mechanism re-validated: the model with it (its strength a calibration
# input on [0, 1]) simulated at a 66-point maximin design, its emulators fitted
# on the basis of the model without it and calibrated on the same field data;
# explain_bias() weighs the four by their Bayes factors against themselves
# with the strength at 0.
testbed_revalidated <- function(hidden, seed) {
  d <- testbed_diagnosis(hidden, seed)
  withr::local_options(list(wavevalid.quiet = TRUE))
  fits <- testbed_revalidation(d$tb, d$fit)
  as.data.frame(unclass(explain_bias(d$fit, fits, n_draws = 50)))
}

# At seed 3 the progressive bump stop is not found: its model puts the
# strength near zero and "(none)" takes 0.69.
test_that("on three test beds, re-validating each mechanism finds the hidden one and claims none with nothing hidden", {
  skip_unless_slow()
  res <- NULL
  for (h in c("none", testbed_mechanisms())) {
    for (seed in 1:3) {
      ex <- testbed_revalidated(h, seed)
      res <- rbind(res, data.frame(hidden = h, seed = seed, first = ex$candidate[1],
                                   prob = if (h == "none") NA else ex$inclusion_prob[ex$candidate == h],
                                   decoy = max(ex$inclusion_prob[ex$candidate != h])))
    }
  }
  lab <- paste(utils::capture.output(print(res)), collapse = "\n")
  none <- res$hidden == "none"
  expect_true(all(res$decoy < 0.5), label = lab)
  found <- res$first[!none] == res$hidden[!none] & res$prob[!none] >= 0.9
  expect_gte(sum(found), 10L, label = lab)
})
