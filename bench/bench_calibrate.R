# Speed of calibrate() on the suspension test bed (seed 1, condition A):
# (a) one full chain of n_draws x n_inner cycles (plus the burn-in) on Site 1
# alone (one thread, then two sharing the emulator predictions), then on both
# sites jointly,
# (b) the cost of one Metropolis-Hastings cycle in C++ against plain R
# implementations of eq. (11) + eq. (18): a loop over coefficients calling
# DiceKriging::predict() on km objects with the fitted hyperparameters, and a
# vectorised loop in base R; (c) effective samples per second of each input;
# (d) cycles per effective sample with and without independence moves.
# Run: R_LIBS=<lib> Rscript bench/bench_calibrate.R [n_draws] [n_inner]
library(wavevalid)
options(wavevalid.quiet = TRUE)
# calibrate() uses no more threads than free cores; the two-thread chain below
# is run with two whatever the load, to measure them
options(wavevalid.free_cores = 2L)
args <- commandArgs(trailingOnly = TRUE)
n_draws <- if (length(args) >= 1) as.integer(args[1]) else 1000L
n_inner <- if (length(args) >= 2) as.integer(args[2]) else 200L

t0 <- proc.time()[["elapsed"]]
tb <- testbed_suspension(seed = 1)
field <- register_curves(tb$A$field, tb$A$runs, tb$windows)
basis <- wavelet_basis(tb$A$runs, field)
emulators <- fit_emulators(tb$A$runs, basis)
iu <- tb$iu
p <- length(emulators$inputs)
cat(sprintf("Test bed: %d coefficients per site, sites %s, %d runs, %d inputs (built in %.0f s)\n",
            length(basis$index), paste(names(emulators$banks), collapse = ", "), nrow(emulators$design), p,
            proc.time()[["elapsed"]] - t0))

# (a) one full chain: Site 1 alone, then both sites jointly
one_chain <- function(label, emulators, field, threads = 1L) {
  el <- system.time(fit <- calibrate(emulators, field, iu, chains = 1, seed = 1,
                                     sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, threads = threads)))[["elapsed"]]
  n_iter <- n_draws * n_inner + fit$settings$burnin
  cat(sprintf("(a) %s, %d thread%s: one chain, %d x %d cycles + %d burn-in = %d cycles: %.1f s (%.3f ms per cycle)\n",
              label, threads, if (threads > 1) "s" else "", n_draws, n_inner, fit$settings$burnin, n_iter, el,
              1e3 * el / n_iter))
  cat(sprintf("    acceptance: tau2 %.2f, inputs %.2f (random walk), %.2f (global moves), burn-in %.2f\n",
              fit$acceptance$tau2, fit$acceptance$inputs, fit$acceptance$global, fit$acceptance$burnin))
  list(fit = fit, el = el)
}
emu1 <- emulators
emu1$banks <- emulators$banks["site1"]
field1 <- field
field1$curves <- field$curves["site1"]
a1 <- one_chain("Site 1", emu1, field1)
a1t <- one_chain("Site 1", emu1, field1, threads = 2L)
cat(sprintf("    two threads: %.2fx faster; identical draws: %s\n", a1$el / a1t$el,
            identical(as.matrix(a1$fit$draws), as.matrix(a1t$fit$draws))))
a2 <- one_chain("Sites 1 and 2", emulators, field)
fit <- a1$fit
el <- a1$el

# (b) one cycle: the C++ sampler's cost per cycle, the difference of two
# calibrations of both sites that differ only in their number of cycles
# (the start search and burn-in cancel), against plain R
cycles_time <- function(n_draws) {
  system.time(calibrate(emulators, field, iu, chains = 1, seed = 1,
                        sampler = sampler_control(n_draws = n_draws, n_inner = 100, quiet = TRUE)))[["elapsed"]]
}
cpp <- (cycles_time(55) - cycles_time(5)) / 5000

# The data of the likelihood by site: the field mean's retained coefficients
# (wbar), the replicates' sums of squared deviations (s2), their number (R)
sites <- lapply(stats::setNames(nm = names(emulators$banks)), function(s) {
  W <- wavelet_coef(basis, field$curves[[s]])
  wbar <- colMeans(W)
  list(bank = emulators$banks[[s]], wbar = wbar, s2 = colSums(sweep(W, 2L, wbar)^2), R = nrow(W))
})
prior <- as.data.frame(iu)[match(emulators$inputs, iu$name), ]

