# Which mechanism is missing, told by re-validating the model with each
# candidate mechanism instead of regressing the bias on fixed signature curves.
# For one test-bed case (hidden mechanism, seed): the model without any
# mechanism is validated on condition A (66 runs, the tests' settings) as in
# check_diagnosis.R; then for each mechanism m of the test bed, the model with
# m, its strength s_m an extra calibration input on [0, 1], is simulated at a
# maximin design of 66 points, its emulators fitted on the same wavelet basis,
# and it is calibrated on the same registered field data. Each model is scored
# by the largest log posterior over its inputs with every tau2 profiled
# (sigma2 at its posterior median): lp_free with s_m free, lp_off with s_m
# fixed at 0 (the same emulators, the mechanism switched off). The nested
# difference lp_free - lp_off is free of the differences between emulators
# fitted to different designs; lp_free alone is not (a mechanism whose strength
# goes to zero can still score tens of log units above the model without it).
# Also printed: the posterior mean strength and the root mean square of the
# posterior mean bias.
#   Rscript bench/check_revalidation.R [hidden=digressive_damper] [seed=3] [n_draws=150] [n_inner=20]
suppressPackageStartupMessages(library(wavevalid))
args <- commandArgs(trailingOnly = TRUE)
hidden <- if (length(args) >= 1) args[1] else "digressive_damper"
seed <- if (length(args) >= 2) as.integer(args[2]) else 3L
n_draws <- if (length(args) >= 3) as.integer(args[3]) else 150L
n_inner <- if (length(args) >= 4) as.integer(args[4]) else 20L
options(wavevalid.quiet = TRUE)
clock <- function() as.numeric(proc.time()[["elapsed"]])

v <- wavevalid:::testbed_validation(hidden, seed, n_draws = n_draws, n_inner = n_inner)
tb <- v$tb
field <- v$field
basis <- v$basis
base <- v$fit
sigma2 <- lapply(base$sigma2, function(m) apply(m, 2, stats::median))

# Log posterior at inputs z (the emulators' units), every tau2 at its mode
# under its prior 1 / (tau2 + c_j).
log_post <- function(fit, z) {
  tot <- 0
  for (s in names(fit$wb)) {
    pr <- wavevalid:::gasp_bank_predict_cpp(fit$emulators$banks[[s]], matrix(z, 1))
    e <- fit$wbar[[s]] - pr$mean[1, ]
    S <- pr$var[1, ] + sigma2[[s]] / fit$n_rep[[s]]
    g <- fit$bias_group[[s]]
    for (j in unique(g)) {
      i <- g == j
      cj <- mean(sigma2[[s]][i] / fit$n_rep[[s]])
      f <- function(lt) sum(stats::dnorm(e[i], 0, sqrt(S[i] + exp(lt)), log = TRUE)) - log(exp(lt) + cj) + lt
      tot <- tot + stats::optimize(f, c(log(cj) - 30, log(max(e[i]^2) + cj) + 5), maximum = TRUE)$objective
    }
  }
  p <- fit$prior_iu[match(fit$inputs, fit$prior_iu$name), ]
  v <- p$type == "variation"
  tot + sum(stats::dnorm(z[v], p$nominal[v], p$prior_sd[v], log = TRUE))
}
# Largest log posterior from six starts among the draws `D` (columns named),
# the inputs in `fixed` held at their values.
best <- function(fit, D, fixed = NULL) {
  p <- fit$prior_iu[match(fit$inputs, fit$prior_iu$name), ]
  free <- setdiff(fit$inputs, names(fixed))
  k <- match(free, p$name)
  lo <- ifelse(p$type[k] == "calibration", p$lower[k], -Inf)
  hi <- ifelse(p$type[k] == "calibration", p$upper[k], Inf)
  full <- function(x) c(stats::setNames(x, free), fixed)[fit$inputs]
  starts <- D[unique(round(seq(1, nrow(D), length.out = 6))), free, drop = FALSE]
  res <- lapply(seq_len(nrow(starts)), function(r) {
    stats::optim(pmin(pmax(starts[r, ], lo), hi), function(x) -log_post(fit, full(x)),
                 method = "L-BFGS-B", lower = lo, upper = hi, control = list(maxit = 200))
  })
  -min(vapply(res, `[[`, 0, "value"))
}
bias_rms <- function(fit) sqrt(mean(bias(fit)$mean^2))

D0 <- as.matrix(base$draws)
rows <- list(data.frame(model = "none", lp_free = best(base, D0), lp_off = NA, s_mean = NA,
                        bias_rms = bias_rms(base), seconds = NA))
iu <- tb$iu
for (m in testbed_mechanisms()) {
  t0 <- clock()
  s_name <- paste0("s_", m)
  iu_m <- iu_add(iu, s_name, lower = 0, upper = 1, nominal = 0.5)
  runs_m <- simulate_suspension(design_maximin(iu_m, 66, seed = 2), mechanism = m)
  em_m <- suppressWarnings(fit_emulators(runs_m, basis))
  fit_m <- suppressWarnings(calibrate(em_m, field, iu_m, n_draws = n_draws, n_inner = n_inner, chains = 1,
                                      seed = 1, quiet = TRUE))
  Dm <- as.matrix(fit_m$draws)
  D0m <- cbind(D0[, iu$name], stats::setNames(rep(0, nrow(D0)), s_name))
  colnames(D0m)[ncol(D0m)] <- s_name
  rows[[m]] <- data.frame(model = m, lp_free = best(fit_m, rbind(Dm[, fit_m$inputs], D0m[, fit_m$inputs])),
                          lp_off = best(fit_m, D0m, fixed = stats::setNames(0, s_name)),
                          s_mean = mean(Dm[, s_name]), bias_rms = bias_rms(fit_m), seconds = clock() - t0)
}
res <- do.call(rbind, rows)
res$nested <- res$lp_free - res$lp_off
rownames(res) <- NULL
cat(sprintf("hidden %s, seed %d: the model with each mechanism re-validated\n", hidden, seed))
print(res, digits = 4)
