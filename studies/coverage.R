# Are the emulators honest, and do the posterior and the bands cover the
# truth? On the suspension test bed, chosen by `measure` (comma-separated):
#   inputs  with nothing hidden (the model at the true inputs is reality), per
#           seed, the emulators as fitted and with their variances rescaled by
#           rescale_emulators() on n_check held-out runs (a maximin design on
#           the I/U ranges): z_max, the largest |posterior mean - truth| /
#           posterior sd over the inputs; cover90, the share of the inputs
#           whose true value lies in the central 90% posterior interval; err,
#           the rms of posterior mean - truth (coded); sd, the mean posterior
#           sd; longest, the longest interval where_fails() flags (grid
#           steps); credible, the largest credible bias (kN); heldout, the rms
#           studentised error of the emulators' coefficients at 20 other runs
#           near the truth (sd 0.03 coded). field = registered: the
#           replicates registered to the runs (knots every 2 time units);
#           unwarped: the truth plus the same kind of noise without time
#           warps, a perfect registration, so that what is left is the
#           emulators' error. inform_levels is calibrate()'s.
#   bands   test bed `seed` (one seed) with `hidden`, calibrated with two
#           chains of n_draws x n_inner: the 90% reality band's coverage of the
#           noise-free truth (registered, and its projection on the basis),
#           the true inputs inside their 95% intervals, the median band widths
#           by prediction type, condition B's held-out replicates inside the
#           new_nominal band, the added-mass run inside the added_load band,
#           and with a mechanism hidden, where the bias band excludes zero.
#           With n_runs the emulators are fitted to a maximin design of that
#           many runs instead of condition A's 66.
#   Rscript studies/coverage.R [measure=inputs] [seeds=1] [field=registered] [n_check=30] [n_draws=150]
#                              [n_inner=20] [inform_levels=NULL] [hidden=none] [n_runs=NA] [engine=gasp_level]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(measure = "inputs", seeds = "1", field = "registered", n_check = "30", n_draws = "150",
                       n_inner = "20", inform_levels = "NULL", hidden = "none", n_runs = "NA",
                       engine = "gasp_level"))
measure <- arg_names(opt$measure)
stopifnot(all(measure %in% c("inputs", "bands")), opt$field %in% c("registered", "unwarped"))
seeds <- arg_numbers(opt$seeds)
n_check <- as.integer(opt$n_check)
n_draws <- as.integer(opt$n_draws)
n_inner <- as.integer(opt$n_inner)
inform_levels <- arg_value(opt$inform_levels)
options(wavevalid.quiet = TRUE)

# --- inputs: the posterior of the inputs against the truth ------------------------
# rms studentised error of the emulators' coefficients at `new_runs`, the
# coefficients whose likelihood is flat left out
heldout_rms <- function(em, new_runs) {
  W <- wavelet_coef(em$basis, new_runs)
  r <- unlist(lapply(names(em$banks), function(s) {
    pr <- predict(em, new_runs$design[em$inputs], site = s)
    res <- (W[[s]] - pr$mean) / sqrt(pr$var)
    res[, !is.finite(em$params$loglik[em$params$site == s])] <- NA_real_
    res
  }))
  sqrt(mean(r[is.finite(r)]^2))
}

inputs_case <- function(seed) {
  tb <- testbed_suspension(seed = seed, hidden = "none")
  runs <- tb$A$runs
  field <- if (opt$field == "registered") {
    register_curves(tb$A$field, runs, tb$windows, knots_every = 2)
  } else {
    testbed_unwarped_field(tb, seed)
  }
  em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, field), engine = opt$engine))
  check <- simulate_suspension(design_maximin(tb$iu, n_check, nominal = FALSE, seed = 9))
  truth <- true_inputs(tb, em$inputs)
  near <- withr::with_seed(seed + 100, as.data.frame(t(replicate(20, pmin(pmax(
    truth + stats::rnorm(length(truth), sd = 0.03), 0.01), 0.99)))))
  near_runs <- simulate_suspension(near)
  do.call(rbind, lapply(c("as fitted", "rescaled"), function(setting) {
    e <- if (setting == "rescaled") rescale_emulators(em, check) else em
    fit <- suppressWarnings(calibrate(e, field, tb$iu, chains = 1, seed = 1,
                                      bias = bias_control(inform_levels = inform_levels),
                                      sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, quiet = TRUE)))
    d <- as.matrix(fit$draws)[, fit$inputs]
    m <- colMeans(d)
    s <- apply(d, 2, stats::sd)
    lo <- apply(d, 2, stats::quantile, 0.05)
    hi <- apply(d, 2, stats::quantile, 0.95)
    wf <- where_fails(fit)
    data.frame(seed = seed, emulators = setting, z_max = max(abs(m - truth) / s),
               cover90 = mean(truth >= lo & truth <= hi), err = sqrt(mean((m - truth)^2)), sd = mean(s),
               longest = longest_steps(wf), credible = max(attr(wf, "credible")$credible_bias),
               heldout = heldout_rms(e, near_runs))
  }))
}

if ("inputs" %in% measure) {
  cat(sprintf("== inputs (nothing hidden): %d seeds, field %s, %d held-out runs for the rescaling, %d x %d draws, inform_levels = %s\n",
              length(seeds), opt$field, n_check, n_draws, n_inner, deparse(inform_levels)))
  res <- do.call(rbind, lapply(seeds, inputs_case))
  num <- vapply(res, is.double, logical(1))
  res[num] <- lapply(res[num], signif, 3)
  print(res[order(res$emulators, res$seed), ], row.names = FALSE)
  cat("\nby setting\n")
  agg <- stats::aggregate(cbind(z_max, cover90, err, sd, heldout) ~ emulators, res, mean)
  agg$clean <- tapply(res$longest <= 3, res$emulators, mean)[agg$emulators]
  print(agg, row.names = FALSE)
}

