# The diagnosis criteria 1 and 2 over test-bed seeds and hidden mechanisms.
# Does where_fails() flag where the hidden mechanism acts, and only there
# (and nothing longer than a few grid steps with nothing hidden)? Does
# explain_bias() name the hidden mechanism? For each case (hidden mechanism,
# seed) the model without any mechanism is validated on condition A as the
# diagnosis tests validate it (66 runs, 150 x 20 draws, one chain; the field
# registered to the runs' mean, testbed_validation(), see
# tests/testthat/helper-protocol.R), with calibrate()'s `pool_levels` and
# `registration_variance`. Printed per case (by site where it applies):
#   recall     share of the grid points where the mechanism acts (its effect
#              above 10% of its peak) that are flagged (flagged_share());
#   precision  share of the flagged points where it acts;
#   base       share of the grid where it acts (the precision of flags thrown
#              at random);
#   flagged    share of the grid flagged;
#   lift       mean |posterior mean bias| where it acts over the same
#              elsewhere;
#   level0     share of the bias energy at wavelet level 0 (an offset of the
#              whole record);
#   longest    longest flagged interval (grid steps); credible, the largest
#              credible bias (kN).
# Criterion 1 (testbed_where_verdict()): where_ok, recall > 0.2 at both
# sites; localised adds precision - base > min(base, (1 - base) / 2); with
# nothing hidden, no flagged interval longer than 3 steps. Criterion 2
# (testbed_explain_verdict()): explain_bias() given the four mechanisms'
# signatures at the posterior mean inputs with the automatic shifts (sig_ok,
# shift_max the largest inclusion of a shift), and given the four mechanisms
# re-validated (testbed_revalidation(), refit_ok): the hidden mechanism first
# among the mechanisms at >= 0.9, every other below 0.5; with nothing hidden,
# no candidate at 0.5, shifts included.
# field = unwarped replaces the registered replicates by the truth plus the
# same kind of noise without time warps (a perfect registration); mean_warp
# by the truth warped by the mean of the replicates' true warps (replicates
# aligned with each other, not with the model). rescale = TRUE widens the
# emulators' variances by rescale_emulators() on 30 held-out runs.
#   Rscript studies/diagnosis.R [hidden=none] [seeds=1] [cases=] [pool_levels=NULL]
#                               [registration_variance=FALSE] [explain=signatures] [field=registered]
#                               [rescale=FALSE]
# hidden: none and the mechanisms, comma-separated (all: hidden=all); cases
# (hidden:seed, comma-separated) overrides hidden x seeds; explain: any of
# signatures, refits, or none.
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(hidden = "none", seeds = "1", cases = "", pool_levels = "NULL",
                       registration_variance = "FALSE", explain = "signatures", field = "registered",
                       rescale = "FALSE"))
if (opt$hidden == "all") opt$hidden <- paste(c("none", testbed_mechanisms()), collapse = ",")
cases <- arg_cases(opt$cases, opt$hidden, opt$seeds)
pool <- arg_value(opt$pool_levels)
rv <- arg_flag(opt$registration_variance)
rescale <- arg_flag(opt$rescale)
explain <- arg_names(opt$explain)
stopifnot(all(explain %in% c("signatures", "refits", "none")),
          opt$field %in% c("registered", "unwarped", "mean_warp"))
options(wavevalid.quiet = TRUE)

# The validation of one case: testbed_validation() for the registered field
# as fitted, else the same steps on the field and emulators asked for.
validate_case <- function(hidden, seed) {
  if (opt$field == "registered" && !rescale) {
    return(testbed_validation(hidden, seed, pool_levels = pool, registration_variance = rv))
  }
  tb <- testbed_suspension(seed = seed, hidden = hidden)
  field <- switch(opt$field, registered = testbed_register(tb, tb$A$runs), unwarped = testbed_unwarped_field(tb, seed),
                  mean_warp = mean_warp_field(tb, seed))
  basis <- wavelet_basis(tb$A$runs, field)
  em <- testbed_emulators(tb$A$runs, basis)
  if (rescale) em <- rescale_emulators(em, testbed_check_runs(tb$iu))
  fit <- testbed_calibrate(em, field, tb$iu, pool, registration_variance = rv && opt$field == "registered")
  list(tb = tb, field = field, basis = basis, emulators = em, fit = fit)
}

# flagged share of the grid and lift by site, next to the verdict's recall,
# precision and base
site_stats <- function(fails, sig) {
  b <- attr(fails, "bias")
  lv <- attr(fails, "wavelet_levels")
  dt <- diff(b$t[1:2])
  vapply(names(sig), function(s) {
    acts <- abs(sig[[s]]) > 0.1 * max(abs(sig[[s]]))
    m <- abs(b$mean[b$site == s])
    w <- fails[fails$site %in% s & fails$kind == "interval", , drop = FALSE]
    c(flagged = sum(w$end - w$start) / (length(m) * dt), lift = mean(m[acts]) / mean(m[!acts]),
      level0 = lv$share[lv$site == s & lv$level == 0])
  }, numeric(3))
}

res <- NULL
for (i in seq_len(nrow(cases))) {
  h <- cases$hidden[i]
  seed <- cases$seed[i]
  t0 <- clock()
  v <- validate_case(h, seed)
  fit <- v$fit
  fails <- where_fails(fit)
  sig <- if (h != "none") testbed_signatures(true_inputs(v$tb, fit$inputs), h)[[1]]
  verdict <- testbed_where_verdict(fails, h, sig)
  row <- data.frame(hidden = h, seed = seed, recall = by_site(verdict$recall),
                    precision = by_site(verdict$precision), base = by_site(verdict$base),
                    flagged = NA_character_, lift = NA_character_, level0 = NA_character_,
                    longest = verdict$longest, credible = signif(max(attr(fails, "credible")$credible_bias), 3),
                    where_ok = verdict$where_ok, localised = verdict$localised, stringsAsFactors = FALSE)
  if (h != "none") {
    st <- site_stats(fails, sig)
    for (k in rownames(st)) row[[k]] <- by_site(st[k, ])
  }
  judge <- function(ex) {
    j <- testbed_explain_verdict(ex, h)
    list(top = sprintf("%s %.3f", j$top, j$top_prob), ok = j$ok)
  }
  if ("signatures" %in% explain) {
    ex <- explain_bias(fit, testbed_signatures(coef(fit)), n_draws = 50, seed = 1)
    j <- judge(ex)
    row$sig_top <- j$top
    row$shift_max <- round(max(c(0, ex$inclusion_prob[startsWith(ex$candidate, "shift:")])), 3)
    row$sig_ok <- j$ok
  }
  if ("refits" %in% explain) {
    j <- judge(explain_bias(fit, testbed_revalidation(v$tb, fit, n_check = if (rescale) 30L else 0L),
                            n_draws = 50))
    row$refit_top <- j$top
    row$refit_ok <- j$ok
  }
  row$secs <- round(clock() - t0)
  print(row, row.names = FALSE)
  res <- rbind(res, row)
}
cat("\nfield =", opt$field, " rescale =", rescale, " pool_levels =", opt$pool_levels,
    " registration_variance =", rv, "\n")
print(res, row.names = FALSE)
cat("\ncases meeting each criterion\n")
ok <- intersect(c("where_ok", "localised", "sig_ok", "refit_ok"), names(res))
print(stats::aggregate(res[ok], res["hidden"], sum), row.names = FALSE)
