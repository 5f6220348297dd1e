# Pieces shared by the bench scripts of the second-registration protocol
# (check_reregistration.R, check_reregistration_refits.R, check_offsets.R,
# check_reregistration_loop.R):
# condition A of a test-bed case as the tests run it (66 runs, 150 x 20 draws,
# one chain), emulators rescaled on held-out runs, levels 0-3 pooled. Source
# after library(wavevalid), from the package's root.
clock <- function() as.numeric(proc.time()[["elapsed"]])

# 30 held-out runs of the model (with `mechanism`) at a maximin design over
# the ranges of the I/U map `iu`, for rescale_emulators().
held_out_runs <- function(iu, mechanism = NULL) {
  simulate_suspension(design_maximin(iu, 30, nominal = FALSE, seed = 9), mechanism = mechanism)
}

calibrate_short <- function(em, field, iu, pool_levels = 0:3) {
  suppressWarnings(calibrate(em, field, iu, n_draws = 150, n_inner = 20, chains = 1, seed = 1,
                             pool_levels = pool_levels, quiet = TRUE))
}

# Condition A's field data of test bed `tb` (mechanism `hidden`) registered to
# `reference` (model runs, or curves by site): the maximum alone for a hidden
# tire lift-off, whose minimum is flat.
register_case <- function(tb, hidden, reference) {
  features <- if (hidden == "tire_liftoff") "max" else c("min", "max")
  register_curves(tb$A$field, reference, tb$windows, features = features, knots_every = 2)
}

# The first pass: the field registered to the runs' mean, the basis, the
# emulators (rescaled on `check` unless it is NULL) and the calibration.
first_pass <- function(tb, hidden, check, pool_levels = 0:3) {
  field <- register_case(tb, hidden, tb$A$runs)
  basis <- wavelet_basis(tb$A$runs, field)
  em <- suppressWarnings(fit_emulators(tb$A$runs, basis))
  if (!is.null(check)) em <- rescale_emulators(em, check)
  list(field = field, basis = basis, emulators = em, fit = calibrate_short(em, field, tb$iu, pool_levels))
}

# Longest flagged interval of a fit, in grid steps.
longest_flag <- function(fit) asNamespace("wavevalid")$testbed_where_verdict(where_fails(fit), "none")$longest
