# How often the diagnosis gets it right on the suspension test bed, over
# several test-bed seeds (each seed draws new manufacturing variations, field
# noise and jitter, and so new field data). For every hidden mechanism and for
# hidden = "none", per seed: the model without the mechanism is validated on
# the test bed's condition A (66 runs), where_fails() and explain_bias() (all
# mechanism signatures at the posterior mean inputs, plus the automatic
# shifts) are run, and the two diagnosis criteria are checked:
#   where: with a mechanism, the flagged intervals cover more than 20% of the
#          grid points where it acts (its effect above 10% of its peak) at
#          every site; with none, no flagged interval is longer than 3 grid
#          steps;
#   which: with a mechanism, it is ranked first among the mechanisms with
#          inclusion_prob >= 0.9 and every other mechanism is below 0.5; with
#          none, no candidate (shifts included) reaches 0.5.
# refine = TRUE locates the landmarks between grid points; knots_every is
# register_curves()'s (NULL: landmarks only); with register_runs = TRUE the
# model runs are registered to the same reference as the field data (the mean
# of the runs) before the wavelet decomposition and the emulators; pool_levels
# is calibrate()'s ("NULL" or e.g. "0:3").
# reference = "field" registers the field replicates to their own pointwise
# mean instead of the mean of the model runs; "field2" to the mean of the
# replicates so registered; "posterior" registers them first to the mean of
# the runs, calibrates, then registers them again to one simulator run at the
# posterior mean inputs and validates anew (emulators and calibration on the
# new registration); "unwarped" replaces the registered replicates by the
# same kind of noise on reality without time warps (a perfect registration).
# tolerance is where_fails()'s, in kN (the criteria are then judged on the
# intervals beyond it). Columns: gap, the
# smallest tolerance at which nothing is flagged (the largest distance of
# the whole-curve band from zero), and effect, the peak of the hidden
# mechanism's effect (smaller site); first_share and decoy_share, the
# share_explained of the first mechanism and of the most probable other one;
# eta, the median tempering power of explain_bias() (segments is its argument,
# "NULL" for no tempering). knots_to is register_curves()'s: the knots between
# the windows fitted to the reference or to the replicates' own consensus.
# registration_variance is calibrate()'s: the spread of the landmark times
# over the runs enters the variance of the registered field mean.
# rescale = TRUE widens the emulators' variances by rescale_emulators() from
# 30 held-out runs (a maximin design over the I/U ranges).
# signatures_at is where the mechanism signatures given to explain_bias() are
# simulated: "posterior" (the posterior mean inputs), "nominal" (every input
# at its nominal value) or "unpiled" (the posterior mean, except the inputs
# whose posterior piles up at a bound, at their nominal values) or "both" (the
# posterior mean and the nominal inputs, given as two versions of each
# mechanism through explain_bias()'s effect argument). positive is
# explain_bias()'s: the mechanisms' amplitudes constrained to be
# non-negative.
# temper is calibrate()'s: the likelihood raised to that power.
#   Rscript bench/check_diagnosis.R [seeds=1:5] [refine=FALSE] [n_draws=150] [n_inner=20] [cores=2]
#                                   [knots_every=2] [register_runs=FALSE] [pool_levels=NULL]
#                                   [reference=runs] [tolerance=0] [segments=64] [knots_to=reference]
#                                   [registration_variance=FALSE] [rescale=FALSE]
#                                   [signatures_at=posterior|nominal|unpiled|both] [positive=TRUE]
#                                   [inform_levels=NULL] [temper=1]
# seeds as "1:5" or "1,3,7".
suppressPackageStartupMessages(library(wavevalid))
args <- commandArgs(trailingOnly = TRUE)
seeds <- if (length(args) >= 1) eval(parse(text = paste0("c(", args[1], ")"))) else 1:5
refine <- if (length(args) >= 2) as.logical(args[2]) else FALSE
n_draws <- if (length(args) >= 3) as.integer(args[3]) else 150L
n_inner <- if (length(args) >= 4) as.integer(args[4]) else 20L
cores <- if (length(args) >= 5) as.integer(args[5]) else 2L
knots_every <- if (length(args) >= 6) args[6] else "2"
knots_every <- if (knots_every == "NULL") NULL else as.numeric(knots_every)
register_runs <- if (length(args) >= 7) as.logical(args[7]) else FALSE
pool_levels <- if (length(args) >= 8) eval(parse(text = args[8])) else NULL
reference <- if (length(args) >= 9) match.arg(args[9], c("runs", "field", "field2", "posterior", "unwarped")) else "runs"
tolerance <- if (length(args) >= 10) as.numeric(args[10]) else 0
segments <- if (length(args) >= 11 && args[11] == "NULL") NULL else if (length(args) >= 11) as.integer(args[11]) else 64L
knots_to <- if (length(args) >= 12) match.arg(args[12], c("reference", "replicates")) else "reference"
reg_var <- if (length(args) >= 13) as.logical(args[13]) else FALSE
rescale <- if (length(args) >= 14) as.logical(args[14]) else FALSE
signatures_at <- if (length(args) >= 15) match.arg(args[15], c("posterior", "nominal", "unpiled", "both")) else "posterior"
positive <- if (length(args) >= 16) as.logical(args[16]) else TRUE
inform_levels <- if (length(args) >= 17) eval(parse(text = args[17])) else NULL
temper <- if (length(args) >= 18) as.numeric(args[18]) else 1
options(wavevalid.quiet = TRUE)

