# The verdict judged by the truth. On both test beds, for each seed: the
# model validated with every default (the held-out condition left out), then
# the hidden mechanism added (case "true") or another mechanism instead
# (case "decoy"), each as a calibration input of strength in [0, 1] with 66
# (suspension) or 80 (dosing) new runs, validated again with
# update(fit, runs = , iu = ), and judged by compare_validations() at the
# held-out condition (suspension: the added-mass run, one replicate; dosing:
# the dose of 475 mg, six replicates, the model validated on 400, 250 and 550
# mg, the dose a condition). Beside the package's ratios (after / before of
# the held-out RMSE, model alone and bias-corrected) and its verdict, the
# same ratios against the test bed's noise-free reality at that condition
# (truth_model, truth_corrected: the predictions' means against reality on
# its own clock), and `reality_vs_before`: the RMSE of reality itself
# against the held-out field as the package registered it, over that of the
# unfixed model (at most 1: reality is never graded worse than the unfixed
# model).
# Agreement: "helped" where truth_model <= 0.8 (true mechanism), never
# "helped" for a decoy.
#   Rscript studies/yardstick.R [beds=suspension,dosing] [seeds=1:5] [cases=true,decoy]
#                               [out=studies/yardstick.csv]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(beds = "suspension,dosing", seeds = "1:5", cases = "true,decoy",
                       out = "studies/yardstick.csv"))
beds <- arg_names(opt$beds)
seeds <- arg_numbers(opt$seeds)
cases <- arg_names(opt$cases)
options(wavevalid.quiet = TRUE)
sampler <- sampler_control(quiet = TRUE)

rmse_to <- function(summary, truth, column) {
  sqrt(mean(unlist(lapply(names(truth), function(s) {
    (summary[summary$site == s, column] - as.vector(truth[[s]]))^2
  }))))
}

# The bed's problem: the fit before, the held-out experiment, the truth
# there, the mechanisms and how to run the model with one added.
suspension_problem <- function(seed) {
  mechs <- testbed_mechanisms()
  hidden <- mechs[(seed - 1) %% length(mechs) + 1]
  decoy <- mechs[seed %% length(mechs) + 1]
  tb <- testbed_suspension(seed, hidden = hidden)
  fit <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, sampler = sampler, seed = 1))
  list(tb = tb, fit = fit, hidden = hidden, decoy = decoy,
       holdout = experiment(tb$added_mass$field, change = tb$added_mass$delta),
       truth = tb$truth$reality_added_mass,
       runs_with = function(mech, iu_m) {
         s_name <- paste0("s_", mech)
         off <- tb$A$runs$design
         off[[s_name]] <- 0
         c(model_runs(off, tb$A$runs$curves, tb$A$runs$t),
           simulate_suspension(design_maximin(iu_m, 66L, seed = seed + 1), mechanism = mech))
       })
}

dosing_problem <- function(seed) {
  mechs <- dosing_mechanisms()
  hidden <- mechs[(seed - 1) %% length(mechs) + 1]
  decoy <- mechs[seed %% length(mechs) + 1]
  tb <- testbed_dosing(seed, hidden = hidden, doses = c(250, 550, 475))
  exps <- experiments_at(tb$doses$fields[c("dose_250", "dose_550")], data.frame(dose = c(250, 550)))
  fit <- suppressWarnings(validate(tb$doses$runs, tb$A$field, tb$doses$iu, windows = tb$windows, experiments = exps,
                                   sampler = sampler, seed = 1))
  list(tb = tb, fit = fit, hidden = hidden, decoy = decoy,
       holdout = experiment(tb$doses$fields$dose_475, condition = c(dose = 475)),
       truth = tb$doses$truth$reality$dose_475,
       runs_with = function(mech, iu_m) {
         simulate_dosing(design_maximin(iu_m, nrow(tb$doses$runs$design), seed = seed + 1), mechanism = mech)
       })
}

rows <- list()
for (bed in beds) {
  for (seed in seeds) {
    t0 <- clock()
    pb <- switch(bed, suspension = suspension_problem(seed), dosing = dosing_problem(seed))
    for (case in cases) {
      mech <- if (case == "true") pb$hidden else pb$decoy
      iu_m <- iu_add(pb$fit$iu, paste0("s_", mech), lower = 0, upper = 1, nominal = 0.5)
      fit_m <- suppressWarnings(update(pb$fit, runs = pb$runs_with(mech, iu_m), iu = iu_m))
      cmp <- compare_validations(pb$fit, fit_m, holdout = pb$holdout, seed = 1)
      hr <- attr(cmp, "holdout_ratio")
      pr <- attr(cmp, "holdout_predictions")
      fld <- attr(cmp, "holdout_field")$before
      graded <- function(curves) {
        sqrt(mean(unlist(lapply(names(pb$truth), function(s) sweep(fld$curves[[s]], 2, as.vector(curves[[s]]))^2))))
      }
      before_model <- lapply(stats::setNames(names(pb$truth), names(pb$truth)),
                             function(s) pr$before[pr$before$site == s, "model"])
      m <- stats::setNames(cmp$after / cmp$before, cmp$metric)
      rows[[length(rows) + 1L]] <- data.frame(
        bed = bed, seed = seed, case = case, mechanism = mech, verdict = attr(cmp, "verdict"),
        ratio_model = hr$ratio[1], lower_model = hr$lower[1], upper_model = hr$upper[1],
        ratio_corrected = hr$ratio[2], lower_corrected = hr$lower[2], upper_corrected = hr$upper[2],
        truth_model = rmse_to(pr$after, pb$truth, "model") / rmse_to(pr$before, pb$truth, "model"),
        truth_corrected = rmse_to(pr$after, pb$truth, "mean") / rmse_to(pr$before, pb$truth, "mean"),
        reality_vs_before = graded(pb$truth) / graded(before_model),
        model_rmse = m[["model_rmse"]], seconds = round(clock() - t0))
      print(utils::tail(rows[[length(rows)]], 1), digits = 3)
      utils::write.csv(do.call(rbind, rows), opt$out, row.names = FALSE)
    }
  }
}
out <- do.call(rbind, rows)
utils::write.csv(out, opt$out, row.names = FALSE)
print(out, digits = 3)
out$agree <- ifelse(out$case == "decoy", out$verdict != "helped",
                    ifelse(out$truth_model <= 0.8, out$verdict == "helped",
                           ifelse(out$truth_model <= 1, out$verdict != "worse", out$verdict != "helped")))
cat(sprintf("agreement with the truth: %d of %d (%.0f%%); decoys called helped: %d of %d; reality graded worse than the unfixed model: %d of %d\n",
            sum(out$agree), nrow(out), 100 * mean(out$agree), sum(out$case == "decoy" & out$verdict == "helped"),
            sum(out$case == "decoy"), sum(out$reality_vs_before > 1), nrow(out)))