# --- bands: coverage of the truth and of held-out data ----------------------------
if ("bands" %in% measure) {
  hidden <- opt$hidden
  n_runs <- as.integer(opt$n_runs)
  tb <- testbed_suspension(seed = seeds[1], hidden = hidden)
  w <- tb$windows
  field <- register_curves(tb$A$field, tb$A$runs, w, knots_every = 2)
  t0 <- clock()
  runs <- tb$A$runs
  if (!is.na(n_runs)) runs <- simulate_suspension(design_maximin(tb$iu, n_runs, seed = 2))
  basis <- wavelet_basis(runs, field)
  em <- suppressWarnings(fit_emulators(runs, basis, engine = opt$engine))
  t1 <- clock()
  fit <- suppressWarnings(calibrate(em, field, tb$iu, chains = 2, seed = 1,
                                    sampler = sampler_control(n_draws = n_draws, n_inner = n_inner)))
  cat(sprintf("\n== bands: seed %d, hidden = %s; %s emulators; %d model runs; |I| = %d; emulators %.1f s; calibration %d x %d x 2 chains %.1f s\n",
              seeds[1], hidden, opt$engine, nrow(runs$design), length(basis$index), t1 - t0, n_draws, n_inner, clock() - t1))
  # the truth in registered time: the noise-free curve registered like the field data
  truth <- field_runs(lapply(tb$truth$reality, function(y) matrix(y, nrow = 1)), tb$A$field$t)
  truth_reg <- register_curves(truth, tb$A$runs, w, knots_every = 2)
  r <- reality(fit)
  cover <- function(band, curves) {
    vapply(names(curves), function(s) {
      b <- band[band$site == s, ]
      y <- curves[[s]]
      mean(sweep(y, 2, b$lower, ">=") & sweep(y, 2, b$upper, "<="))
    }, numeric(1))
  }
  pct <- function(x) paste(sprintf("%s %.1f%%", names(x), 100 * x), collapse = ", ")
  proj <- lapply(truth_reg$curves, function(y) wavelet_reconstruct(basis, wavelet_coef(basis, y)))
  cat("90% reality band covers the noise-free truth (registered) at:", pct(cover(r, truth_reg$curves)),
      "\n  and its projection on the retained basis at:", pct(cover(r, proj)), "\n")
  X <- as.matrix(fit$draws)
  true_in <- true_inputs(tb)
  inside <- vapply(names(true_in), function(p) {
    q <- stats::quantile(X[, p], c(0.025, 0.975))
    true_in[[p]] >= q[1] && true_in[[p]] <= q[2]
  }, logical(1))
  cat(sprintf("true inputs inside their 95%% posterior intervals: %d of %d (%s outside)\n", sum(inside),
              length(inside), paste(names(inside)[!inside], collapse = ", ")))
  med_width <- function(p) stats::median(p$summary$upper - p$summary$lower)
  cat(sprintf("median 90%% band widths: new_vehicle %.3f > field_run %.3f > reality %.3f\n",
              med_width(predict(fit, type = "new_vehicle", seed = 1)),
              med_width(predict(fit, type = "field_run", seed = 1)), med_width(predict(fit, type = "reality", seed = 1))))
  fB <- register_curves(tb$B$field, tb$A$runs, w, knots_every = 2)
  for (b in c("additive", "multiplicative")) {
    pB <- predict(fit, type = "new_nominal", bias = b, new_runs = tb$B$runs, x_nom = tb$B$x_nom, seed = 1)
    cat(sprintf("condition B held-out replicates inside the 90%% new_nominal band (%s): %s\n", b,
                pct(cover(pB$summary, fB$curves))))
  }
  fM <- register_curves(tb$added_mass$field, tb$A$runs, w, knots_every = 2)
  pM <- predict(fit, type = "added_load", new_runs = tb$added_mass$runs, seed = 1)
  cat(sprintf("added-mass field run inside the 90%% added_load band (D from the two runs): %s\n",
              pct(cover(pM$summary, fM$curves))))
  pE <- predict(fit, type = "added_load", delta = tb$added_mass$delta, seed = 1)
  cat(sprintf("added-mass field run inside the 90%% added_load band (D from the emulators at each draw): %s\n",
              pct(cover(pE$summary, fM$curves))))
  wf <- where_fails(fit)
  cat(sprintf("where_fails: %d intervals; longest %d grid steps\n", sum(wf$kind == "interval"), as.integer(longest_steps(wf))))
  if (hidden != "none") {
    # where the mechanism acts: the difference it makes to reality
    eff <- testbed_signatures(true_in, hidden)[[1]]
    b <- bias(fit)
    for (s in names(eff)) {
      acts <- abs(eff[[s]]) > 0.1 * max(abs(eff[[s]]))
      bs <- b[b$site == s, ]
      excl <- bs$lower > 0 | bs$upper < 0
      cat(sprintf("%s: bias band excludes zero at %.1f%% of the points where the mechanism acts, %.1f%% elsewhere\n",
                  s, 100 * mean(excl[acts]), 100 * mean(excl[!acts])))
    }
  }
}