one <- function(hidden, seed) {
  t0 <- proc.time()[["elapsed"]]
  tb <- testbed_suspension(seed = seed, hidden = hidden)
  features <- if (hidden == "tire_liftoff") "max" else c("min", "max")
  runs <- tb$A$runs
  ref <- if (reference %in% c("runs", "posterior", "unwarped")) runs else lapply(tb$A$field$curves, colMeans)
  reg <- function(f) register_curves(f, ref, tb$windows, features = features, knots_every = knots_every,
                                     refine = refine, knots_to = knots_to)
  if (reference == "field2") ref <- lapply(reg(tb$A$field)$curves, colMeans)
  field <- reg(tb$A$field)
  if (reference == "unwarped") field <- wavevalid:::unwarped_field(tb, seed)
  check <- if (rescale) simulate_suspension(design_maximin(tb$iu, 30, nominal = FALSE, seed = 9))
  emulate <- function(runs, field) {
    em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, field)))
    if (rescale) em <- suppressWarnings(rescale_emulators(em, check))
    em
  }
  calib <- function(em, field) {
    suppressWarnings(calibrate(em, field, tb$iu, n_draws = n_draws, n_inner = n_inner, chains = 1,
                               seed = 1, pool_levels = pool_levels, registration_variance = reg_var,
                               inform_levels = inform_levels, temper = temper, quiet = TRUE))
  }
  if (reference == "posterior") {
    first <- calib(emulate(runs, field), field)
    ref <- simulate_suspension(as.data.frame(as.list(colMeans(as.matrix(first$draws))[first$inputs])))
    field <- reg(tb$A$field)
  }
  if (register_runs) runs <- reg(runs)
  fit <- calib(emulate(runs, field), field)
  z_hat <- colMeans(as.matrix(fit$draws))[fit$inputs]
  nominal <- stats::setNames(tb$iu$nominal, tb$iu$name)[fit$inputs]
  z_sig <- if (signatures_at == "nominal") nominal else z_hat
  if (signatures_at == "unpiled") {
    piled <- intersect(fit$flags$boundary$input, fit$inputs)
    z_sig[piled] <- nominal[piled]
  }
  if (signatures_at == "both") {
    sp <- testbed_signatures(z_hat)
    sn <- testbed_signatures(nominal)
    cand <- c(stats::setNames(sp, paste0(names(sp), "@calibrated")), stats::setNames(sn, paste0(names(sn), "@nominal")))
    ex <- explain_bias(fit, cand, effect = rep(names(sp), 2), n_draws = 50, seed = 1, segments = segments,
                       positive = positive)
  } else {
    ex <- explain_bias(fit, testbed_signatures(z_sig), n_draws = 50, seed = 1, segments = segments,
                       positive = positive)
  }
  eta <- stats::median(attr(ex, "eta"))
  ex <- as.data.frame(unclass(ex))
  fails <- where_fails(fit, tolerance = tolerance)
  gap <- max(attr(fails, "credible")$credible_bias)
  t <- fit$basis$t
  steps <- (fails$end - fails$start) / diff(t[1:2])
  mech <- ex[!startsWith(ex$candidate, "shift:"), ]
  out <- data.frame(hidden = hidden, seed = seed, intervals = nrow(fails), longest = round(max(c(0, steps))),
                    overlap = NA_real_, first = mech$candidate[1], first_prob = mech$inclusion_prob[1],
                    decoy_max = NA_real_, any_max = max(ex$inclusion_prob), first_share = mech$share_explained[1],
                    decoy_share = NA_real_, eta = eta, gap = gap, effect = NA_real_,
                    seconds = NA_real_)
  if (hidden == "none") {
    out$where_ok <- all(steps <= 3)
    out$which_ok <- all(ex$inclusion_prob < 0.5)
  } else {
    truth <- c(tb$truth$u, 0.5 + tb$truth$delta)[fit$inputs]
    effect <- testbed_signatures(truth, hidden)[[1]]
    overlap <- flagged_share(fails, effect)
    out$overlap <- min(overlap)
    out$effect <- min(vapply(effect, function(e) max(abs(e)), numeric(1)))
    decoys <- mech[mech$candidate != hidden, ]
    out$decoy_max <- decoys$inclusion_prob[1]
    out$decoy_share <- decoys$share_explained[1]
    out$where_ok <- all(overlap > 0.2)
    out$which_ok <- mech$candidate[1] == hidden && mech$inclusion_prob[1] >= 0.9 && out$decoy_max < 0.5
  }
  out$seconds <- round(proc.time()[["elapsed"]] - t0)
  out
}

