# Criterion 3 of the diagnosis: add the hidden mechanism to the model and
# watch the error fall. On test bed `seed`, the model without the hidden
# mechanism ("before") and the model with it, its strength a calibration
# input on [0, 1] ("after", its 66 runs the test bed's condition A design with
# the strength spread over [0, 1]), are each validated and compared by
# compare_validations() with condition B held out (testbed_loop(), see
# tests/testthat/helper-protocol.R: each model's runs at B registered to their
# mean, the after-model's strength spread over its 99% posterior interval).
# The package's test (test-diagnose-loop.R) asks bias_rms to fall by more than
# 70% and holdout_rmse to fall.
# protocol = reregister (the test's): levels 0-3 pooled, the field registered
# to the runs' mean, calibrated, registered again to a run at the posterior
# mean inputs and calibrated again (testbed_two_pass()); the emulators
# rescaled on 30 held-out runs of each model unless rescale = FALSE (the test
# uses them as fitted); each chain's start the best of n_search prior draws;
# start = replicates registers the first pass to the replicates' own
# pointwise mean; passes = 3 or more registers again as many times;
# holdout_again = TRUE registers B's replicates to one run of each model at
# its posterior mean calibration inputs and B's nominal variation inputs.
# protocol = default: the missing-effect vignette's loop (landmarks between
# grid points, the emulators as fitted, the method's prior, one registration
# to each model's own runs); protocol = pooled: the same with levels 0-3
# pooled.
# Printed by mechanism: the strength's posterior mean, compare_validations(),
# and the share of each fit's bias energy at wavelet level 0 by site.
#   Rscript studies/loop.R [hidden=tire_liftoff] [seed=1] [protocol=reregister] [rescale=FALSE]
#                          [n_search=2000] [start=runs] [passes=2] [holdout_again=FALSE]
# hidden: mechanisms, comma-separated (all: hidden=all).
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(hidden = "tire_liftoff", seed = "1", protocol = "reregister", rescale = "FALSE",
                       n_search = "2000", start = "runs", passes = "2", holdout_again = "FALSE"))
if (opt$hidden == "all") opt$hidden <- paste(testbed_mechanisms(), collapse = ",")
hidden <- arg_names(opt$hidden)
seed <- as.integer(opt$seed)
stopifnot(opt$protocol %in% c("reregister", "default", "pooled"), opt$start %in% c("runs", "replicates"))
one_pass <- opt$protocol %in% c("default", "pooled")
pool <- if (opt$protocol != "default") 0:3
holdout_again <- arg_flag(opt$holdout_again)
rescale <- arg_flag(opt$rescale)
if (one_pass && (holdout_again || rescale)) stop("holdout_again and rescale go with protocol=reregister")
options(wavevalid.quiet = TRUE)

# The protocol for one model: its runs, I/U map and mechanism (held-out runs
# of that model when rescaling).
fit_model <- function(tb, runs, iu, mechanism) {
  if (!one_pass) {
    check <- if (rescale) testbed_check_runs(iu, mechanism)
    return(testbed_two_pass(tb, runs, iu, mechanism, check, pool, opt$start, as.integer(opt$passes),
                            as.integer(opt$n_search))$fit)
  }
  field <- testbed_register(tb, runs, refine = TRUE)
  testbed_calibrate(testbed_emulators(runs, wavelet_basis(runs, field)), field, iu, pool)
}

# the share of a fit's bias energy at wavelet level 0 (an offset of the record), by site
level0 <- function(fit) {
  lv <- attr(where_fails(fit), "wavelet_levels")
  paste(formatC(lv$share[lv$level == 0], digits = 2, format = "f"), collapse = "/")
}

cat(sprintf("protocol %s, rescale %s, n_search %s, start %s, passes %s, holdout_again %s\n", opt$protocol, rescale,
            opt$n_search, opt$start, opt$passes, holdout_again))
for (h in hidden) {
  t0 <- clock()
  loop <- testbed_loop(h, seed, fit_model, refine = one_pass, holdout_again = holdout_again)
  cat(sprintf("\n%s, seed %d (%.0f s): strength %.2f\n", h, seed, clock() - t0,
              mean(as.matrix(loop$after$draws)[, paste0("s_", h)])))
  print(as.data.frame(unclass(loop$comparison)), row.names = FALSE, digits = 3)
  cat(sprintf("level-0 share of the bias energy: before %s, after %s\n", level0(loop$before), level0(loop$after)))
}
