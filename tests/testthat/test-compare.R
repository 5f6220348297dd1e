# A before/after pair on example_problem()'s grid and basis: emulators of a
# model g(u1, x1, t) fitted to 30 runs, field data of a reality r(x1, t) at
# x1 = 0.5 (fitted) and at x1 = 0.9 (held out: the change c(x1 = 0.4)).
bump <- function(t, at, w = 0.08) exp(-((t - at) / w)^2)

loop_emulators <- function(model) {
  ex <- example_problem()
  t <- ex$field$t
  withr::with_seed(11, {
    design <- cbind(u1 = (sample(30) - stats::runif(30)) / 30, x1 = (sample(30) - stats::runif(30)) / 30)
  })
  Y <- t(apply(design, 1, function(z) model(z[1], z[2], t))) %*% ex$emulators$basis$Psi
  bank <- bank_fixed_hyper(design, Y, beta = c(2, 2), alpha = c(0, 0))
  params <- data.frame(site = "site1", index = ex$emulators$basis$index, level = ex$emulators$basis$level,
                       mu = bank$mu, lambda = bank$lambda, nugget = bank$nugget, loglik = NA_real_,
                       beta_u1 = bank$beta[, 1], alpha_u1 = bank$alpha[, 1],
                       beta_x1 = bank$beta[, 2], alpha_x1 = bank$alpha[, 2])
  validate_wv_emulators(new_wv_emulators(params, c("u1", "x1"), design, list(site1 = bank), ex$emulators$basis,
                                         "gasp", t))
}

loop_field <- function(reality, x, n_rep, seed, sd = 0.03) {
  t <- example_problem()$field$t
  withr::with_seed(seed, {
    reps <- t(replicate(n_rep, reality(x, t) + stats::rnorm(length(t), sd = sd)))
  })
  field_runs(matrix(reps, n_rep), t, x_nom = c(x1 = 0.5), site = "site1")
}

loop_fit <- function(model, field, seed = 1) {
  suppressWarnings(calibrate(loop_emulators(model), field, example_problem()$iu, chains = 2, seed = seed,
                             sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE)),
                   classes = c("wavevalid_warning_mixing", "wavevalid_warning_boundary"))
}

base_model <- function(u, x, t) (1 + 0.5 * x) * sin(2 * pi * t) + u * bump(t, 0.6)

ratios <- function(cmp) {
  hr <- attr(cmp, "holdout_ratio")
  stats::setNames(split(hr[c("ratio", "lower", "upper")], hr$prediction), hr$prediction)
}

test_that("a fix that helps at a new condition: 'helped', its intervals below 1", {
  # reality's bump grows with x1; the model without it lets u1 take its height at x1 = 0.5
  reality <- function(x, t) (1 + 0.5 * x) * sin(2 * pi * t) + 1.2 * x * bump(t, 0.6)
  fixed <- function(u, x, t) (1 + 0.5 * x) * sin(2 * pi * t) + 2 * u * x * bump(t, 0.6)
  field <- loop_field(reality, 0.5, 4, seed = 1)
  before <- loop_fit(base_model, field)
  after <- loop_fit(fixed, field)
  held <- experiment(loop_field(reality, 0.9, 4, seed = 2), change = c(x1 = 0.4))
  cmp <- compare_validations(before, after, holdout = held, seed = 1)
  r <- ratios(cmp)
  expect_identical(attr(cmp, "verdict"), "helped")
  expect_lt(r$model$upper, 1)
  expect_lt(r$model$ratio, 0.6)
  expect_lte(r$corrected$lower, 1.05)
  expect_true(r$model$lower <= r$model$ratio && r$model$ratio <= r$model$upper)
  hr <- attr(cmp, "holdout_ratio")
  expect_identical(attr(hr, "resampling"), "replicates")
  expect_identical(attr(hr, "n_draws"), 300L)
  # the prediction is the model at the inputs plus the change, plus the bias
  m <- stats::setNames(cmp$before, cmp$metric)
  p <- as.data.frame(stats::predict(before, type = "added_load", delta = c(x1 = 0.4), seed = 1))
  expect_equal(m[["holdout_rmse_model"]], sqrt(mean(sweep(held$field$curves$site1, 2, p$model)^2)))
  expect_equal(m[["holdout_rmse"]], sqrt(mean(sweep(held$field$curves$site1, 2, p$mean)^2)))
  out <- capture.output(print(cmp))
  expect_true(any(grepl("the change helped", out, fixed = TRUE)))
  expect_true(any(startsWith(out, "Rule: helped when")))
  expect_true(any(startsWith(capture.output(print(summary(cmp))), "Rule: helped when")))
  # the held-out figure: the field mean less each prediction, whose mean square is the RMSE's with one
  # replicate's noise averaged out, and the verdict in its subtitle
  g <- autoplot(cmp, type = "holdout")
  d <- g$data
  y_bar <- colMeans(held$field$curves$site1)
  expect_equal(d$error[d$model == "before" & d$prediction == "model alone"], y_bar - p$model)
  expect_equal(d$error[d$model == "before" & d$prediction == "bias-corrected"], y_bar - p$mean)
  rms <- function(m) sqrt(mean(d$error[d$model == m & d$prediction == "model alone"]^2))
  expect_lt(rms("after"), 0.6 * rms("before"))
  expect_match(g$labels$subtitle, "^helped: held-out RMSE after / before, model alone 0\\.")
  expect_error(autoplot(compare_validations(before, after), type = "holdout"), class = "wavevalid_error_input")
  # the same with a list of two experiments, one for each model
  cmp2 <- compare_validations(before, after, holdout = list(before = held, after = held), seed = 1)
  expect_identical(attr(cmp2, "holdout_ratio"), attr(cmp, "holdout_ratio"))
  # or each model's own emulators at that condition (its runs at x1 + 0.4), through which it predicts
  own <- function(model) experiment(held$field, emulators = loop_emulators(function(u, x, t) model(u, x + 0.4, t)))
  cmp3 <- compare_validations(before, after, holdout = list(before = own(base_model), after = own(fixed)), seed = 1)
  expect_identical(attr(cmp3, "verdict"), "helped")
  m3 <- stats::setNames(cmp3$after, cmp3$metric)
  expect_equal(m3[["holdout_rmse_model"]], stats::setNames(cmp$after, cmp$metric)[["holdout_rmse_model"]],
               tolerance = 0.1)
})

