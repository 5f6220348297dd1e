# A small, fully specified calibration problem for examples: a wavelet basis
# on 32 points, GASP emulators with given hyperparameters (mu and lambda by
# profile likelihood), a field of four replicates at one site.

# Wavelet basis of the given coefficient positions on a dyadic grid t.
basis_from_index <- function(t, index, filter.number = 2, family = "DaubExPhase") {
  settings <- basis_settings(length(t), filter.number, family, whole_levels = 0:1, fraction = 0)
  index <- as.integer(index)
  new_wv_basis(index, index_level(index), basis_matrix(index, settings), t, sites = NULL,
               settings = settings)
}

#' Example objects
#'
#' A small calibration problem and a fit of it, for examples, tests and
#' trying the functions out: `example_problem()` builds in a moment what
#' [calibrate()] needs, `example_fit()` calibrates it in about a second.
#'
#' The problem has one site and a grid of 32 time points. The model has one
#' calibration input `u1` and one variation input `x1`, both on \[0, 1\]:
#' `(1 + x1 / 2) sin(2 pi t)` plus a bump of height `u1` near `t = 0.6`. Its
#' 12 runs are summarised by 16 wavelet coefficients, each with a GASP
#' emulator of fixed correlation parameters. The field data are four
#' replicates of the model at `u1 = 0.3`, `x1 = 0.55`, with noise of standard
#' deviation 0.03 and a bump of height 0.1 near `t = 0.25` that the model
#' lacks: the bias that [where_fails()] should find and [explain_bias()]
#' explain.
#'
#' `example_fit()` is `calibrate(ex$emulators, ex$field, ex$iu, chains = 2,
#' seed = seed, sampler = sampler_control(n_draws = 200, n_inner = 20, quiet =
#' TRUE))` on `ex <- example_problem(seed)`, muffling the warning that chains
#' this short have not mixed. The fit at `seed = 1` (the default) ships with
#' the package, computed that way, so it comes back at once; other seeds
#' calibrate anew. It is meant to show the functions at work, not to be read
#' as a converged posterior.
#'
#' @param seed A whole number fixing the design of the runs and the field
#'   noise and, for `example_fit()`, the draws of the calibration. The same
#'   seed gives identical objects.
#' @return `example_problem()`: a list with `emulators` (a `wv_emulators`
#'   object), `field` (a `wv_field` object) and `iu` (a `wv_iu` object), the
#'   first three arguments of [calibrate()]. `example_fit()`: a `wv_fit`
#'   object (see [calibrate()]).
#' @export
#' @examples
#' ex <- example_problem()
#' ex$emulators
#' ex$field
#' ex$iu
#'
#' fit <- example_fit()
#' fit
#' head(bias(fit))
example_problem <- function(seed = 1) {
  check_number(seed, integer = TRUE)
  with_rng_seed(seed, {
    t <- seq(0, 1, length.out = 33)[-33]
    iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), lower = c(0, 0), upper = c(1, 1),
                 nominal = c(0.5, 0.5))
    model <- function(u, x) (1 + 0.5 * x) * sin(2 * pi * t) + u * exp(-((t - 0.6) / 0.08)^2)
    design <- cbind(u1 = (0:11 + stats::runif(12)) / 12, x1 = (sample(12) - stats::runif(12)) / 12)
    curves <- t(apply(design, 1, function(z) model(z[1], z[2])))
    basis <- basis_from_index(t, 1:16)
    Y <- curves %*% basis$Psi
    emulators <- fixed_hyper_emulators(design, Y, basis, t, beta = c(2, 2), alpha = c(0, 0))
    truth <- model(0.3, 0.55) + 0.1 * exp(-((t - 0.25) / 0.05)^2)
    reps <- t(replicate(4, truth + stats::rnorm(length(t), sd = 0.03)))
    field <- new_wv_field(t, list(site1 = reps), x_nom = c(x1 = 0.5))
    list(emulators = emulators, field = field, iu = iu)
  })
}

#' @rdname example_problem
#' @export
example_fit <- function(seed = 1) {
  check_number(seed, integer = TRUE)
  if (seed == 1) return(validate_wv_fit(new_wv_fit(unclass(example_fit_1))))
  compute_example_fit(seed)
}

# The calibration behind example_fit(); its result at seed 1 ships with the
# package (R/sysdata.rda, made by data-raw/make-example.R) and a test checks
# it against this.
compute_example_fit <- function(seed) {
  ex <- example_problem(seed)
  withCallingHandlers(
    calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = seed,
              sampler = sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE)),
    wavevalid_warning_mixing = function(w) invokeRestart("muffleWarning")
  )
}

# The former name of example_problem(), kept for the package's tests.
example_calibration_inputs <- example_problem
