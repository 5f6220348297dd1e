# example_problem()'s runs, as validate() takes them, and a fit of them
# registered on the bump's window.
update_problem <- function() {
  ex <- example_problem()
  runs <- model_runs(as.data.frame(ex$emulators$design),
                     ex$emulators$banks$site1$y %*% t(ex$emulators$basis$Psi), ex$field$t, site = "site1")
  list(ex = ex, runs = runs, windows = list(c(0.4, 0.8)))
}

update_validate <- function(p, ...) {
  suppressWarnings(validate(p$runs, p$ex$field, p$ex$iu, windows = p$windows, knots_every = NULL, chains = 1,
                            sampler = sampler_control(n_draws = 40, n_inner = 5, quiet = TRUE), ...))
}

test_that("update() with the fit's own runs reproduces validate() with the same settings, draw for draw", {
  p <- update_problem()
  fit <- update_validate(p, seed = 3)
  withr::local_seed(99)
  again <- suppressWarnings(update(fit))
  expect_identical(again$seed, 3L)
  expect_identical(as.matrix(again$draws), as.matrix(fit$draws))
  expect_identical(again$wb, fit$wb)
  expect_identical(again$field$curves, fit$field$curves)
  expect_identical(again$control[c("emulation", "bias", "sampler")], fit$control[c("emulation", "bias", "sampler")])
  expect_identical(again$control$registration$windows, p$windows)
  # registered to the reference the former fit registered its field to
  expect_identical(again$control$registration$reference, p$runs)
  # the raw field is kept, registered afresh (not the registered curves registered again)
  expect_identical(fit$pipeline$field, p$ex$field)
  expect_false(identical(fit$field$curves, p$ex$field$curves))
})

test_that("update() registers the raw field to the former fit's reference, and its arguments override the fit's", {
  p <- update_problem()
  fit <- update_validate(p, seed = 3)
  # a model with an added effect: a further input, its strength, moving the bump
  d <- p$runs$design
  withr::local_seed(2)
  d$s <- (sample(nrow(d)) - stats::runif(nrow(d))) / nrow(d)
  t <- p$runs$t
  # a dip that moves the runs' mean minimum in the window by a grid step
  curves <- p$runs$curves$site1 - outer(0.5 * d$s, exp(-((t - 0.7) / 0.06)^2))
  runs2 <- model_runs(d, curves, t, site = "site1")
  iu2 <- iu_add(p$ex$iu, "s", lower = 0, upper = 1, nominal = 0.5)
  # the runs' new input without the I/U map that names it: stopped before any fit
  expect_error(update(fit, runs = runs2), class = "wavevalid_error_update")
  expect_error(update(fit, runs = runs2), "I/U map lacks")
  fit2 <- suppressWarnings(update(fit, runs = runs2, iu = iu2))
  expect_true("s" %in% fit2$inputs)
  # one yardstick: the field registered as the former fit registered it, not to the new runs
  expect_identical(fit2$field$curves, fit$field$curves)
  expect_identical(fit2$field$warps, fit$field$warps)
  expect_identical(fit2$pipeline$registered_to$field, p$runs)
  expect_identical(fit2$pipeline$runs, runs2)
  to_new <- register_curves(p$ex$field, runs2, p$windows, knots_every = NULL)
  expect_false(isTRUE(all.equal(fit2$field$curves, to_new$curves)))
  # registered to the new runs when told so
  fit2n <- suppressWarnings(update(fit, runs = runs2, iu = iu2, reference = runs2))
  expect_identical(fit2n$field$curves, to_new$curves)
  # two fits on differently registered data: the comparison says their fitted errors are not comparable
  expect_true(attr(compare_validations(fit, fit2), "same_field"))
  cmp_n <- compare_validations(fit, fit2n)
  expect_false(attr(cmp_n, "same_field"))
  expect_true(any(grepl("registered differently", capture.output(print(cmp_n)), fixed = TRUE)))
  # overrides: the sampler, the chains and the seed
  fit3 <- suppressWarnings(update(fit, sampler = sampler_control(n_draws = 30, n_inner = 5, quiet = TRUE),
                                  chains = 2, seed = 4))
  expect_identical(coda::nchain(fit3$draws), 2L)
  expect_identical(nrow(fit3$draws[[1]]), 30L)
  expect_identical(fit3$seed, 4L)
  direct <- suppressWarnings(validate(p$runs, p$ex$field, p$ex$iu, windows = p$windows, knots_every = NULL, chains = 2,
                                      seed = 4, sampler = sampler_control(n_draws = 30, n_inner = 5, quiet = TRUE)))
  expect_identical(as.matrix(fit3$draws), as.matrix(direct$draws))
  expect_error(update(fit, n_draw = 10), class = "wavevalid_error_update")
  expect_error(update(fit, n_draw = 10), "does not take `n_draw`", fixed = TRUE)
  expect_error(update(fit, NULL, NULL, 10), class = "wavevalid_error_update")
})

