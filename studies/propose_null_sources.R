# Where does a proposal with nothing hidden come from? The suspension bed
# with nothing hidden, seeds `seeds`: validate() (one chain of n_draws x
# n_inner, seed 1), propose_terms() with the simulator's states (as
# propose_terms.R, mode=states), then the posterior mean residual of the
# field from the emulated model split into three parts, each projected (in
# the regression's weights, the parameter shifts and the offsets removed) on
# the top proposal's effect:
#   field - sim(truth)     the field mean's own error: noise and registration
#   sim(truth) - sim(hat)  the inputs' error (hat: coef(fit)) that the
#                          shifts, the emulators' derivatives, leave
#   sim(hat) - em(hat)     the emulators' error at the calibrated inputs
# Per part: its weighted energy, its component along the term (their sum is
# the posterior mean residual's at first order) and the share of its energy
# the term takes (r2).
#   Rscript studies/propose_null_sources.R [seeds=1:5] [n_draws=150] [n_inner=20]
suppressPackageStartupMessages(library(wavevalid))
source("studies/args.R")
source("studies/propose_beds.R")
a <- study_args(list(seeds = "1:5", n_draws = "150", n_inner = "20"))
options(wavevalid.quiet = TRUE, width = 200)
W <- asNamespace("wavevalid")

rows <- list()
for (seed in arg_numbers(a$seeds)) {
  tb <- testbed_suspension(seed = seed, hidden = "none")
  fit <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, chains = 1, seed = 1,
                                   sampler = sampler_control(n_draws = as.integer(a$n_draws),
                                                             n_inner = as.integer(a$n_inner), quiet = TRUE)))
  hat <- fit_inputs(fit)
  states <- bed_states("suspension", fit)
  sim <- bed_simulator("suspension", fit)
  lib <- suppressMessages(term_library(fit, states = states))
  pr <- propose_terms(fit, lib, simulate = sim, seed = 1)
  top <- pr$term[1]
  X <- attr(pr, "signatures")[, top]
  sites <- W$fit_sites(fit)
  Psi <- W$fit_get(fit, "basis")$Psi
  coefs <- function(curves) unlist(lapply(sites, function(s) drop(curves[[s]] %*% Psi)))
  truth <- as.data.frame(as.list(c(tb$truth$u, 0.5 + tb$truth$delta)))
  y_true <- coefs(lapply(simulate_suspension(truth)$curves, function(m) m[1, ]))
  y_hat <- coefs(lapply(simulate_suspension(hat)$curves, function(m) m[1, ]))
  inp <- W$fit_get(fit, "inputs")
  Z <- matrix(coef(fit)[inp], 1L, dimnames = list(NULL, inp))
  em_hat <- unlist(lapply(sites, function(s)
    W$bank_predict(W$site_bank(W$fit_get(fit, "emulators"), s), W$shift_inputs(fit, s, Z))$mean))
  wbar <- unlist(lapply(sites, function(s) W$fit_get(fit, "wbar")[[s]]))
  dr <- W$fit_draws_matrix(fit)
  keep <- unique(round(seq(1, nrow(dr), length.out = 100)))
  rs <- W$residual_regression_data(fit, dr[keep, ], keep)
  w <- colMeans(1 / (rs$variance + W$bias_level_variances(fit, dr[keep, ])))
  q <- qr(W$proposal_nuisance(fit, FALSE)$X * sqrt(w))
  proj <- function(v) qr.resid(q, v * sqrt(w))
  xt <- proj(X)
  xt <- xt / sqrt(sum(xt^2))
  parts <- list(residual = colMeans(rs$residuals), field_error = wbar - y_true,
                input_error = y_true - y_hat, emulator_error = y_hat - em_hat)
  for (p in names(parts)) {
    v <- proj(parts[[p]])
    rows[[length(rows) + 1L]] <- data.frame(seed = seed, top = top, inclusion = round(pr$inclusion_prob[1], 3),
                                             part = p, energy = round(sum(v^2), 1),
                                             along = round(sum(v * xt), 2),
                                             r2 = round(sum(v * xt)^2 / sum(v^2), 3))
  }
  print(do.call(rbind, utils::tail(rows, 4)), row.names = FALSE)
}
out <- do.call(rbind, rows)
cat("\n")
print(out, row.names = FALSE)
