# Why re-validated mechanisms are claimed with nothing hidden on the
# suspension test bed (seed 1) after a second wave of 30 runs at
# design_posterior(): the model with the mechanism (its strength a
# calibration input on [0, 1]) is re-validated on 66 maximin runs, plus, with
# reuse = TRUE, the 96 runs without it at strength 0; with registered = TRUE
# the runs are registered to the mean of the second wave like the field.
# Prints the strength's posterior quantiles, its log Bayes factor and
# inclusion probability from explain_bias(), and the rms gap (kN, per site)
# between the fit's and the refit's emulated curves at the fit's posterior
# mean inputs with the strength at 0.
#   Rscript bench/check_refit_strength.R registered=TRUE reuse=TRUE mechanisms=digressive_damper
suppressPackageStartupMessages(library(wavevalid))
options(wavevalid.quiet = TRUE)
source("bench/args.R")
opts <- list(registered = "TRUE", reuse = "TRUE", mechanisms = "digressive_damper")
opts <- bench_args(opts)
rr <- as.logical(opts$registered)
reuse <- as.logical(opts$reuse)
tb <- testbed_suspension(seed = 1, hidden = "none")
reg <- function(x, reference) register_curves(x, reference, tb$windows, knots_every = 2)
val <- function(runs, field, iu) {
  em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, field)))
  suppressWarnings(calibrate(em, field, iu, n_draws = 150, n_inner = 20, chains = 1, seed = 1, quiet = TRUE))
}
fit0 <- val(tb$A$runs, reg(tb$A$field, tb$A$runs), tb$iu)
wave <- simulate_suspension(design_posterior(fit0, 30, seed = 1))
all_runs <- c(tb$A$runs, wave)
field <- reg(tb$A$field, wave)
runs <- if (rr) reg(all_runs, wave) else all_runs
fit <- val(runs, field, tb$iu)
for (m in strsplit(opts$mechanisms, ",")[[1]]) {
  s <- paste0("s_", m)
  iu_m <- iu_add(tb$iu, s, lower = 0, upper = 1, nominal = 0.5)
  r <- simulate_suspension(design_maximin(iu_m, 66L, seed = 2), mechanism = m)
  if (reuse) {
    off <- all_runs
    off$design[[s]] <- 0
    r <- c(off, r)
  }
  if (rr) r <- reg(r, wave)
  em <- suppressWarnings(fit_emulators(r, fit$basis))
  rf <- suppressWarnings(calibrate(em, fit$field, iu_m, n_draws = 150, n_inner = 20, chains = 1, seed = 1, quiet = TRUE))
  d <- as.matrix(rf$draws)
  ex <- explain_bias(fit, stats::setNames(list(rf), m), n_draws = 50)
  z <- wavevalid:::posterior_mean_inputs(fit)
  zz <- c(z, stats::setNames(0, s))[rf$inputs]
  gap <- sapply(names(fit$wb), function(site) {
    a <- wavevalid:::gasp_bank_predict_cpp(fit$emulators$banks[[site]], matrix(z[fit$inputs], 1, dimnames = list(NULL, fit$inputs)))$mean
    b <- wavevalid:::gasp_bank_predict_cpp(rf$emulators$banks[[site]], matrix(zz, 1, dimnames = list(NULL, rf$inputs)))$mean
    sqrt(mean((fit$basis$Psi %*% drop(a - b))^2))
  })
  cat(sprintf("  emulator gap (rms kN) fit vs refit at strength 0: %s\n", paste(signif(gap, 3), collapse = "/")))
  cat(sprintf("%s runs registered %s, reuse %s: strength q05/q50/q95 %s; log_bf %.1f; inclusion %.3f\n", m, rr, reuse,
              paste(signif(stats::quantile(d[, s], c(.05, .5, .95)), 2), collapse = "/"),
              attr(ex, "log_bf")[[1]], ex$inclusion_prob[1]))
}