test_that("a change tuned to the fitted condition looks good there but is not 'helped' at a new condition", {
  # reality's small bump at 0.25 fades as x1 grows; the changed model adds it at its height at x1 = 0.5
  reality <- function(x, t) (1 + 0.5 * x) * sin(2 * pi * t) + 0.6 * bump(t, 0.6) + 0.2 * (1 - x) * bump(t, 0.25)
  tuned <- function(u, x, t) base_model(u, x, t) + 0.1 * bump(t, 0.25)
  field <- loop_field(reality, 0.5, 4, seed = 1)
  before <- loop_fit(base_model, field)
  after <- loop_fit(tuned, field)
  held <- experiment(loop_field(reality, 0.9, 4, seed = 2), change = c(x1 = 0.4))
  cmp <- compare_validations(before, after, holdout = held, seed = 1)
  v <- stats::setNames(cmp$change, cmp$metric)
  # at the fitted condition the change looks good
  expect_lt(v[["bias_rms_local"]], -0.3)
  expect_lt(v[["model_rmse"]], -0.1)
  # at the new condition it is not
  expect_false(identical(attr(cmp, "verdict"), "helped"))
  expect_gt(ratios(cmp)$model$upper, 1)
  # judged on new replicates at the fitted condition, it would pass for a fix, margin and all
  at_fitted <- compare_validations(before, after, holdout = loop_field(reality, 0.5, 4, seed = 2), seed = 1)
  expect_identical(attr(at_fitted, "verdict"), "helped")
})

test_that("a change within the held-out data's noise is 'no clear change', however its point ratio falls", {
  reality <- function(x, t) (1 + 0.5 * x) * sin(2 * pi * t) + 0.6 * bump(t, 0.6) + 0.02 * bump(t, 0.25)
  slight <- function(u, x, t) base_model(u, x, t) + 0.01 * bump(t, 0.25)
  field <- loop_field(reality, 0.5, 4, seed = 1)
  before <- loop_fit(base_model, field)
  after <- loop_fit(slight, field)
  # one held-out curve: the moving-block bootstrap of its residuals
  held <- experiment(loop_field(reality, 0.9, 1, seed = 3), change = c(x1 = 0.4))
  cmp <- compare_validations(before, after, holdout = held, seed = 1)
  r <- ratios(cmp)
  expect_lt(r$model$ratio, 1)
  expect_identical(attr(cmp, "verdict"), "no clear change")
  expect_true(r$model$lower < 1 && r$model$upper > 1)
  hr <- attr(cmp, "holdout_ratio")
  expect_identical(attr(hr, "resampling"), "moving_block")
  expect_identical(attr(hr, "block"), 6)
  expect_true(any(grepl("blocks of 6 time points", capture.output(print(cmp)), fixed = TRUE)))
})

test_that("the verdict's rule, branch by branch", {
  hr <- function(m, c) data.frame(prediction = c("model", "corrected"), ratio = c(mean(m), mean(c)),
                                  lower = c(m[1], c[1]), upper = c(m[2], c[2]))
  expect_identical(holdout_verdict(hr(c(0.5, 0.9), c(0.8, 1.1))), "helped")
  expect_identical(holdout_verdict(hr(c(0.5, 0.9), c(1.06, 1.2))), "no clear change")
  expect_identical(holdout_verdict(hr(c(0.9, 1.02), c(0.8, 0.9))), "no clear change")
  expect_identical(holdout_verdict(hr(c(1.06, 1.3), c(0.8, 0.9))), "worse")
  # the margin of 5%: a credible fall or rise smaller than it is no clear change
  expect_identical(holdout_verdict(hr(c(0.8, 0.95), c(0.8, 1.03))), "helped")
  expect_identical(holdout_verdict(hr(c(0.9, 0.96), c(0.8, 1.03))), "no clear change")
  expect_identical(holdout_verdict(hr(c(0.8, 0.95), c(1.051, 1.2))), "no clear change")
  expect_identical(holdout_verdict(hr(c(1.01, 1.3), c(0.8, 0.9))), "no clear change")
  expect_identical(holdout_verdict(NULL), NA_character_)
})

