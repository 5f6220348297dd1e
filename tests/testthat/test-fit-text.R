test_that("fit_assumptions() gives the lines print() gives for each part of a fit", {
  fit <- example_fit()
  # the example's I/U map: u1 uniform on [0, 1], x1 normal about its nominal 0.5 with sd 1/6
  expect_identical(fit_assumptions(fit), c("Priors:", "  u1  uniform on [0, 1]", "  x1  normal(0.5, sd 0.1667) on [0, 1]"))
  # the noise of the example's four replicates, with the median sd of the fit's variance draws
  sd_med <- format(signif(stats::median(sqrt(fit$sigma2$site1)), 3))
  expect_identical(fit_assumptions(fit, "noise"), c(
    "Field noise:",
    paste0("  site1: from 4 replicates, one variance per coefficient (the method's estimate); median sd ", sd_med)
  ))
  # the likelihood's weight and what it came from, as stored in the fit
  lik <- fit_assumptions(fit, "likelihood")
  se <- fit$shared_errors
  expect_length(lik, 1L)
  expect_match(lik, sprintf("raised to %s in the inputs' steps (%d inputs / %s", format(signif(se$weight, 3)), se$p,
                            format(signif(se$trace, 3))), fixed = TRUE)
  expect_match(lik, sprintf("errors across %d coefficients", se$n_coef), fixed = TRUE)
  expect_identical(fit_assumptions(fit, "experiments"), character(0))
  expect_identical(fit_assumptions(fit, "joint_prior"), character(0))
  printed <- utils::capture.output(print(fit))
  for (part in c("priors", "noise", "likelihood")) {
    expect_true(all(fit_assumptions(fit, part) %in% printed), label = part)
  }
  expect_error(fit_assumptions(fit, "bias"), class = "wavevalid_error_input")
  expect_error(fit_assumptions(fit$emulators, "noise"), class = "wavevalid_error_input")
})

test_that("fit_assumptions() gives the joint prior's correlations of a fit under a joint prior", {
  fit <- example_fit()
  fit$prior_iu <- iu_prior_joint(fit$prior_iu, "u1", mean = 0.5, cov = matrix(0.04))
  expect_identical(fit_assumptions(fit, "joint_prior"), joint_prior_text(fit$prior_iu))
  expect_match(fit_assumptions(fit, "joint_prior")[1], "Joint Gaussian 1 on u1")
})

test_that("iu_prior_sample() draws from the I/U map's prior with R's random numbers", {
  tb <- load_testbed()
  nom <- c(x1 = 0.4, x3 = 0.6)
  z <- withr::with_seed(4, iu_prior_sample(tb$iu, 500, nominal = nom))
  expect_identical(z, withr::with_seed(4, iu_prior_draws(tb$iu, 500L, nominal = nom)))
  expect_identical(dim(z), c(500L, nrow(tb$iu)))
  expect_identical(colnames(z), tb$iu$name)
  # the variations drawn about the new nominals, the others about theirs
  expect_lt(abs(mean(z[, "x1"]) - 0.4), 0.02)
  expect_lt(abs(mean(z[, "x2"]) - tb$iu$nominal[tb$iu$name == "x2"]), 0.02)
  expect_identical(nrow(iu_prior_sample(tb$iu, 1)), 1L)
  expect_error(iu_prior_sample(tb$iu, 0), class = "wavevalid_error_input")
  expect_error(iu_prior_sample(tb$iu, 5, nominal = c(u1 = 0.3)), class = "wavevalid_error_input")
  expect_error(iu_prior_sample(tb$iu, 5, nominal = 0.3), class = "wavevalid_error_input")
  expect_error(iu_prior_sample(as.data.frame(tb$iu), 5), class = "wavevalid_error_input")
})

test_that("the report shows the correlations of a joint prior", {
  skip_if_not(rmarkdown::pandoc_available())
  fit <- example_fit()
  fit$prior_iu <- iu_prior_joint(fit$prior_iu, "u1", mean = 0.5, cov = matrix(0.04))
  out <- withr::local_tempfile(fileext = ".html")
  suppressWarnings(validation_report(fit, file = out, quiet = TRUE))
  html <- paste(readLines(out, warn = FALSE), collapse = "\n")
  expect_match(html, "Joint Gaussian 1 on u1, truncated to the ranges", fixed = TRUE)
  expect_match(html, "site1: from 4 replicates", fixed = TRUE)
})
