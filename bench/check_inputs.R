# How well the posterior of the inputs covers the true inputs on the
# suspension test bed with nothing hidden (the model at the true inputs is
# reality), with the emulators as fitted and with their variances rescaled
# by rescale_emulators() from held-out runs (a maximin design on the I/U
# ranges, not at the design points).
# field = "registered": the field replicates registered to the model runs
# (grid landmarks, knots every 2 time units); "unwarped": the same noise on
# reality without the time warps, i.e. a perfect registration, so that what
# is left is the emulators' error.
# Per seed and setting: z_max, the largest |posterior mean - truth| / posterior
# sd over the inputs; cover90, the share of the inputs whose true value lies
# in the central 90% posterior interval; err, the root mean square of
# posterior mean - truth (coded units); sd, the mean posterior sd; longest,
# the longest interval where_fails() flags (grid steps); credible, the
# largest credible bias (kN); heldout, the root mean square studentised error
# of the emulators at 20 other runs near the truth (sd 0.03 in coded units).
# inform_levels is calibrate()'s: the wavelet levels that inform the inputs
# ("NULL": all of them).
#   Rscript bench/check_inputs.R [seeds=1:5] [field=registered] [n_check=30] [n_draws=150] [n_inner=20]
#                                [inform_levels=NULL]
suppressPackageStartupMessages(library(wavevalid))
args <- commandArgs(trailingOnly = TRUE)
seeds <- if (length(args) >= 1) eval(parse(text = paste0("c(", args[1], ")"))) else 1:5
field_kind <- if (length(args) >= 2) match.arg(args[2], c("registered", "unwarped")) else "registered"
n_check <- if (length(args) >= 3) as.integer(args[3]) else 30L
n_draws <- if (length(args) >= 4) as.integer(args[4]) else 150L
n_inner <- if (length(args) >= 5) as.integer(args[5]) else 20L
inform_levels <- if (length(args) >= 6) eval(parse(text = args[6])) else NULL
options(wavevalid.quiet = TRUE)
ns <- asNamespace("wavevalid")

one <- function(seed) {
  tb <- testbed_suspension(seed = seed, hidden = "none")
  runs <- tb$A$runs
  field <- if (field_kind == "registered") {
    register_curves(tb$A$field, runs, tb$windows, knots_every = 2)
  } else {
    ns$unwarped_field(tb, seed)
  }
  em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, field)))
  check <- simulate_suspension(design_maximin(tb$iu, n_check, nominal = FALSE, seed = 9))
  truth <- c(tb$truth$u, 0.5 + tb$truth$delta)[em$inputs]
  near <- withr::with_seed(seed + 100, as.data.frame(t(replicate(20, pmin(pmax(truth + stats::rnorm(length(truth), sd = 0.03),
                                                                                  0.01), 0.99)))))
  near_runs <- simulate_suspension(near)
  rms_near <- function(e) {
    h <- ns$heldout_residuals(e, near_runs)
    sqrt(mean(h$residual[is.finite(h$residual)]^2))
  }
  do.call(rbind, lapply(c("as fitted", "rescaled"), function(setting) {
    e <- if (setting == "rescaled") rescale_emulators(em, check) else em
    fit <- suppressWarnings(calibrate(e, field, tb$iu, n_draws = n_draws, n_inner = n_inner, chains = 1,
                                      seed = 1, inform_levels = inform_levels, quiet = TRUE))
    d <- as.matrix(fit$draws)[, fit$inputs]
    m <- colMeans(d)
    s <- apply(d, 2, stats::sd)
    lo <- apply(d, 2, stats::quantile, 0.05)
    hi <- apply(d, 2, stats::quantile, 0.95)
    wf <- where_fails(fit)
    data.frame(seed = seed, emulators = setting, z_max = max(abs(m - truth) / s),
               cover90 = mean(truth >= lo & truth <= hi), err = sqrt(mean((m - truth)^2)), sd = mean(s),
               longest = max(c(0, round((wf$end - wf$start) / diff(fit$basis$t[1:2])))),
               credible = max(attr(wf, "credible")$credible_bias), heldout = rms_near(e))
  }))
}

cat(sprintf("inputs on the test bed (nothing hidden): %d seeds, field %s, %d held-out runs for the rescaling, %d x %d draws, inform_levels = %s\n",
            length(seeds), field_kind, n_check, n_draws, n_inner, deparse(inform_levels)))
res <- do.call(rbind, parallel::mclapply(seeds, one, mc.cores = 2, mc.preschedule = FALSE))
num <- vapply(res, is.double, logical(1))
res[num] <- lapply(res[num], signif, 3)
print(res[order(res$emulators, res$seed), ], row.names = FALSE)
cat("\nby setting\n")
agg <- aggregate(cbind(z_max, cover90, err, sd, heldout) ~ emulators, res, mean)
agg$clean <- tapply(res$longest <= 3, res$emulators, mean)[agg$emulators]
print(agg, row.names = FALSE)