# DiceKriging: one km object per (site, coefficient) with the fitted
# hyperparameters; powexp correlation exp(-sum (|h| / theta)^p) with
# p = 2 - alpha, theta = beta^(-1 / p) (beta = 0: theta = 1e8).
km_bank <- function(bank) {
  X <- as.data.frame(bank$X)
  colnames(X) <- emulators$inputs
  lapply(seq_along(bank$mu), function(i) {
    pw <- 2 - bank$alpha[i, ]
    theta <- ifelse(bank$beta[i, ] > 0, bank$beta[i, ]^(-1 / pw), 1e8)
    v <- 1 / bank$lambda[i]
    DiceKriging::km(~1, design = X, response = bank$y[, i], covtype = "powexp",
                    coef.trend = bank$mu[i], coef.cov = c(theta, pw), coef.var = v,
                    nugget = if (bank$nugget[i] > 0) bank$nugget[i] * v else NULL)
  })
}
kms <- lapply(emulators$banks, km_bank)
dk_predict <- function(models, bank, z) {
  nd <- as.data.frame(matrix((z - bank$lower) / bank$width, 1, dimnames = list(NULL, emulators$inputs)))
  pr <- lapply(models, function(m) DiceKriging::predict(m, newdata = nd, type = "SK", checkNames = FALSE,
                                                         se.compute = TRUE, light.return = TRUE))
  list(m = vapply(pr, function(x) x$mean, 0), v = vapply(pr, function(x) x$sd^2, 0))
}
loglik_r <- function(pred, tau2, sigma2, site) {
  tot <- pred$v + sigma2 / site$R + tau2
  sum(stats::dnorm(site$wbar, pred$m, sqrt(tot), log = TRUE))
}
set.seed(1)
tau2 <- 0.01
draw_z <- function() prior$lower + stats::runif(p) * (prior$upper - prior$lower)
z_check <- draw_z()
chk <- dk_predict(kms[[1]], emulators$banks[[1]], z_check)
ref <- predict(emulators, matrix(z_check, 1, dimnames = list(NULL, emulators$inputs)), site = names(emulators$banks)[1])
cat(sprintf("    DiceKriging vs C++ predictions (site 1): max |mean diff| %.1e, max |var diff| %.1e\n",
            max(abs(chk$m - drop(ref$mean))), max(abs(chk$v - drop(ref$var)))))
n_dk <- 3
el_dk <- system.time(for (k in seq_len(n_dk)) {
  z <- draw_z()
  for (s in names(sites)) {
    site <- sites[[s]]
    loglik_r(dk_predict(kms[[s]], site$bank, z), tau2, site$s2 / (site$R - 1), site)
  }
})[["elapsed"]] / n_dk

r_predict <- function(bank, z) {
  zs <- (z - bank$lower) / bank$width
  D <- abs(sweep(bank$X, 2, zs))
  n <- length(bank$mu)
  m <- v <- numeric(n)
  for (i in seq_len(n)) {
    s <- rowSums(sweep(D, 2, 2 - bank$alpha[i, ], "^") %*% diag(bank$beta[i, ], p))
    r <- exp(-s)
    m[i] <- bank$mu[i] + sum(r * bank$weights[, i])
    u <- forwardsolve(bank$chol[, , if (is.null(bank$chol_of)) i else bank$chol_of[i]], r)  # its factor
    v[i] <- max(1 - sum(u^2), 0) / bank$lambda[i]
  }
  list(m = m, v = v)
}
n_r <- 10
el_r <- system.time(for (k in seq_len(n_r)) {
  z <- draw_z()
  for (s in names(sites)) {
    site <- sites[[s]]
    loglik_r(r_predict(site$bank, z), tau2, site$s2 / (site$R - 1), site)
  }
})[["elapsed"]] / n_r
cat(sprintf("(b) per cycle, both sites: C++ %.2f ms; DiceKriging::predict loop %.0f ms (ratio %.0fx); vectorised base R %.0f ms (ratio %.0fx)\n",
            1e3 * cpp, 1e3 * el_dk, el_dk / cpp, 1e3 * el_r, el_r / cpp))

# (c) effective samples per second for each input
ess <- coda::effectiveSize(fit$draws)[emulators$inputs]
cat("(c) Site 1 chain: effective samples per second of chain time (ESS of", n_draws, "draws):\n")
print(data.frame(input = names(ess), ess = round(ess), ess_per_s = signif(ess / el, 3)), row.names = FALSE)

# (d) mixing per cycle, side by side: unthinned Site-1 chains of 20,000 saved
# cycles after a 50,000-cycle burn-in, with independence moves in half of the
# cycles (global_moves = 0.5) and with the default (the report's mixture step
# in a tenth); cycles per effective sample of each input
unthinned <- function(global_moves) {
  el <- system.time(f <- calibrate(emu1, field1, iu, chains = 1, seed = 1,
                                   sampler = sampler_control(n_draws = 20000, n_inner = 1, burnin = 50000, global_moves = global_moves)))[["elapsed"]]
  e <- coda::effectiveSize(f$draws)[emulators$inputs]
  list(cpe = 20000 / e, el = el, acc = f$acceptance)
}
u_def <- unthinned(0.5)
u_rw <- unthinned(0)  # the default
cat("(d) Site 1, unthinned chains of 20,000 cycles: cycles per effective sample (lower mixes faster)\n")
print(data.frame(input = emulators$inputs, global_moves_0.5 = round(u_def$cpe), default = round(u_rw$cpe),
                 ratio = round(u_rw$cpe / u_def$cpe, 2)), row.names = FALSE)
cat(sprintf("    slowest input: %.0f against %.0f cycles per effective sample (%.1fx); acceptance: walk %.2f, global %.2f\n",
            max(u_def$cpe), max(u_rw$cpe), max(u_rw$cpe) / max(u_def$cpe), u_def$acc$inputs, u_def$acc$global))
cat(sprintf("    slowest input's effective samples per second of sampling (cycles at %.3f ms): %.0f against %.0f\n",
            1e3 * el / (n_draws * n_inner + fit$settings$burnin),
            (n_draws * n_inner + fit$settings$burnin) / el / max(u_def$cpe),
            (n_draws * n_inner + fit$settings$burnin) / el / max(u_rw$cpe)))
cat(sprintf("Total bench time %.0f s\n", proc.time()[["elapsed"]] - t0))
