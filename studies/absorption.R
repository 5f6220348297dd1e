# Does the calibration absorb a missing mechanism? The model without the
# hidden mechanism can move its own inputs to take up part of the
# mechanism's effect; the bias left at the calibrated inputs is then not the
# mechanism's effect, and no diagnosis can name it from the bias alone.
# Three measures, chosen by `measure` (comma-separated):
#   simulator  in the simulator itself (no emulators, no registration, no
#              noise): reality is the simulator at the true inputs z* with the
#              mechanism at strength 1; the model without it is fitted to
#              reality by least squares over its nine inputs within their
#              ranges (L-BFGS-B from z*, the two sites together). effect: rms
#              of the mechanism's effect at z* (kN); left: the rms no input
#              setting removes; absorbed: 1 - left^2 / effect^2; moved: the
#              inputs the best setting moves by more than 0.05 (coded). With
#              fits = TRUE also bias_rms, the rms posterior mean bias of the
#              case validated as the diagnosis tests validate it
#              (testbed_validation()), next to the same with nothing hidden
#              (floor).
#   posterior  the case validated (testbed_validation()): dist, rms distance
#              (coded) of the posterior mean inputs from the truth; lp_true,
#              lp_ls, lp_opt, the method's log posterior of the inputs (eq.
#              18, the noise variances at s^2 / (R - 1), each tau^2 at its
#              mode) at the truth, at the simulator's least-squares setting,
#              and its best value found by L-BFGS-B from the posterior mean,
#              the truth and that setting, each relative to its value at the
#              posterior mean; shifts and with_sig, in the simulator, the
#              share of the discrepancy of reality from the model at the
#              posterior mean inputs that least squares on the nine shift
#              directions there (simulator gradients) explains, and on those
#              plus the mechanism's signature (with_sig - shifts: the room
#              explain_bias() has); incl and top, the hidden mechanism's
#              inclusion probability in explain_bias() and the leading
#              mechanism.
#   explain    the case validated (pool_levels as given): explain_bias()'s
#              attribute `absorbed` for each signature (the share the
#              parameter shifts span in the regression's metric) next to its
#              inclusion probability.
#   Rscript studies/absorption.R [measure=simulator] [seeds=1] [mechanisms=all] [cases=] [fits=FALSE]
#                                [pool_levels=NULL]
# mechanisms: comma-separated (all: every test-bed mechanism; measure
# explain also takes none); cases (hidden:seed) overrides mechanisms x seeds.
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(measure = "simulator", seeds = "1", mechanisms = "all", cases = "", fits = "FALSE",
                       pool_levels = "NULL"))
if (opt$mechanisms == "all") opt$mechanisms <- paste(testbed_mechanisms(), collapse = ",")
measure <- arg_names(opt$measure)
stopifnot(all(measure %in% c("simulator", "posterior", "explain")))
cases <- arg_cases(opt$cases, opt$mechanisms, opt$seeds)
with_fits <- arg_flag(opt$fits)
pool <- arg_value(opt$pool_levels)
options(wavevalid.quiet = TRUE)

# The model's runs at the rows of Z (with `mechanism`), the two sites side by side.
sim_flat <- function(Z, mechanism = NULL) {
  do.call(cbind, simulate_suspension(as.data.frame(Z), mechanism = mechanism)$curves)
}
bias_rms <- function(hidden, seed) sqrt(mean(bias(testbed_validation(hidden, seed)$fit)$mean^2))

# --- simulator: what the inputs absorb of each mechanism's effect ----------------
absorbed_in_simulator <- function(hidden, seed) {
  tb <- testbed_suspension(seed = seed, hidden = "none")
  iu <- tb$iu
  z_star <- true_inputs(tb)
  on <- as.list(z_star)
  on[[paste0("s_", hidden)]] <- 1
  y_real <- drop(sim_flat(as.data.frame(on), hidden))
  y0 <- drop(sim_flat(t(z_star)))
  loss <- function(z) mean((drop(sim_flat(t(stats::setNames(z, iu$name)))) - y_real)^2)
  grad <- function(z) {
    h <- 1e-4
    Z <- rbind(t(z + diag(h, length(z))), t(z - diag(h, length(z))))
    colnames(Z) <- iu$name
    Y <- sim_flat(Z)
    k <- length(z)
    vapply(seq_len(k), function(j) (mean((Y[j, ] - y_real)^2) - mean((Y[k + j, ] - y_real)^2)) / (2 * h), 1)
  }
  best <- stats::optim(z_star, loss, grad, method = "L-BFGS-B", lower = iu$lower, upper = iu$upper,
                       control = list(maxit = 200))
  effect <- sqrt(mean((y_real - y0)^2))
  left <- sqrt(best$value)
  moved <- best$par - z_star
  big <- abs(moved) > 0.05
  data.frame(seed = seed, mechanism = hidden, effect = effect, left = left, absorbed = 1 - left^2 / effect^2,
             bias_rms = if (with_fits) bias_rms(hidden, seed) else NA_real_,
             floor = if (with_fits) bias_rms("none", seed) else NA_real_,
             moved = if (any(big)) paste(sprintf("%s%+.2f", iu$name[big], moved[big]), collapse = " ") else "-")
}

