# How much of each hidden mechanism's effect the model without it can absorb
# by moving its own inputs, on the suspension test bed (simulator runs only, no
# emulators, no registration, no noise). For each seed and mechanism, reality
# is the simulator at the true inputs z* with the mechanism at strength 1; the
# model without it is fitted to reality by least squares over its nine inputs
# within their ranges (L-BFGS-B from z*, the two sites together). Printed per
# case: `effect`, the rms of the mechanism's effect at z* (kN); `left`, the rms
# that no input setting removes (kN); `absorbed`, the share of the effect's
# energy that the best input setting takes up (1 - left^2 / effect^2);
# `moved`, the inputs the best setting moves by more than 0.05 (coded units).
# A mechanism whose effect the inputs absorb almost whole leaves the bias
# little to carry: no diagnosis can then name it from the bias alone.
# With fits=TRUE each case is also validated as the diagnosis tests validate
# it (testbed_validation(): registered once, one chain of 150 draws) and
# `bias_rms` gives compare_validations()'s bias_rms of that fit (kN), next to
# the same figure with nothing hidden at that seed (`floor`): the bias that
# registration and emulator error leave when the model lacks nothing.
#   Rscript bench/check_identifiability.R seeds=1:5 fits=FALSE
suppressPackageStartupMessages(library(wavevalid))
source("bench/args.R")
opts <- bench_args(list(seeds = "1:5", mechanisms = paste(testbed_mechanisms(), collapse = ","), fits = "FALSE"))
with_fits <- as.logical(opts$fits)
options(wavevalid.quiet = TRUE)
ns <- asNamespace("wavevalid")
bias_rms <- function(hidden, seed) {
  fit <- ns$testbed_validation(hidden, seed)$fit
  b <- bias(fit)
  sqrt(mean(b$mean^2))
}
seeds <- eval(parse(text = opts$seeds))
mechanisms <- strsplit(opts$mechanisms, ",", fixed = TRUE)[[1]]

sim_flat <- function(Z, mechanism = NULL) {
  runs <- simulate_suspension(as.data.frame(Z), mechanism = mechanism)
  do.call(cbind, runs$curves)
}

rows <- NULL
for (seed in seeds) {
  tb <- testbed_suspension(seed = seed, hidden = "none")
  iu <- tb$iu
  z_star <- c(tb$truth$u, 0.5 + tb$truth$delta)[iu$name]
  floor_rms <- if (with_fits) bias_rms("none", seed) else NA_real_
  for (m in mechanisms) {
    on <- as.list(z_star)
    on[[paste0("s_", m)]] <- 1
    y_real <- drop(sim_flat(as.data.frame(on), m))
    y0 <- drop(sim_flat(t(z_star)))
    loss <- function(z) mean((drop(sim_flat(t(stats::setNames(z, iu$name)))) - y_real)^2)
    grad <- function(z) {
      h <- 1e-4
      Z <- rbind(t(z + diag(h, length(z))), t(z - diag(h, length(z))))
      colnames(Z) <- iu$name
      Y <- sim_flat(Z)
      k <- length(z)
      vapply(seq_len(k), function(j) {
        (mean((Y[j, ] - y_real)^2) - mean((Y[k + j, ] - y_real)^2)) / (2 * h)
      }, numeric(1))
    }
    opt <- stats::optim(z_star, loss, grad, method = "L-BFGS-B", lower = iu$lower, upper = iu$upper,
                        control = list(maxit = 200))
    effect <- sqrt(mean((y_real - y0)^2))
    left <- sqrt(opt$value)
    moved <- opt$par - z_star
    big <- abs(moved) > 0.05
    rows <- rbind(rows, data.frame(
      seed = seed, mechanism = m, effect = effect, left = left, absorbed = 1 - left^2 / effect^2,
      bias_rms = if (with_fits) bias_rms(m, seed) else NA_real_, floor = floor_rms,
      moved = if (any(big)) paste(sprintf("%s%+.2f", iu$name[big], moved[big]), collapse = " ") else "-"
    ))
    cat(sprintf("seed %d %-21s effect %.3f  left %.3f  absorbed %.2f  bias_rms %.3f (floor %.3f)  %s\n", seed,
                m, effect, left, 1 - left^2 / effect^2, rows$bias_rms[nrow(rows)], floor_rms, rows$moved[nrow(rows)]))
  }
}
cat("\n")
num <- c("effect", "left", "absorbed", "bias_rms", "floor")
rows[num] <- lapply(rows[num], round, 3)
if (!with_fits) rows$bias_rms <- rows$floor <- NULL
print(rows, row.names = FALSE)
