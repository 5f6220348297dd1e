# Emulator fitting: the gasp engine against DiceKriging on Site 1 of the test
# bed (or a synthetic stand-in of the same size), one core, sequentially.
# Prints the time of each engine, their ratio, and the share of coefficients
# where the gasp engine's maximised log-likelihood is at least DiceKriging's
# minus 0.1.
suppressPackageStartupMessages(library(wavevalid))
options(wavevalid.quiet = TRUE)
future::plan(future::sequential)
ns <- asNamespace("wavevalid")

if (exists("testbed_suspension", ns) && exists("wavelet_basis", ns)) {
  tb <- wavevalid::testbed_suspension(seed = 1)
  runs <- tb$A$runs
  runs$curves <- runs$curves["site1"]
  basis <- wavevalid::wavelet_basis(runs, tb$A$field)
  basis$sites <- "site1"
  source_label <- "test bed condition A, site 1"
} else {
  here <- if (file.exists("bench/synthetic.R")) "bench" else "."
  source(file.path(here, "synthetic.R"))
  set.seed(2)
  X <- synthetic_lhd(66, 9)
  colnames(X) <- c("u1", "u2", paste0("x", 1:7))
  t <- 65 * (0:4095) / 4096
  curves <- synthetic_curves(X, t)
  runs <- model_runs(as.data.frame(X), curves, t, site = "site1")
  basis <- synthetic_basis(curves, t)
  source_label <- "synthetic stand-in (66 runs, 9 inputs)"
}
cat(sprintf("%s: %d runs, %d inputs, %d coefficients\n", source_label, nrow(runs$design),
            ncol(runs$design), length(basis$index)))

time_g <- system.time(g <- suppressWarnings(fit_emulators(runs, basis, engine = "gasp")))[["elapsed"]]
cat(sprintf("gasp engine:        %7.1f s (%.1f ms per coefficient)\n", time_g, 1000 * time_g / nrow(g$params)))
time_d <- system.time(d <- suppressWarnings(fit_emulators(runs, basis, engine = "dicekriging", seed = 1)))[["elapsed"]]
cat(sprintf("dicekriging engine: %7.1f s (%.1f ms per coefficient)\n", time_d, 1000 * time_d / nrow(d$params)))
cat(sprintf("speed ratio (dicekriging / gasp): %.1f (target >= 10)\n", time_d / time_g))

ok <- is.finite(g$params$loglik) & is.finite(d$params$loglik)
diff <- g$params$loglik[ok] - d$params$loglik[ok]
cat(sprintf("gasp loglik >= dicekriging loglik - 0.1: %d of %d coefficients (%.1f%%, target >= 95%%)\n",
            sum(diff >= -0.1), length(diff), 100 * mean(diff >= -0.1)))
cat(sprintf("loglik difference gasp - dicekriging: median %.2f, quartiles %.2f, %.2f, min %.2f\n",
            stats::median(diff), stats::quantile(diff, 0.25), stats::quantile(diff, 0.75), min(diff)))
cat(sprintf("nuggets: gasp %d, dicekriging %d; dicekriging fallbacks to gasp: %d\n",
            sum(g$params$nugget > 0 & ok), sum(d$params$nugget > 0 & ok), sum(!d$params$converged, na.rm = TRUE)))

# prediction speed of one bank (what the sampler calls per iteration)
Z <- as.matrix(runs$design)[rep(1:5, 400), ] * 0.98 + 0.01
time_p <- system.time(pr <- predict(g, Z, site = "site1"))[["elapsed"]]
cat(sprintf("bank prediction: %.3f ms per input point for %d coefficients\n",
            1000 * time_p / nrow(Z), ncol(pr$mean)))
if (nzchar(Sys.getenv("WAVEVALID_BENCH_SAVE"))) saveRDS(list(g = g, d = d), Sys.getenv("WAVEVALID_BENCH_SAVE"))