grid <- expand.grid(hidden = c("none", testbed_mechanisms()), seed = seeds, stringsAsFactors = FALSE)
cat(sprintf("diagnosis on the test bed: %d seeds, refine = %s, knots_every = %s, register_runs = %s, pool_levels = %s, reference = %s, tolerance = %g, segments = %s, knots_to = %s, registration_variance = %s, rescale = %s, signatures at %s, %d x %d draws, 1 chain\n",
            length(seeds), refine, format(knots_every), register_runs, deparse(pool_levels), reference, tolerance,
            deparse(segments), knots_to, reg_var, rescale, signatures_at, n_draws, n_inner))
cat(sprintf("explain_bias(positive = %s), calibrate(inform_levels = %s, temper = %g)\n", positive,
            deparse(inform_levels), temper))
res <- parallel::mclapply(seq_len(nrow(grid)), function(i) one(grid$hidden[i], grid$seed[i]),
                          mc.cores = cores, mc.preschedule = FALSE)
bad <- vapply(res, inherits, logical(1), "try-error")
if (any(bad)) stop("failed: ", paste(vapply(res[bad], as.character, ""), collapse = "\n"))
res <- do.call(rbind, res)
res <- res[order(res$hidden, res$seed), ]
num <- vapply(res, is.double, logical(1))
res[num] <- lapply(res[num], round, 2)
print(res, row.names = FALSE)
cat("\nshare of seeds meeting each criterion\n")
rate <- aggregate(cbind(where = where_ok, which = which_ok, both = where_ok & which_ok) ~ hidden, res, mean)
print(rate, row.names = FALSE)
