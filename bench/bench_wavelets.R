# Timing of the wavelet basis and coefficient extraction, and the registration
# and reconstruction figures on a test bed (the package's, when it has one;
# otherwise synthetic irregular curves of the same size).
#
#   R CMD INSTALL -l /tmp/lib . && R_LIBS=/tmp/lib Rscript bench/bench_wavelets.R

library(wavevalid)
options(wavevalid.quiet = TRUE)
ns <- asNamespace("wavevalid")

# Synthetic test bed: 4096 points on [0, 65), two events (6 < t < 11 and
# 37 < t < 41) answered by damped oscillations over a fixed road roughness, two
# sites, 65 runs with varying parameters, 7 replicates with jittered event
# times and AR(1) measurement noise.
synthetic_testbed <- function(seed = 1, n_runs = 65, n_rep = 7, roughness = 0.05) {
  set.seed(seed)
  t <- 65 * (0:4095) / 4096
  # road roughness seen through the suspension: an AR(2) resonance near 1.2 cycles per time unit
  theta <- 2 * pi * 1.2 * 65 / 4096
  road <- as.numeric(stats::filter(rnorm(4096), c(2 * 0.98 * cos(theta), -0.98^2), method = "recursive"))
  road <- roughness * road / stats::sd(road)
  response <- function(tt, p, site) {
    lag <- if (site == 1) 0 else 0.35
    amp <- if (site == 1) c(1, 0.6) else c(0.7, 0.8)
    y <- p[["gain"]] * stats::approx(t, road, xout = tt - lag, rule = 2)$y
    for (e in 1:2) {
      te <- c(7.5, 38.4)[e] + lag
      s <- pmax(tt - te, 0)
      y <- y - amp[e] * p[["amp"]] * (tt > te) * exp(-p[["damp"]] * s) * sin(2 * pi * p[["freq"]] * s)
    }
    y + 0.15 * sin(2 * pi * tt / 13)
  }
  design <- data.frame(amp = runif(n_runs, 0.8, 1.2), damp = runif(n_runs, 0.8, 1.4),
                       freq = runif(n_runs, 0.9, 1.3), gain = runif(n_runs, 0.8, 1.2))
  runs <- lapply(1:2, function(s) t(apply(design, 1, function(p) response(t, p, s))))
  truth <- c(amp = 1.05, damp = 1, freq = 1.1, gain = 1)
  jitter_time <- function() {
    shift <- rnorm(2, sd = 0.25)
    knots_after <- c(0, 7.5, 38.4, 65)
    stats::approx(knots_after, knots_after + c(0, shift, 0), xout = t)$y
  }
  field <- lapply(1:2, function(s) matrix(0, n_rep, 4096))
  for (r in seq_len(n_rep)) {
    tt <- jitter_time()
    for (s in 1:2) {
      noise <- as.numeric(stats::filter(rnorm(4096, sd = 0.02), 0.9, method = "recursive"))
      field[[s]][r, ] <- response(tt, truth, s) + noise
    }
  }
  names(runs) <- names(field) <- c("site1", "site2")
  list(runs = model_runs(design, runs, t), field = field_runs(field, t),
       windows = list(c(6, 11), c(37, 41)))
}

if (exists("testbed_suspension", envir = ns)) {
  tb <- ns$testbed_suspension(seed = 1)
  bed <- list(runs = tb$A$runs, field = tb$A$field, windows = list(c(6, 11), c(37, 41)))
  cat("Test bed: testbed_suspension(seed = 1), condition A\n")
} else {
  bed <- synthetic_testbed()
  cat("Test bed: synthetic damped oscillations (testbed_suspension() not available)\n")
}
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
n_rep_time <- 10
t_coef <- stats::median(vapply(seq_len(n_rep_time), function(i)
  system.time(w <- wavelet_coef(basis, runs))[["elapsed"]], numeric(1)))
t_full <- stats::median(vapply(seq_len(3), function(i)
  system.time(for (s in names(runs$curves)) apply(runs$curves[[s]], 1, ns$full_coef, settings = basis$settings))[["elapsed"]],
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
