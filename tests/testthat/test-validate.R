# validate()'s arguments: the data, the experiments, four control objects
# and the seed; the controls' arguments also given directly.

# example_problem()'s runs, as validate() takes them, and the bump's window.
validate_problem <- function() {
  ex <- example_problem()
  runs <- model_runs(as.data.frame(ex$emulators$design),
                     ex$emulators$banks$site1$y %*% t(ex$emulators$basis$Psi), ex$field$t, site = "site1")
  list(ex = ex, runs = runs, windows = list(c(0.4, 0.8)))
}

test_that("validate() takes its data, four control objects and the seed: at most 10 arguments", {
  expect_lte(length(formals(validate)), 10L)
  expect_identical(names(formals(validate)),
                   c("runs", "field", "iu", "experiments", "registration", "emulation", "bias", "sampler", "seed",
                     "..."))
  # every control argument names one setting of one control, none an argument of validate() itself
  fields <- unlist(control_fields(), use.names = FALSE)
  expect_false(anyDuplicated(fields) > 0)
  expect_length(intersect(fields, names(formals(validate))), 0L)
  # none is a prefix of an argument of validate(), which R would match partially
  own <- setdiff(names(formals(validate)), "...")
  expect_false(any(vapply(fields, function(f) any(startsWith(own, f)), logical(1))))
})

test_that("a control's argument given directly gives the same fit as given in its control", {
  p <- validate_problem()
  sampler <- sampler_control(n_draws = 20, n_inner = 5, burnin = 100, n_search = 10, quiet = TRUE)
  in_controls <- suppressWarnings(validate(
    p$runs, p$ex$field, p$ex$iu, seed = 1,
    registration = registration_control(windows = p$windows, knots_every = NULL),
    emulation = emulation_control(engine = "gasp"),
    sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 100, n_search = 10, quiet = TRUE, chains = 1)
  ))
  direct <- suppressWarnings(validate(p$runs, p$ex$field, p$ex$iu, windows = p$windows, knots_every = NULL,
                                      engine = "gasp", chains = 1, seed = 1, sampler = sampler))
  expect_identical(as.matrix(direct$draws), as.matrix(in_controls$draws))
  expect_identical(direct$wb, in_controls$wb)
  expect_identical(direct$control, in_controls$control)
})

test_that("a name no control takes is an error that names it", {
  p <- validate_problem()
  expect_error(validate(p$runs, p$ex$field, p$ex$iu, window = p$windows), class = "wavevalid_error_input")
  expect_error(validate(p$runs, p$ex$field, p$ex$iu, window = p$windows), "does not take `window`", fixed = TRUE)
  expect_error(validate(p$runs, p$ex$field, p$ex$iu, registration = sampler_control()),
               class = "wavevalid_error_input")
  expect_error(validate(p$runs, p$ex$field, p$ex$iu, chains = 0), class = "wavevalid_error_input")
})
