# Why a mechanism's signature can fail to explain the bias: the calibration
# moves the inputs to take up what it can of the missing effect, and the bias
# left at the calibrated inputs is then not the mechanism's effect.
# For each case, the model without the mechanism is validated as the
# diagnosis tests validate it (testbed_validation(): registered once, one
# chain of 150 draws, one bias variance per level), and printed:
#   dist       rms distance (coded units) of the posterior mean inputs from
#              the truth;
#   lp_true, lp_ls, lp_opt
#              the method's log posterior of the inputs (eq. 18, the noise
#              variances at s^2 / (R - 1), each tau^2 at its mode) at the
#              truth, at the input setting that best fits reality in the
#              simulator itself (least squares, L-BFGS-B from the truth, as
#              bench/check_identifiability.R), and its best value found by
#              L-BFGS-B from the posterior mean, the truth and that setting,
#              each relative to its value at the posterior mean: negative
#              lp_true and lp_ls mean the posterior prefers where it is to
#              both;
#   shifts, with_sig
#              in the simulator itself (no emulators, no registration), the
#              share of the discrepancy of reality from the model at the
#              posterior mean inputs that least squares on the nine shift
#              directions there (simulator gradients) explains, and on those
#              plus the mechanism's signature there: with_sig - shifts is the
#              most the signature can add, the room explain_bias() has;
#   incl       the hidden mechanism's inclusion probability in
#              explain_bias() (signatures at the posterior mean inputs), and
#   top        the leading mechanism.
# On the test bed (seeds 1-5, 20 cases) the posterior preferred its own
# inputs to the truth in every case (lp_true -99 to -819) and to the
# least-squares setting (lp_ls -14 to -408): the calibration's take-up of a
# missing effect is the method's posterior, not a sampler failure (the short
# chains stop short of the mode too, by up to 97 for the damper). For the
# damper and the bump stop the shifts explained 86% to 99% of the
# discrepancy (the damper at seed 1: 43%) and the signature added at most
# 0.06 (0.00 to 0.02 at eight of those ten cases); the four cases where
# explain_bias() missed one of them all had 0.01 or less. For the friction and
# the lift-off the signature added 0.07 to 0.69; the one miss among them
# (the lift-off at seed 2, 0.13) had 0.20.
#   Rscript bench/check_confounding.R [cases=digressive_damper:3,...] [seeds=1:5] [mechanisms=...]
# cases (hidden:seed, comma-separated) overrides seeds x mechanisms.
suppressPackageStartupMessages(library(wavevalid))
source("bench/args.R")
opts <- bench_args(list(cases = "", seeds = "1:5", mechanisms = paste(testbed_mechanisms(), collapse = ",")))
options(wavevalid.quiet = TRUE)
ns <- asNamespace("wavevalid")

cases <- if (nzchar(opts$cases)) {
  kv <- strsplit(strsplit(opts$cases, ",", fixed = TRUE)[[1]], ":", fixed = TRUE)
  data.frame(hidden = vapply(kv, `[`, "", 1), seed = as.integer(vapply(kv, `[`, "", 2)))
} else {
  expand.grid(hidden = strsplit(opts$mechanisms, ",", fixed = TRUE)[[1]], seed = eval(parse(text = opts$seeds)),
              stringsAsFactors = FALSE)
}

# The model's runs at the rows of Z, the two sites side by side.
sim_flat <- function(Z) do.call(cbind, simulate_suspension(as.data.frame(Z))$curves)