# --- posterior: where the calibration leaves the inputs --------------------------
# The method's log posterior of the inputs z, up to a constant: eq. 18 with
# the noise variances at s^2 / (R - 1) and each tau^2 at its mode under its
# prior; s^2 the sum of squared deviations of the replicates' coefficients.
log_post <- function(fit, z) {
  z <- as.data.frame(as.list(z))[, fit$inputs, drop = FALSE]
  total <- 0
  for (s in names(fit$wb)) {
    W <- wavelet_coef(fit$basis, fit$field$curves[[s]])
    R <- nrow(W)
    wbar <- colMeans(W)
    sig <- colSums(sweep(W, 2L, wbar)^2) / (R - 1)
    group <- fit$bias_group[[s]]
    pr <- predict(fit$emulators, z, site = s)
    r <- wbar - drop(pr$mean)
    v0 <- drop(pr$var) + sig / R
    for (g in unique(group)) {
      k <- group == g
      sb <- mean(sig[k])
      f <- function(lt) sum(stats::dnorm(r[k], 0, sqrt(v0[k] + exp(lt)), log = TRUE)) - log(exp(lt) + sb / R) + lt
      total <- total + stats::optimize(f, c(-25, 10), maximum = TRUE)$objective
    }
  }
  total
}

posterior_case <- function(hidden, seed) {
  v <- testbed_validation(hidden, seed)
  fit <- v$fit
  iu <- fit$iu
  z_fit <- coef(fit)
  z_true <- true_inputs(v$tb, fit$inputs)
  y_real <- unlist(v$tb$truth$reality, use.names = FALSE)
  loss <- function(z) mean((drop(sim_flat(t(stats::setNames(z, fit$inputs)))) - y_real)^2)
  z_ls <- stats::setNames(stats::optim(z_true, loss, method = "L-BFGS-B", lower = iu$lower, upper = iu$upper,
                                       control = list(maxit = 100))$par, fit$inputs)
  lp <- function(z) log_post(fit, z)
  lp_fit <- lp(z_fit)
  lp_opt <- max(vapply(list(z_fit, z_true, z_ls), function(st) {
    -stats::optim(st, function(z) -lp(stats::setNames(z, fit$inputs)), method = "L-BFGS-B",
                  lower = iu$lower, upper = iu$upper, control = list(maxit = 100))$value
  }, numeric(1)))
  # the discrepancy at the posterior mean inputs, and what linear shifts there
  # and the signature there explain of it
  e <- y_real - drop(sim_flat(t(z_fit)))
  h <- 1e-3
  Zp <- t(z_fit + diag(h, length(z_fit)))
  Zm <- t(z_fit - diag(h, length(z_fit)))
  colnames(Zp) <- colnames(Zm) <- fit$inputs
  S <- t(sim_flat(Zp) - sim_flat(Zm)) / (2 * h)
  signatures <- testbed_signatures(z_fit)
  sig <- unlist(signatures[[hidden]], use.names = FALSE)
  explained <- function(X) 1 - sum(stats::lm.fit(X, e)$residuals^2) / sum(e^2)
  ex <- as.data.frame(unclass(explain_bias(fit, signatures, n_draws = 50, seed = 1)))
  mech <- ex[!startsWith(ex$candidate, "shift:"), ]
  data.frame(hidden = hidden, seed = seed, dist = sqrt(mean((z_fit - z_true)^2)),
             lp_true = lp(z_true) - lp_fit, lp_ls = lp(z_ls) - lp_fit, lp_opt = lp_opt - lp_fit,
             shifts = explained(S), with_sig = explained(cbind(S, sig)),
             incl = mech$inclusion_prob[mech$candidate == hidden], top = mech$candidate[1])
}

# --- explain: what explain_bias() reports as absorbed ----------------------------
explain_case <- function(hidden, seed) {
  fit <- testbed_validation(hidden, seed, pool_levels = pool)$fit
  ex <- explain_bias(fit, testbed_signatures(coef(fit)), n_draws = 50, seed = 1)
  ab <- attr(ex, "absorbed")
  ab$inclusion_prob <- ex$inclusion_prob[match(ab$candidate, ex$candidate)]
  cbind(seed = seed, hidden = hidden, ab[c("candidate", "absorbed", "inclusion_prob", "inputs")])
}

show <- function(rows) {
  num <- vapply(rows, is.double, logical(1))
  rows[num] <- lapply(rows[num], round, 3)
  print(rows, row.names = FALSE)
}
run_cases <- function(f) {
  do.call(rbind, lapply(seq_len(nrow(cases)), function(i) {
    r <- f(cases$hidden[i], cases$seed[i])
    print(r, row.names = FALSE, digits = 3)
    r
  }))
}
if ("simulator" %in% measure) {
  cat("== simulator: the share of each mechanism's effect the model's inputs absorb\n")
  rows <- run_cases(absorbed_in_simulator)
  if (!with_fits) rows$bias_rms <- rows$floor <- NULL
  cat("\n")
  show(rows)
}
if ("posterior" %in% measure) {
  cat("\n== posterior: the calibration's inputs against the truth and the least-squares setting\n")
  show(run_cases(posterior_case))
}
if ("explain" %in% measure) {
  cat("\n== explain: explain_bias()'s absorbed share (inclusion probability) by candidate\n")
  rows <- run_cases(explain_case)
  cat("\nmean absorbed share of each signature over the cases:\n")
  print(round(tapply(rows$absorbed, rows$candidate, mean), 2))
}
