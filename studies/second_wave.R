# What a second wave of model runs at design_posterior() does on the
# suspension test bed: are the emulators then honest where the posterior
# lies, and does the diagnosis hold? Chosen by `measure` (comma-separated):
#   rounds    per case (hidden:seed) the model is validated on condition A
#             with the 66 runs, then n_add runs are simulated at
#             design_posterior(fit, n_add, spread) and added with c(), the
#             emulators fitted again on the same basis and the model
#             calibrated again; `rounds` times. field = unwarped (default):
#             the truth plus the same kind of noise without time warps (a
#             perfect registration); registered: the replicates registered to
#             the first runs' mean (knots every 2 time units). With reference
#             = posterior (registered only) the replicates are registered anew
#             after each round to the mean of that round's runs and the basis
#             built anew on all the runs; register_runs (TRUE by default)
#             then registers every run to that mean too. Columns: longest (grid steps),
#             credible (kN), cover90 (share of the nine true inputs inside
#             their central 90% interval), err (rms posterior mean - truth,
#             coded), sd (mean posterior sd), share (flagged share of the
#             hidden mechanism's region by site).
#   workflow  the whole workflow per case: validate on condition A, a second
#             wave of n_add runs at design_posterior(), the replicates and
#             every run (register_runs = TRUE) registered to the mean of the
#             new runs, the basis
#             built anew on all the runs, emulators and calibration again;
#             then criterion 1 (where: the flagged share of where the
#             mechanism acts by site, pass > 0.2 at both; with none, the
#             longest flagged interval, pass <= 3 steps) and criterion 2
#             (which: explain_bias() on every mechanism re-validated with 66
#             maximin runs registered to the same reference; with reuse =
#             TRUE the re-validated models also get the runs without the
#             mechanism as runs at strength 0).
#   strength  nothing hidden, seed 1, the workflow's fit: each of `mechanisms`
#             re-validated (66 maximin runs, plus with reuse = TRUE the 96
#             runs without it at strength 0, registered like the field);
#             printed: the strength's posterior quantiles, its log Bayes
#             factor and inclusion probability from explain_bias(), and the
#             rms gap (kN, by site) between the fit's and the refit's emulated
#             curves at the fit's posterior mean inputs with the strength at 0.
# All calibrations: one chain of 150 x 20 draws, seed 1; pool_levels is
# calibrate()'s.
#   Rscript studies/second_wave.R [measure=rounds] [cases=none:1] [field=unwarped] [n_add=30] [rounds=1]
#                                 [spread=0.05] [reference=first] [register_runs=TRUE] [reuse=FALSE]
#                                 [pool_levels=NULL] [mechanisms=digressive_damper]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(measure = "rounds", cases = "none:1", field = "unwarped", n_add = "30", rounds = "1",
                       spread = "0.05", reference = "first", register_runs = "TRUE", reuse = "FALSE",
                       pool_levels = "NULL", mechanisms = "digressive_damper"))
measure <- arg_names(opt$measure)
stopifnot(all(measure %in% c("rounds", "workflow", "strength")), opt$field %in% c("registered", "unwarped"),
          opt$reference %in% c("first", "posterior"))
cases <- arg_cases(opt$cases, "", "")
n_add <- as.integer(opt$n_add)
n_rounds <- as.integer(opt$rounds)
spread <- as.numeric(opt$spread)
register_runs <- arg_flag(opt$register_runs)
reuse <- arg_flag(opt$reuse)
pool <- arg_value(opt$pool_levels)
options(wavevalid.quiet = TRUE)

# registration as the tests do it (knots every 2 time units; the maximum alone
# for the lift-off), to the curves or runs `reference`
register_to <- function(tb, x, reference) {
  features <- if (identical(tb$truth$hidden, "tire_liftoff")) "max" else c("min", "max")
  register_curves(x, reference, tb$windows, features = features, knots_every = 2)
}
validate <- function(runs, field, iu, basis = wavelet_basis(runs, field)) {
  testbed_calibrate(testbed_emulators(runs, basis), field, iu, pool)
}

# --- rounds: waves of runs at design_posterior() ----------------------------------
rounds_case <- function(hidden, seed) {
  if (opt$reference == "posterior" && opt$field != "registered") stop("reference=posterior needs field=registered")
  tb <- testbed_suspension(seed = seed, hidden = hidden)
  field <- if (opt$field == "unwarped") testbed_unwarped_field(tb, seed) else register_to(tb, tb$A$field, tb$A$runs)
  runs <- tb$A$runs
  basis <- wavelet_basis(runs, field)
  truth <- true_inputs(tb)
  row <- function(fit, round) {
    wf <- where_fails(fit)
    d <- as.matrix(fit$draws)[, fit$inputs]
    z <- truth[fit$inputs]
    lo <- apply(d, 2, stats::quantile, 0.05)
    hi <- apply(d, 2, stats::quantile, 0.95)
    share <- if (hidden == "none") NA_character_ else by_site(flagged_share(wf, testbed_signatures(z, hidden)[[1]]))
    data.frame(hidden = hidden, seed = seed, runs = nrow(fit$emulators$design), round = round,
               longest = longest_steps(wf), credible = max(attr(wf, "credible")$credible_bias),
               cover90 = mean(z >= lo & z <= hi), err = sqrt(mean((colMeans(d) - z)^2)),
               sd = mean(apply(d, 2, stats::sd)), share = share)
  }
  fit <- validate(runs, field, tb$iu, basis)
  out <- row(fit, 0L)
  all_runs <- runs
  for (r in seq_len(n_rounds)) {
    wave <- simulate_suspension(design_posterior(fit, n_add, spread = spread, seed = r))
    all_runs <- c(all_runs, wave)
    runs <- all_runs
    if (opt$reference == "posterior") {
      field <- register_to(tb, tb$A$field, wave)
      if (register_runs) runs <- register_to(tb, all_runs, wave)
      basis <- wavelet_basis(runs, field)
    }
    fit <- validate(runs, field, tb$iu, basis)
    out <- rbind(out, row(fit, r))
  }
  out
}

