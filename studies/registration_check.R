# How well the registration's own error, as register_curves() measures it on
# the model runs nearest the field (`check_runs`), describes the registered
# field mean's error against reality, on both test beds with nothing hidden
# (the model at the true inputs is reality there, so every part of that
# error is a false signal). For each seed and site, the field mean's wavelet
# coefficients less reality's, standardised by the sampling variance the
# replicates' scatter gives them (pooled by level) plus each estimate of the
# registration's variance:
#   none   nothing added (the method's)
#   site   the mean square of the check's change over its runs and every
#          coefficient, one number per site (registration_variance = "check")
#   level  the same by wavelet level
#   coef   the same by coefficient (mean over the check's runs)
# and prints the mean square of the standardised errors (1 when the variance
# is right), the share beyond 2.5 and 3.5, the largest, and the ratio of the
# true error's excess variance to the estimate.
#   Rscript studies/registration_check.R [beds=suspension,dosing] [seeds=1:5] [check_runs=5]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
args <- study_args(list(beds = "suspension,dosing", seeds = "1:5", check_runs = "5"))
options(wavevalid.quiet = TRUE)
bed <- testbed_beds()
res <- list()
for (b in arg_names(args$beds)) for (seed in arg_numbers(args$seeds)) {
  tb <- bed[[b]]$make(seed = seed, hidden = "none")
  field <- tb$A$field
  runs <- tb$A$runs
  # validate()'s automatic knot spacing
  ke <- max(diff(range(field$t)) / 32, 4 * diff(field$t[1:2]))
  reg <- suppressWarnings(register_curves(field, runs, tb$windows, features = bed[[b]]$features, knots_every = ke,
                                          check_runs = as.integer(args$check_runs)))
  basis <- wavelet_basis(runs, reg)
  lv <- basis$level
  for (s in names(reg$curves)) {
    Y <- reg$curves[[s]]
    W <- wavelet_coef(basis, Y)
    e <- drop(wavelet_coef(basis, colMeans(Y) - tb$truth$reality[[s]]))
    vs <- stats::ave(apply(W, 2, stats::var) / nrow(Y), lv)
    E2 <- wavelet_coef(basis, reg$registration_check[[s]])^2
    est <- list(none = 0 * e, site = rep(mean(E2), length(e)), level = stats::ave(colMeans(E2), lv),
                coef = colMeans(E2))
    for (nm in names(est)) {
      z <- e / sqrt(vs + est[[nm]])
      res[[length(res) + 1L]] <- data.frame(
        bed = b, seed = seed, site = s, estimate = nm, mean_z2 = mean(z^2), beyond_2.5 = mean(abs(z) > 2.5),
        beyond_3.5 = mean(abs(z) > 3.5), max_z = max(abs(z)),
        true_over_estimate = if (nm == "none") NA else (mean(e^2) - mean(vs)) / mean(est[[nm]]))
    }
  }
}
res <- do.call(rbind, res)
print(res[res$estimate == "site", ], digits = 2, row.names = FALSE)
cat("\nMeans over seeds and sites:\n")
print(stats::aggregate(cbind(mean_z2, beyond_2.5, beyond_3.5, max_z) ~ bed + estimate, res, mean), digits = 2,
      row.names = FALSE)
