# Pieces shared by the bench scripts of the second-registration protocol
# (check_reregistration.R, check_reregistration_refits.R, check_offsets.R,
# check_reregistration_loop.R):
# condition A of a test-bed case as the tests run it (66 runs, 150 x 20 draws,
# one chain), emulators rescaled on held-out runs, levels 0-3 pooled. Source
# after library(wavevalid), from the package's root.
clock <- function() as.numeric(proc.time()[["elapsed"]])

# 30 held-out runs of the model (with `mechanism`) at a maximin design over
# the ranges of the I/U map `iu`, for rescale_emulators().
held_out_runs <- function(iu, mechanism = NULL) asNamespace("wavevalid")$testbed_check_runs(iu, mechanism)

# The tests' calibration (testbed_calibrate(): one chain, 150 x 20 draws), levels 0-3 pooled unless told.
calibrate_short <- function(em, field, iu, pool_levels = 0:3) {
  asNamespace("wavevalid")$testbed_calibrate(em, field, iu, pool_levels)
}

# Condition A's field data of test bed `tb` registered to `reference` (model
# runs, or curves by site), as testbed_register() does it.
register_case <- function(tb, reference) asNamespace("wavevalid")$testbed_register(tb, reference)

# The first pass of testbed_two_pass() on the model without mechanism: the
# field registered to the runs' mean, the basis, the emulators (rescaled on
# `check` unless it is NULL) and the calibration.
first_pass <- function(tb, check, pool_levels = 0:3) {
  asNamespace("wavevalid")$testbed_first_pass(tb, tb$A$runs, tb$iu, check, pool_levels)
}

# Longest flagged interval of a fit, in grid steps.
longest_flag <- function(fit) asNamespace("wavevalid")$testbed_where_verdict(where_fails(fit), "none")$longest