# The method's log posterior of the inputs, up to a constant: eq. 18 with the
# noise variances plugged in and each tau^2 at its mode (under its prior).
log_post <- function(fit, spec, z) {
  z <- as.data.frame(as.list(z))[, fit$inputs, drop = FALSE]
  total <- 0
  for (s in names(spec$sites)) {
    d <- spec$sites[[s]]
    pr <- predict(fit$emulators, z, site = s)
    sig <- d$s2 / (d$R - 1)
    r <- d$wbar - drop(pr$mean)
    v0 <- drop(pr$var) + sig / d$R
    for (g in unique(d$group)) {
      k <- d$group == g
      sb <- mean(sig[k])
      f <- function(lt) {
        sum(stats::dnorm(r[k], 0, sqrt(v0[k] + exp(lt)), log = TRUE)) - log(exp(lt) + sb / d$R) + lt
      }
      total <- total + stats::optimize(f, c(-25, 10), maximum = TRUE)$objective
    }
  }
  total
}

one <- function(hidden, seed) {
  v <- ns$testbed_validation(hidden, seed)
  fit <- v$fit
  iu <- fit$iu
  spec <- ns$calibration_spec(fit$emulators, fit$field, iu)
  z_fit <- ns$posterior_mean_inputs(fit)
  z_true <- c(v$tb$truth$u, 0.5 + v$tb$truth$delta)[fit$inputs]
  y_real <- unlist(v$tb$truth$reality, use.names = FALSE)
  loss <- function(z) mean((drop(sim_flat(t(stats::setNames(z, fit$inputs)))) - y_real)^2)
  z_ls <- stats::setNames(stats::optim(z_true, loss, method = "L-BFGS-B", lower = iu$lower, upper = iu$upper,
                                       control = list(maxit = 100))$par, fit$inputs)
  lp <- function(z) log_post(fit, spec, z)
  lp_fit <- lp(z_fit)
  lp_opt <- max(vapply(list(z_fit, z_true, z_ls), function(st) {
    -stats::optim(st, function(z) -lp(stats::setNames(z, fit$inputs)), method = "L-BFGS-B",
                  lower = iu$lower, upper = iu$upper, control = list(maxit = 100))$value
  }, numeric(1)))
  # the discrepancy at the posterior mean inputs, and what linear shifts there
  # and the signature there can explain of it
  y_fit <- drop(sim_flat(t(z_fit)))
  e <- y_real - y_fit
  h <- 1e-3
  Zp <- t(z_fit + diag(h, length(z_fit)))
  Zm <- t(z_fit - diag(h, length(z_fit)))
  colnames(Zp) <- colnames(Zm) <- fit$inputs
  S <- t(sim_flat(Zp) - sim_flat(Zm)) / (2 * h)
  signatures <- ns$testbed_signatures(z_fit)
  sig <- unlist(signatures[[hidden]], use.names = FALSE)
  explained <- function(X) 1 - sum(stats::lm.fit(X, e)$residuals^2) / sum(e^2)
  ex <- as.data.frame(unclass(explain_bias(fit, signatures, n_draws = 50, seed = 1)))
  mech <- ex[!startsWith(ex$candidate, "shift:"), ]
  data.frame(hidden = hidden, seed = seed, dist = sqrt(mean((z_fit - z_true)^2)),
             lp_true = lp(z_true) - lp_fit, lp_ls = lp(z_ls) - lp_fit, lp_opt = lp_opt - lp_fit,
             shifts = explained(S), with_sig = explained(cbind(S, sig)),
             incl = mech$inclusion_prob[mech$candidate == hidden], top = mech$candidate[1])
}

rows <- NULL
for (i in seq_len(nrow(cases))) {
  r <- one(cases$hidden[i], cases$seed[i])
  rows <- rbind(rows, r)
  cat(sprintf("%-21s seed %d  dist %.2f  lp_true %8.1f  lp_ls %8.1f  lp_opt %6.1f  shifts %.2f  with_sig %.2f  incl %.2f  top %s\n",
              r$hidden, r$seed, r$dist, r$lp_true, r$lp_ls, r$lp_opt, r$shifts, r$with_sig, r$incl, r$top))
}
cat("\n")
num <- vapply(rows, is.double, logical(1))
rows[num] <- lapply(rows[num], round, 2)
print(rows, row.names = FALSE)
