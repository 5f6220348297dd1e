# Speed of calibrate(): (a) a full 1000 x 200 chain at the size of the test bed
# (~230 coefficients, 66 runs, 9 inputs), (b) the C++ likelihood step against
# a plain R implementation of eq. (11) + eq. (18), (c) effective samples per
# second of the inputs.
# Run: R_LIBS=<lib> Rscript bench/bench_calibrate.R [n_draws] [n_inner]
library(wavevalid)
args <- commandArgs(trailingOnly = TRUE)
n_draws <- if (length(args) >= 1) as.integer(args[1]) else 1000L
n_inner <- if (length(args) >= 2) as.integer(args[2]) else 200L
ns <- asNamespace("wavevalid")
set.seed(1)

n_t <- 4096L
n_coef <- 230L
K <- 66L
inputs <- c("u1", "u2", paste0("x", 1:7))
p <- length(inputs)
iu <- iu_map(inputs, c("calibration", "calibration", rep("variation", 7)),
             lower = rep(0.125, p), upper = rep(0.875, p), nominal = rep(0.5, p))
design <- apply(matrix(runif(K * p), K, p), 2, function(v) (rank(v) - runif(K)) / K)
design <- 0.125 + 0.75 * design
colnames(design) <- inputs
t <- 65 * (0:(n_t - 1)) / n_t
index <- sort(c(1:8, sample(9:n_t, n_coef - 8)))
basis <- ns$basis_from_index(t, index)
# coefficient i: a smooth function of the inputs; GASP hyperparameters with
# some zero betas as fitted emulators have
A <- matrix(rnorm(n_coef * p), n_coef, p) / sqrt(seq_len(n_coef))
Y <- sin(design %*% t(A) * 3) + 0.1 * matrix(rnorm(K * n_coef), K, n_coef)
beta <- matrix(rexp(n_coef * p, 1 / 2), n_coef, p) * (matrix(runif(n_coef * p), n_coef, p) > 0.3)
alpha <- matrix(sample(c(0, 0.5, 1), n_coef * p, TRUE, c(0.6, 0.3, 0.1)), n_coef, p)
bank <- ns$bank_fixed_hyper(design, Y, beta, alpha, nugget = 1e-6)
emulators <- structure(list(params = NULL, inputs = inputs, design = design, banks = list(site1 = bank),
                            basis = basis, engine = "gasp", t = t), class = "wv_emulators")
z_true <- rep(0.55, p)
m_true <- ns$gasp_bank_predict_cpp(bank, matrix(z_true, 1))$mean
W <- matrix(drop(m_true), 7, n_coef, byrow = TRUE) + matrix(rnorm(7 * n_coef, sd = 0.05), 7, n_coef)
field <- ns$new_wv_field(t, list(site1 = W %*% t(basis$Psi)))

cat(sprintf("Problem: %d coefficients, %d runs, %d inputs, %d-point grid\n", n_coef, K, p, n_t))

# (a) a full chain
el <- system.time(fit <- calibrate(emulators, field, iu, n_draws = n_draws, n_inner = n_inner, chains = 1,
                                   seed = 1, quiet = TRUE))[["elapsed"]]
n_iter <- n_draws * n_inner
cat(sprintf("(a) one chain of %d x %d = %d iterations: %.1f s (%.1f us per iteration); acceptance tau2 %.2f, inputs %.2f\n",
            n_draws, n_inner, n_iter, el, 1e6 * el / n_iter, fit$acceptance$tau2, fit$acceptance$inputs))

# (b) per-iteration time against plain R (eq. 11 by a loop over coefficients, eq. 18)
spec <- ns$calibration_spec(emulators, field, iu)
r_predict <- function(bank, z) {
  zs <- (z - bank$lower) / bank$width
  D <- abs(sweep(bank$X, 2, zs))
  n <- length(bank$mu)
  m <- v <- numeric(n)
  for (i in seq_len(n)) {
    s <- rowSums(sweep(D, 2, 2 - bank$alpha[i, ], "^") %*% diag(bank$beta[i, ], p))
    r <- exp(-s)
    m[i] <- bank$mu[i] + sum(r * bank$weights[, i])
    u <- forwardsolve(bank$chol[, , i], r)
    v[i] <- max(1 - sum(u^2), 0) / bank$lambda[i]
  }
  list(m = m, v = v)
}
r_iteration <- function(z, tau2, sigma2, site) {
  pr <- r_predict(site$bank, z)
  tot <- pr$v + sigma2 / site$R + tau2[site$group + 1]
  sum(dnorm(site$wbar, pr$m, sqrt(tot), log = TRUE))
}
n_r <- 20
sig2 <- spec$s2$site1 / 6
tau2 <- rep(0.01, nrow(spec$groups))
el_r <- system.time(for (k in seq_len(n_r)) {
  z <- spec$priors$lower + runif(p) * (spec$priors$upper - spec$priors$lower)
  r_iteration(z, tau2, sig2, spec$sites$site1)
})[["elapsed"]] / n_r
tau <- ns$resolve_fix_tau2(NULL, spec$groups)
short <- system.time(ns$run_chains(spec, 20, 100, 1, 1, 0.1, tau, 0L, quiet = TRUE))[["elapsed"]] / 2000
cat(sprintf("(b) per iteration: plain R %.2f ms, C++ %.1f us: ratio %.0fx\n", 1e3 * el_r, 1e6 * short, el_r / short))

# (c) effective samples per second for the inputs
ess <- coda::effectiveSize(fit$draws)[inputs]
cat(sprintf("(c) effective samples per second (inputs): median %.1f, min %.1f (ESS median %.0f, min %.0f of %d draws)\n",
            median(ess) / el, min(ess) / el, median(ess), min(ess), n_draws))
