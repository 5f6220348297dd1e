# Timing of the wavelet basis and of the coefficient extraction against the
# full wavethresh::wd() transform of each curve (the ratio printed), and the
# registration and reconstruction figures, on the suspension test bed (seed 1,
# condition A).
#   Rscript bench/bench_wavelets.R

library(wavevalid)
options(wavevalid.quiet = TRUE)
tb <- testbed_suspension(seed = 1)
bed <- list(runs = tb$A$runs, field = tb$A$field, windows = tb$windows)
cat("Test bed: testbed_suspension(seed = 1), condition A\n")
runs <- bed$runs
field <- bed$field
cat(sprintf("%d runs x %d sites x %d points; %d field replicates\n\n", nrow(runs$design), length(runs$curves),
            length(runs$t), nrow(field$curves[[1]])))

timeit <- function(expr, reps = 5) {
  f <- function() expr
  times <- vapply(seq_len(reps), function(i) system.time(eval.parent(substitute(expr)))[["elapsed"]], numeric(1))
  stats::median(times)
}

# Registration
t_reg <- system.time(reg <- register_curves(field, runs, bed$windows))[["elapsed"]]
spread <- function(f, w, s) {
  idx <- f$t >= w[1] & f$t <= w[2]
  mean(apply(f$curves[[s]][, idx, drop = FALSE], 2, stats::sd))
}
cat(sprintf("register_curves(): %.3f s\n", t_reg))
cat("Mean pointwise sd of the replicates in each event window, before -> after registration:\n")
for (s in names(field$curves)) for (w in bed$windows) {
  b <- spread(field, w, s)
  a <- spread(reg, w, s)
  cat(sprintf("  %s, %g < t < %g: %.4f -> %.4f (ratio %.2f)\n", s, w[1], w[2], b, a, a / b))
}

# Basis
t_basis <- system.time(basis <- wavelet_basis(runs, reg))[["elapsed"]]
cat(sprintf("\nwavelet_basis(): %.3f s; |I| = %d for both sites together (%s alone)\n", t_basis,
            length(basis$index), paste(sprintf("%s %d", names(basis$by_site), lengths(basis$by_site)),
                                       collapse = ", ")))
print(basis)

# Coefficient extraction: all runs of both sites on the retained basis
# the peer: every coefficient of a curve by wavethresh's periodic transform,
# from which the retained ones would be picked
full_wd <- function(y, settings) {
  w <- wavethresh::wd(y, filter.number = settings$filter.number, family = settings$family, bc = "periodic")
  c(wavethresh::accessC(w, 0), unlist(lapply(seq_len(wavethresh::nlevelsWT(w)) - 1L,
                                              function(l) wavethresh::accessD(w, l))))
}
n_rep_time <- 10
t_coef <- stats::median(vapply(seq_len(n_rep_time), function(i)
  system.time(w <- wavelet_coef(basis, runs))[["elapsed"]], numeric(1)))
t_full <- stats::median(vapply(seq_len(3), function(i)
  system.time(for (s in names(runs$curves)) apply(runs$curves[[s]], 1, full_wd, settings = basis$settings))[["elapsed"]],
  numeric(1)))
n_curves <- nrow(runs$design) * length(runs$curves)
cat(sprintf("\nCoefficient extraction of %d curves x %d points:\n", n_curves, length(runs$t)))
cat(sprintf("  wavelet_coef() (curves %%*%% Psi):     %.4f s (%.2f ms per curve)\n", t_coef, 1000 * t_coef / n_curves))
cat(sprintf("  full wavethresh::wd() per curve:      %.4f s (ratio %.1f)\n", t_full, t_full / t_coef))

# Reconstruction accuracy
chk <- reconstruction_check(basis, runs, reg)
d <- as.data.frame(chk)
cat(sprintf("\nRelative L2 reconstruction error: median %.4f, worst %.4f (%s %s %d)\n",
            stats::median(d$rel_l2), max(d$rel_l2), d$site[which.max(d$rel_l2)],
            d$source[which.max(d$rel_l2)], d$id[which.max(d$rel_l2)]))
print(chk)
cat("\nError-process check, site 1:\n")
print(error_processes(basis, reg, site = 1, seed = 1))
cat("\nSame, with the field residuals projected on the retained basis:\n")
print(error_processes(basis, reg, site = 1, seed = 1, project = TRUE))
