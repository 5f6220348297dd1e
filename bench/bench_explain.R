# Cost of the sign constraint in explain_bias() on the suspension test bed
# (seed 1, hidden digressive damper, condition A, 150 x 20 draws as in the
# tests): the four mechanism signatures at the posterior mean inputs plus the
# nine shifts, 50 draws, subsets of up to three; explain_bias() with the
# mechanisms' amplitudes constrained to be non-negative (positive = TRUE, the
# GHK orthant probabilities) against the same regression without it, run
# alternately. Prints the median seconds of each and their ratio.
# Run: R_LIBS=<lib> Rscript bench/bench_explain.R [reps]
library(wavevalid)
options(wavevalid.quiet = TRUE)
args <- commandArgs(trailingOnly = TRUE)
reps <- if (length(args) >= 1) as.integer(args[1]) else 5L

tb <- testbed_suspension(seed = 1, hidden = "digressive_damper")
field <- register_curves(tb$A$field, tb$A$runs, tb$windows, knots_every = 2)
em <- suppressWarnings(fit_emulators(tb$A$runs, wavelet_basis(tb$A$runs, field)))
fit <- suppressWarnings(calibrate(em, field, tb$iu, chains = 1, seed = 1,
                                  sampler = sampler_control(n_draws = 150, n_inner = 20)))
sig <- testbed_signatures(colMeans(as.matrix(fit$draws))[fit$inputs])
tm <- vapply(seq_len(reps), function(i) c(
  free = system.time(explain_bias(fit, sig, positive = FALSE, n_draws = 50, seed = 1))[["elapsed"]],
  positive = system.time(explain_bias(fit, sig, n_draws = 50, seed = 1))[["elapsed"]]
), numeric(2))
med <- apply(tm, 1, stats::median)
cat(sprintf("explain_bias, 13 candidates, 50 draws: free %.2f s, positive %.2f s, ratio %.2f\n",
            med[["free"]], med[["positive"]], med[["positive"]] / med[["free"]]))
