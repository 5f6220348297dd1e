# Re-validated mechanisms under the second-registration protocol of
# bench/check_reregistration.R, each registered to its own model. There the
# field data of pass 2 are registered to a run of the model without any
# mechanism at pass 1's calibrated inputs, and every re-validated model is
# calibrated on them. Here each re-validated model (the mechanism's strength
# a calibration input on [0, 1], 66 runs, emulators on pass 2's basis
# rescaled on 30 held-out runs of that model, levels 0-3 pooled) is
# calibrated on pass 2's field data (refit 1), then the replicates are
# registered to a run of that model at refit 1's posterior mean inputs, and
# it is calibrated again (refit 2). Each mechanism's Bayes factor, strength
# free against switched off, is the Savage-Dickey ratio explain_bias() uses,
# on the model's own registered data. Printed per case: the strength's
# posterior mean and the inclusion probability (no mechanism and each alone
# equally likely a priori) from refit 1 (what explain_bias() gives) and
# refit 2.
#   Rscript bench/check_reregistration_refits.R [hidden=none] [seeds=1:5]
suppressPackageStartupMessages(library(wavevalid))
source("bench/args.R")
opt <- bench_args(list(hidden = "none", seeds = "1:5"))
hidden <- strsplit(opt$hidden, ",")[[1]]
seeds <- eval(parse(text = paste0("c(", opt$seeds, ")")))
options(wavevalid.quiet = TRUE)
ns <- asNamespace("wavevalid")
source("bench/protocol.R")
check0 <- held_out_runs(testbed_suspension(1)$iu)
log_bf <- function(rf, strength) {
  rf$draw_matrix <- as.matrix(rf$draws)
  H <- nrow(rf$draw_matrix)
  keep <- unique(round(seq(1, H, length.out = min(50, H))))
  -ns$log_density_at_off(rf, strength, keep)
}
inclusion <- function(lb) {
  p <- exp(c(0, lb) - max(c(0, lb)))
  (p / sum(p))[-1]
}

res <- NULL
for (h in hidden) {
  for (seed in seeds) {
    t0 <- clock()
    tb <- testbed_suspension(seed = seed, hidden = h)
    reg <- function(reference) register_case(tb, reference)
    p1 <- first_pass(tb, check0)
    field2 <- reg(simulate_suspension(as.data.frame(as.list(coef(p1$fit)))))
    out <- lapply(testbed_mechanisms(), function(m) {
      s <- paste0("s_", m)
      iu_m <- iu_add(tb$iu, s, lower = 0, upper = 1, nominal = 0.5)
      runs <- simulate_suspension(design_maximin(iu_m, 66L, seed = 2), mechanism = m)
      em_m <- rescale_emulators(suppressWarnings(fit_emulators(runs, p1$basis)), held_out_runs(iu_m, m))
      r1 <- calibrate_short(em_m, field2, iu_m)
      own <- reg(simulate_suspension(as.data.frame(as.list(coef(r1))), mechanism = m))
      r2 <- calibrate_short(em_m, own, iu_m)
      c(s1 = coef(r1)[[s]], lb1 = log_bf(r1, s), s2 = coef(r2)[[s]], lb2 = log_bf(r2, s))
    })
    tab <- as.data.frame(do.call(rbind, out))
    tab$p1 <- inclusion(tab$lb1)
    tab$p2 <- inclusion(tab$lb2)
    for (k in seq_along(testbed_mechanisms())) {
      m <- testbed_mechanisms()[k]
      row <- data.frame(hidden = h, seed = seed, mechanism = m, strength1 = round(tab$s1[k], 3),
                        incl1 = round(tab$p1[k], 3), strength2 = round(tab$s2[k], 3), incl2 = round(tab$p2[k], 3))
      res <- rbind(res, row)
      print(row, row.names = FALSE)
    }
    ok <- function(p) if (h == "none") all(p < 0.5) else {
      k <- testbed_mechanisms() == h
      p[k] >= 0.9 && all(p[!k] < 0.5)
    }
    cat(sprintf("%s seed %d: refit 1 %s, refit 2 %s (%d s)\n", h, seed, ok(tab$p1), ok(tab$p2), round(clock() - t0)))
  }
}
print(res, row.names = FALSE)