test_that("a held-out experiment is checked against each model", {
  fit <- example_fit()
  held <- experiment(example_problem()$field, change = c(nope = 0.1))
  expect_error(compare_validations(fit, fit, holdout = held), class = "wavevalid_error_experiment")
  expect_error(compare_validations(fit, fit, holdout = list(before = 1)), class = "wavevalid_error_input")
})

test_that("the resampled errors of the draws equal those of the curves built in full", {
  withr::local_seed(5)
  basis <- example_problem()$emulators$basis
  n_t <- nrow(basis$Psi)
  k <- ncol(basis$Psi)
  y <- matrix(stats::rnorm(3 * n_t), 3)
  center <- stats::rnorm(n_t)
  corrected <- center + 0.1
  d <- list(Psi = basis$Psi, model = matrix(stats::rnorm(20 * k, sd = 0.1), 20))
  h <- sample.int(20, 50, replace = TRUE)
  rows <- matrix(sample.int(3, 150, replace = TRUE), 50)
  time <- lapply(1:3, function(j) t(replicate(50, moving_blocks(n_t, 6))))
  # each resampled curve: the bias-corrected mean plus a replicate's residuals at block-resampled times
  brute <- vapply(1:50, function(b) {
    sum(vapply(1:3, function(j) {
      e <- y[rows[b, j], ] - corrected
      sum((corrected + e[time[[j]][b, ]] - center - drop(basis$Psi %*% d$model[h[b], ]))^2)
    }, numeric(1)))
  }, numeric(1))
  expect_equal(resampled_sse(y, center, corrected, rows, time, d, "model", h), brute)
  # identity resamples give the plain error of the data
  ident <- list(matrix(seq_len(n_t), 50, n_t, byrow = TRUE))
  plain <- sum((y[1, ] - center - drop(basis$Psi %*% d$model[h[1], ]))^2)
  expect_equal(resampled_sse(y[1, , drop = FALSE], center, corrected, matrix(1L, 50, 1), ident, d, "model", h)[1],
               plain)
  # curve draws without a basis
  dc <- list(Psi = NULL, corrected = matrix(stats::rnorm(20 * n_t, sd = 0.1), 20))
  brute2 <- vapply(1:50, function(b) {
    sum(vapply(1:3, function(j) sum((y[rows[b, j], time[[j]][b, ]] - corrected[time[[j]][b, ]] - dc$corrected[h[b], ])^2),
               numeric(1)))
  }, numeric(1))
  expect_equal(resampled_sse(y, corrected, corrected, rows, time, dc, "corrected", h), brute2)
  expect_length(moving_blocks(n_t, 6), n_t)
  # wavelet_basis()'s columns are orthonormal: its Gram matrix is taken as the identity
  runs <- model_runs(as.data.frame(example_problem()$emulators$design),
                     example_problem()$emulators$banks$site1$y %*% t(basis$Psi), example_problem()$field$t)
  wb <- wavelet_basis(runs)
  expect_false(is.null(wb$settings))
  expect_equal(crossprod(wb$Psi), diag(ncol(wb$Psi)), ignore_attr = TRUE)
})

test_that("no verdict from chains that did not mix: 'not judged', and the print names the inputs", {
  reality <- function(x, t) (1 + 0.5 * x) * sin(2 * pi * t) + 1.2 * x * bump(t, 0.6)
  fixed <- function(u, x, t) (1 + 0.5 * x) * sin(2 * pi * t) + 2 * u * x * bump(t, 0.6)
  field <- loop_field(reality, 0.5, 4, seed = 1)
  before <- loop_fit(base_model, field)
  after <- loop_fit(fixed, field)
  held <- experiment(loop_field(reality, 0.9, 4, seed = 2), change = c(x1 = 0.4))
  mixed <- compare_validations(before, after, holdout = held, seed = 1)
  expect_identical(attr(mixed, "verdict"), "helped")
  expect_length(attr(mixed, "unmixed"), 0L)
  stuck <- after
  stuck$rhat[["u1"]] <- 1.24
  cmp <- compare_validations(before, stuck, holdout = held, seed = 1)
  expect_identical(attr(cmp, "verdict"), "not judged")
  expect_equal(attr(cmp, "unmixed"), list(after = c(u1 = 1.24)))
  # the numbers are those of the same comparison; only the verdict is withheld
  expect_equal(attr(cmp, "holdout_ratio"), attr(mixed, "holdout_ratio"))
  out <- capture.output(print(cmp))
  expect_true(any(grepl("Chains that did not mix (R-hat above 1.1): after: u1 1.24.", out, fixed = TRUE)))
  expect_true(any(grepl("not judged: the chains of a fit did not mix", out, fixed = TRUE)))
  expect_match(comparison_sentence(cmp), "is **not judged**", fixed = TRUE)
})
