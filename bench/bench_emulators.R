# Emulator fitting: the gasp engine against DiceKriging on Site 1 of the test
# bed (condition A, registered field, wavelet basis of runs and field), one
# core, sequentially (gasp before and after DiceKriging). Prints the time of
# each engine, their ratio, and the
# share of coefficients where the gasp engine's maximised log-likelihood is at
# least DiceKriging's minus 0.1. Both log-likelihoods are params$loglik, which
# fit_emulators() computes for either engine with the same code from the
# fitted beta, alpha and nugget.
#
# Argument: [seed=1] (positional), the test bed's seed (DiceKriging's starting
# points use the same seed).
# Environment: WAVEVALID_BENCH_DK=<file.rds> reuses a saved DiceKriging fit
# (written there when the file does not exist yet); WAVEVALID_BENCH_SAVE=<file>
# saves both fits.
suppressPackageStartupMessages(library(wavevalid))
options(wavevalid.quiet = TRUE)
future::plan(future::sequential)

args <- commandArgs(trailingOnly = TRUE)
bench_seed <- if (length(args) >= 1L) as.integer(args[1]) else 1L
tb <- testbed_suspension(seed = bench_seed)
f <- register_curves(tb$A$field, tb$A$runs, tb$windows)
basis <- wavelet_basis(tb$A$runs, f)
runs <- tb$A$runs
runs$curves <- runs$curves["site1"]
cat(sprintf("test bed seed %d, condition A, site 1: %d runs, %d inputs, %d coefficients\n", bench_seed,
            nrow(runs$design), ncol(runs$design), length(basis$index)))

# gasp is timed just before and just after DiceKriging and the two times
# averaged, so that a change of the machine's load during the run weighs on
# both engines alike (a fresh DiceKriging fit only; a saved one is timed once)
fit_gasp <- function() {
  t <- system.time(g <- suppressWarnings(fit_emulators(runs, basis, engine = "gasp")))[["elapsed"]]
  list(g = g, time = t)
}
before <- fit_gasp()
g <- before$g
cat(sprintf("gasp engine:        %7.1f s (%.1f ms per coefficient)\n", before$time, 1000 * before$time / nrow(g$params)))
dk_file <- Sys.getenv("WAVEVALID_BENCH_DK")
if (nzchar(dk_file) && file.exists(dk_file)) {
  saved <- readRDS(dk_file)
  d <- saved$d
  time_d <- saved$time
  time_g <- before$time
  cat(sprintf("dicekriging engine: %7.1f s (saved fit from %s)\n", time_d, dk_file))
} else {
  time_d <- system.time(d <- suppressWarnings(fit_emulators(runs, basis, engine = "dicekriging", seed = bench_seed)))[["elapsed"]]
  cat(sprintf("dicekriging engine: %7.1f s (%.1f ms per coefficient)\n", time_d, 1000 * time_d / nrow(d$params)))
  if (nzchar(dk_file)) saveRDS(list(d = d, time = time_d), dk_file)
  after <- fit_gasp()
  stopifnot(identical(after$g$params, g$params))
  time_g <- (before$time + after$time) / 2
  cat(sprintf("gasp engine again:  %7.1f s; mean of the two %.1f s\n", after$time, time_g))
}
cat(sprintf("speed ratio (dicekriging / gasp): %.1f (target >= 20)\n", time_d / time_g))

ok <- is.finite(g$params$loglik) & is.finite(d$params$loglik)
diff <- g$params$loglik[ok] - d$params$loglik[ok]
cat(sprintf("gasp loglik >= dicekriging loglik - 0.1: %d of %d coefficients (%.1f%%, target >= 99%%)\n",
            sum(diff >= -0.1), length(diff), 100 * mean(diff >= -0.1)))
cat(sprintf("loglik difference gasp - dicekriging: median %.3f, quartiles %.3f, %.3f, worst %.2f\n",
            stats::median(diff), stats::quantile(diff, 0.25), stats::quantile(diff, 0.75), min(diff)))
lev <- g$params$level[ok]
cat("share >= dicekriging - 0.1 by level:\n")
print(round(tapply(diff >= -0.1, lev, mean), 3))
cat(sprintf("nuggets: gasp %d, dicekriging %d; dicekriging fallbacks to gasp: %d\n",
            sum(g$params$nugget > 0 & ok), sum(d$params$nugget > 0 & ok), sum(!d$params$converged, na.rm = TRUE)))

# prediction speed of one bank (what the sampler calls per iteration)
Z <- as.matrix(runs$design)[rep(1:5, 400), ] * 0.98 + 0.01
time_p <- system.time(pr <- predict(g, Z, site = "site1"))[["elapsed"]]
cat(sprintf("bank prediction: %.3f ms per input point for %d coefficients\n",
            1000 * time_p / nrow(Z), ncol(pr$mean)))
if (nzchar(Sys.getenv("WAVEVALID_BENCH_SAVE"))) saveRDS(list(g = g, d = d), Sys.getenv("WAVEVALID_BENCH_SAVE"))