test_that("update() replays the fit's control objects, and overrides a setting as validate() takes it", {
  p <- update_problem()
  sampler <- sampler_control(n_draws = 20, n_inner = 5, burnin = 100, n_search = 10, quiet = TRUE)
  fit <- suppressWarnings(validate(p$runs, p$ex$field, p$ex$iu, seed = 2, sampler = sampler, chains = 1,
                                   registration = registration_control(windows = p$windows, knots_every = NULL)))
  expect_named(fit$control, c("registration", "emulation", "bias", "sampler"))
  expect_identical(fit$control$sampler$chains, 1)
  # the same settings given to validate() again: the same draws
  again <- suppressWarnings(update(fit))
  direct <- suppressWarnings(validate(p$runs, p$ex$field, p$ex$iu, seed = 2, registration = fit$control$registration,
                                      emulation = fit$control$emulation, bias = fit$control$bias,
                                      sampler = fit$control$sampler))
  expect_identical(as.matrix(again$draws), as.matrix(direct$draws))
  expect_identical(as.matrix(again$draws), as.matrix(fit$draws))
  # one setting overridden directly, by the name of its control's argument
  longer <- suppressWarnings(update(fit, n_draws = 30, seed = 5))
  expect_identical(nrow(longer$draws[[1]]), 30L)
  expect_identical(longer$control$sampler, modify_control(fit$control$sampler, list(n_draws = 30)))
  expect_identical(longer$control$registration$windows, p$windows)
  direct30 <- suppressWarnings(validate(p$runs, p$ex$field, p$ex$iu, seed = 5, windows = p$windows,
                                        knots_every = NULL, sampler = sampler, n_draws = 30, chains = 1))
  expect_identical(as.matrix(longer$draws), as.matrix(direct30$draws))
  # a registration control given whole keeps the former fit's reference unless it names one
  reg <- suppressWarnings(update(fit, registration = registration_control(windows = p$windows, knots_every = NULL)))
  expect_identical(reg$control$registration$reference, p$runs)
  expect_identical(as.matrix(reg$draws), as.matrix(fit$draws))
})

test_that("update() of a calibrate() fit says to validate first", {
  expect_error(update(example_fit()), class = "wavevalid_error_update")
  expect_error(update(example_fit()), "made by `calibrate()`", fixed = TRUE)
})

test_that("the loop in three calls: validate(), update(), compare_validations() at a held-out experiment", {
  p <- update_problem()
  fit <- update_validate(p, seed = 3)
  d <- p$runs$design
  withr::local_seed(2)
  d$s <- (sample(nrow(d)) - stats::runif(nrow(d))) / nrow(d)
  t <- p$runs$t
  runs2 <- model_runs(d, p$runs$curves$site1 - outer(0.5 * d$s, exp(-((t - 0.7) / 0.06)^2)), t, site = "site1")
  fit2 <- suppressWarnings(update(fit, runs = runs2, iu = iu_add(p$ex$iu, "s", lower = 0, upper = 1, nominal = 0.5)))
  held <- experiment(p$ex$field, change = c(x1 = 0.2))
  cmp <- compare_validations(fit, fit2, holdout = held, seed = 1)
  expect_true(attr(cmp, "verdict") %in% c("helped", "worse", "no clear change"))
  # one target: the held-out field data registered once, as the first fit registers its own (to its model in
  # the experiment's condition), and both models graded against it
  hf <- attr(cmp, "holdout_field")
  direct <- register_experiments(list(h = held), fit$emulators, fit$pipeline$runs, p$windows, knots_every = NULL,
                                 quiet = TRUE)$h$field
  expect_identical(hf$before$curves, direct$curves)
  expect_identical(hf$after$curves, direct$curves)
  own <- register_experiments(list(h = held), fit2$emulators, fit2$pipeline$runs, p$windows, knots_every = NULL,
                              quiet = TRUE)$h$field
  expect_false(isTRUE(all.equal(own$curves, direct$curves)))
  expect_false(identical(hf$before$curves, held$field$curves))
  # the errors are those of each model against that one field
  pr <- attr(cmp, "holdout_predictions")
  rmse <- function(s) sqrt(mean(sweep(direct$curves$site1, 2, s$model)^2))
  m <- stats::setNames(cmp$after, cmp$metric)
  expect_equal(m[["holdout_rmse_model"]], rmse(pr$after))
  expect_equal(stats::setNames(cmp$before, cmp$metric)[["holdout_rmse_model"]], rmse(pr$before))
})

test_that("model_rmse is taken net of the registration's shifts the sampler drew", {
  fit <- example_fit()
  k <- length(fit$wbar$site1)
  n <- nrow(as.matrix(fit$draws))
  # two landmark shifts with their coefficient directions, drawn away from zero
  withr::local_seed(4)
  U <- matrix(stats::rnorm(2 * k), k)
  fit$registration_shifts <- list(U = list(site1 = U), draws = matrix(stats::rnorm(2 * n, mean = c(0.3, -0.2)), n,
                                                                         byrow = TRUE))
  shifted <- colMeans(fit$field$curves$site1) -
    drop(tcrossprod(colMeans(fit$registration_shifts$draws) %*% t(U), fit$basis$Psi))
  expect_equal(field_mean_curve(fit, "site1"), shifted)
  expect_gt(max(abs(shifted - colMeans(fit$field$curves$site1))), 0.01)
  # the same as the mean over the draws of the field mean the sampler's shifts moved
  expect_equal(drop(colMeans(field_mean_draws(fit, "site1", seq_len(n))) %*% t(fit$basis$Psi)) +
                 colMeans(fit$field$curves$site1) - drop(fit$wbar$site1 %*% t(fit$basis$Psi)), shifted)
  mp <- model_prediction(fit, 0.9)
  cmp <- compare_validations(fit, fit)
  m <- stats::setNames(cmp$before, cmp$metric)
  expect_equal(m[["model_rmse"]], sqrt(mean((mp$mean[mp$site == "site1"] - shifted)^2)))
})
