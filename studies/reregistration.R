# The diagnosis criteria when the field data are registered a second time,
# to a run of the model at the calibrated inputs. For each case (hidden
# mechanism, seed), condition A as the diagnosis tests run it (66 runs,
# 150 x 20 draws, one chain), levels `pool_levels` pooled, the emulators
# rescaled on 30 held-out runs (rescale_emulators()) unless rescale = FALSE:
#   pass 1  the field registered to the mean of the runs (start = runs) or to
#           the replicates' own pointwise mean (start = replicates),
#           calibrated;
#   pass 2  the field registered to the model run at the posterior mean inputs
#           of pass 1 (the same emulators and basis), calibrated again; with
#           again = emulator, to pass 1's model_prediction() (the posterior
#           mean of the emulated model) instead of a run; passes = 3 or more
#           registers again to a run at the last pass's inputs, as many times
#           (again = run only).
# This is testbed_two_pass() (tests/testthat/helper-protocol.R), each chain's
# start the best of n_search prior draws. Printed for the last pass (and the
# longest flag of pass 1): criterion 1, recall, precision and base of
# where_fails() against where the mechanism acts (studies/diagnosis.R), with
# nothing hidden the longest flagged interval; criterion 2, explain_bias()
# with the four signatures at the posterior mean inputs and the automatic
# shifts (sig_ok), and with the four mechanisms re-validated on the last
# pass's field data (refit_ok: testbed_revalidation(), emulators rescaled on
# 30 held-out runs of each model when rescaling); err_in, the rms error of
# the posterior mean inputs against the truth (coded).
#   Rscript studies/reregistration.R [hidden=none] [seeds=1] [cases=] [pool_levels=0:3] [rescale=TRUE]
#                                    [explain=signatures] [again=run] [start=runs] [passes=2]
#                                    [n_search=2000]
# hidden: none and the mechanisms, comma-separated (all: hidden=all); cases
# (hidden:seed) overrides hidden x seeds; explain: any of signatures, refits,
# or none.
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(hidden = "none", seeds = "1", cases = "", pool_levels = "0:3", rescale = "TRUE",
                       explain = "signatures", again = "run", start = "runs", passes = "2", n_search = "2000"))
if (opt$hidden == "all") opt$hidden <- paste(c("none", testbed_mechanisms()), collapse = ",")
cases <- arg_cases(opt$cases, opt$hidden, opt$seeds)
pool <- arg_value(opt$pool_levels)
rescale <- arg_flag(opt$rescale)
explain <- arg_names(opt$explain)
passes <- as.integer(opt$passes)
n_search <- as.integer(opt$n_search)
stopifnot(all(explain %in% c("signatures", "refits", "none")), opt$again %in% c("run", "emulator"),
          opt$start %in% c("runs", "replicates"), opt$again == "run" || passes == 2L)
options(wavevalid.quiet = TRUE)
check0 <- if (rescale) testbed_check_runs(testbed_suspension(1)$iu)

res <- NULL
for (i in seq_len(nrow(cases))) {
  h <- cases$hidden[i]
  seed <- cases$seed[i]
  t0 <- clock()
  tb <- testbed_suspension(seed = seed, hidden = h)
  if (opt$again == "run") {
    two <- testbed_two_pass(tb, tb$A$runs, tb$iu, check = check0, pool_levels = pool, start = opt$start,
                            passes = passes, n_search = n_search)
    p1 <- two$first
    fit <- two$fit
  } else {
    p1 <- testbed_first_pass(tb, tb$A$runs, tb$iu, check0, pool, opt$start, n_search)
    mp <- model_prediction(p1$fit)
    run <- split(mp$mean, factor(mp$site, levels = unique(mp$site)))
    fit <- testbed_calibrate(p1$emulators, testbed_register(tb, run), tb$iu, pool, n_search = n_search)
  }
  z_hat <- coef(fit)
  truth <- true_inputs(tb, fit$inputs)
  sig <- if (h != "none") testbed_signatures(truth, h)[[1]]
  verdict <- testbed_where_verdict(where_fails(fit), h, sig)
  row <- data.frame(hidden = h, seed = seed, longest1 = longest_steps(where_fails(p1$fit)),
                    longest = verdict$longest, recall = by_site(verdict$recall),
                    precision = by_site(verdict$precision), base = by_site(verdict$base),
                    where_ok = verdict$where_ok, localised = verdict$localised,
                    err_in = signif(sqrt(mean((z_hat - truth)^2)), 2), stringsAsFactors = FALSE)
  judge <- function(ex) {
    j <- testbed_explain_verdict(ex, h)
    list(top = sprintf("%s %.3f", j$top, j$top_prob), ok = j$ok)
  }
  if ("signatures" %in% explain) {
    j <- judge(explain_bias(fit, testbed_signatures(z_hat), n_draws = 50, seed = 1))
    row$sig_top <- j$top
    row$sig_ok <- j$ok
  }
  if ("refits" %in% explain) {
    j <- judge(explain_bias(fit, testbed_revalidation(tb, fit, n_check = if (rescale) 30L else 0L), n_draws = 50))
    row$refit_top <- j$top
    row$refit_ok <- j$ok
  }
  row$secs <- round(clock() - t0)
  print(row, row.names = FALSE)
  res <- rbind(res, row)
}
cat("\npool_levels =", opt$pool_levels, " rescale =", rescale, " again =", opt$again, " start =", opt$start,
    " passes =", passes, " n_search =", n_search, "\n")
print(res, row.names = FALSE)
cat("\ncases meeting each criterion\n")
ok <- intersect(c("where_ok", "localised", "sig_ok", "refit_ok"), names(res))
print(stats::aggregate(res[ok], res["hidden"], sum), row.names = FALSE)