# --- workflow: the second wave, registered to its mean ---------------------------
# The fit after the second wave, with what the re-validations need.
second_wave_fit <- function(tb) {
  fit0 <- validate(tb$A$runs, register_to(tb, tb$A$field, tb$A$runs), tb$iu)
  wave <- simulate_suspension(design_posterior(fit0, n_add, seed = 1))
  all_runs <- c(tb$A$runs, wave)
  field <- register_to(tb, tb$A$field, wave)
  runs <- if (register_runs) register_to(tb, all_runs, wave) else all_runs
  list(fit = validate(runs, field, tb$iu), all_runs = all_runs, wave = wave)
}
# The model with mechanism m re-validated on the fit's field and basis.
refit_with <- function(tb, sw, m) {
  s <- paste0("s_", m)
  iu_m <- iu_add(tb$iu, s, lower = 0, upper = 1, nominal = 0.5)
  r <- simulate_suspension(design_maximin(iu_m, 66L, seed = 2), mechanism = m)
  if (reuse) {
    off <- sw$all_runs
    off$design[[s]] <- 0
    r <- c(off, r)
  }
  if (register_runs) r <- register_to(tb, r, sw$wave)
  testbed_calibrate(testbed_emulators(r, sw$fit$basis), sw$fit$field, iu_m, pool)
}

workflow_case <- function(hidden, seed) {
  tb <- testbed_suspension(seed = seed, hidden = hidden)
  sw <- second_wave_fit(tb)
  fit <- sw$fit
  wf <- where_fails(fit)
  if (hidden == "none") {
    where <- longest_steps(wf)
    where_ok <- where <= 3
  } else {
    share <- flagged_share(wf, testbed_signatures(true_inputs(tb, fit$inputs), hidden)[[1]])
    where <- by_site(share)
    where_ok <- all(share > 0.2)
  }
  refits <- lapply(stats::setNames(nm = testbed_mechanisms()), function(m) refit_with(tb, sw, m))
  ex <- explain_bias(fit, refits, n_draws = 50)
  j <- testbed_explain_verdict(ex, hidden)
  data.frame(hidden = hidden, seed = seed, where = as.character(where), where_ok = where_ok,
             credible = signif(max(attr(wf, "credible")$credible_bias), 3), first = j$top,
             prob = signif(j$top_prob, 3), which_ok = j$ok)
}

# --- strength: what a re-validated mechanism claims with nothing hidden -----------
strength_rows <- function() {
  tb <- testbed_suspension(seed = 1, hidden = "none")
  sw <- second_wave_fit(tb)
  fit <- sw$fit
  z <- coef(fit)
  for (m in arg_names(opt$mechanisms)) {
    s <- paste0("s_", m)
    rf <- refit_with(tb, sw, m)
    d <- as.matrix(rf$draws)
    ex <- explain_bias(fit, stats::setNames(list(rf), m), n_draws = 50)
    zz <- as.data.frame(as.list(c(z, stats::setNames(0, s))))[rf$inputs]
    gap <- vapply(names(fit$wb), function(site) {
      a <- predict(fit$emulators, as.data.frame(as.list(z))[fit$inputs], site = site)$mean
      b <- predict(rf$emulators, zz, site = site)$mean
      sqrt(mean(wavelet_reconstruct(fit$basis, drop(a - b))^2))
    }, numeric(1))
    cat(sprintf("%s: strength q05/q50/q95 %s; log_bf %.1f; inclusion %.3f; emulator gap (rms kN) at strength 0: %s\n",
                m, paste(signif(stats::quantile(d[, s], c(.05, .5, .95)), 2), collapse = "/"),
                attr(ex, "log_bf")[[1]], ex$inclusion_prob[1], by_site(gap)))
  }
}

run_cases <- function(f) {
  res <- do.call(rbind, lapply(seq_len(nrow(cases)), function(i) {
    t0 <- clock()
    r <- f(cases$hidden[i], cases$seed[i])
    r$secs <- round(clock() - t0)
    print(r, row.names = FALSE, digits = 3)
    r
  }))
  cat("\n")
  print(res, row.names = FALSE, digits = 3)
  res
}
settings <- sprintf("%d runs, pool_levels = %s, register_runs = %s, reuse = %s", n_add, opt$pool_levels,
                    register_runs, reuse)
if ("rounds" %in% measure) {
  cat(sprintf("== rounds: field %s, %d round(s), spread %g, reference %s, %s\n", opt$field, n_rounds, spread,
              opt$reference, settings))
  invisible(run_cases(rounds_case))
}
if ("workflow" %in% measure) {
  cat(sprintf("\n== workflow: second wave of %s\n", settings))
  res <- run_cases(workflow_case)
  cat(sprintf("where: %d of %d pass; which: %d of %d pass\n", sum(res$where_ok), nrow(res), sum(res$which_ok),
              nrow(res)))
}
if ("strength" %in% measure) {
  cat(sprintf("\n== strength: nothing hidden, seed 1, second wave of %s\n", settings))
  strength_rows()
}
