# The diagnosis criteria on the suspension test bed for the whole workflow:
# validate on condition A with the 66 runs (replicates registered to the mean
# of the runs), simulate a second wave of n_add runs at design_posterior(),
# register the replicates and every model run (first and new) to the mean of
# the new runs with register_curves(), build the wavelet basis anew on all the
# runs, fit the emulators and calibrate again. Then, on that fit:
#   where: where_fails(); with a mechanism, the flagged share of where it acts
#          at each site (pass: > 0.2 at both); with none, the longest flagged
#          interval in grid steps (pass: at most 3);
#   which: explain_bias() with every mechanism re-validated (the model with it,
#          its strength a calibration input on [0, 1], at 66 maximin runs
#          registered to the same reference, emulators on the fit's basis,
#          calibrated on the same registered field); pass with a mechanism:
#          ranked first among the mechanisms, inclusion_prob >= 0.9, every
#          other below 0.5; with none: no candidate reaches 0.5.
# reuse = TRUE gives each re-validated model the runs of the model without
# the mechanism too, as runs at strength 0 (where the mechanism is off), so
# that its emulators are as good as the fit's where the posterior lies.
# pool_levels is calibrate()'s (e.g. 0:3, NULL by default); explain = FALSE
# skips the re-validations and explain_bias() (criterion "which").
#   Rscript bench/check_full_workflow.R cases=none:1,damper:2 n_add=30 cores=2 register_runs=TRUE reuse=FALSE
#                                       pool_levels=NULL explain=TRUE
# Arguments are name=value; cases default to every mechanism and none at
# seeds 1-5 (mechanisms abbreviated: damper, bumpstop, liftoff, friction).
suppressPackageStartupMessages(library(wavevalid))
source("bench/args.R")
opts <- list(cases = NULL, n_add = "30", cores = "2", register_runs = "TRUE", n_draws = "150", n_inner = "20",
             reuse = "FALSE", pool_levels = "NULL", explain = "TRUE")
opts <- bench_args(opts)
short <- c(none = "none", damper = "digressive_damper", bumpstop = "progressive_bumpstop",
           liftoff = "tire_liftoff", friction = "strut_friction")
cases <- if (is.null(opts$cases)) {
  as.vector(t(outer(names(short), 1:5, paste, sep = ":")))
} else strsplit(opts$cases, ",")[[1]]
n_add <- as.integer(opts$n_add)
cores <- as.integer(opts$cores)
register_runs <- as.logical(opts$register_runs)
n_draws <- as.integer(opts$n_draws)
n_inner <- as.integer(opts$n_inner)
reuse <- as.logical(opts$reuse)
pool_levels <- eval(parse(text = opts$pool_levels))
explain <- as.logical(opts$explain)
options(wavevalid.quiet = TRUE)

one <- function(case) {
  hidden <- unname(short[sub(":.*", "", case)])
  seed <- as.integer(sub(".*:", "", case))
  t0 <- proc.time()[["elapsed"]]
  tb <- testbed_suspension(seed = seed, hidden = hidden)
  features <- if (hidden == "tire_liftoff") "max" else c("min", "max")
  reg <- function(x, reference) register_curves(x, reference, tb$windows, features = features, knots_every = 2)
  validate <- function(runs, field, iu) {
    em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, field)))
    suppressWarnings(calibrate(em, field, iu, n_draws = n_draws, n_inner = n_inner, chains = 1, seed = 1, quiet = TRUE,
                               pool_levels = pool_levels))
  }
  fit0 <- validate(tb$A$runs, reg(tb$A$field, tb$A$runs), tb$iu)
  wave <- simulate_suspension(design_posterior(fit0, n_add, seed = 1))
  all_runs <- c(tb$A$runs, wave)
  field <- reg(tb$A$field, wave)
  runs <- if (register_runs) reg(all_runs, wave) else all_runs
  fit <- validate(runs, field, tb$iu)
  wf <- where_fails(fit)
  truth <- c(tb$truth$u, 0.5 + tb$truth$delta)[fit$inputs]
  where <- if (hidden == "none") {
    longest <- max(c(0, round((wf$end - wf$start) / diff(fit$basis$t[1:2]))))
    list(value = as.character(longest), pass = longest <= 3)
  } else {
    share <- flagged_share(wf, testbed_signatures(truth, hidden)[[1]])
    list(value = paste(round(share, 2), collapse = "/"), pass = all(share > 0.2))
  }
  out <- data.frame(case = case, where = where$value, where_ok = where$pass,
                    credible = signif(max(attr(wf, "credible")$credible_bias), 3))
  if (explain) out <- cbind(out, explain_row(fit, tb, hidden, all_runs, wave, reg))
  out$seconds <- round(proc.time()[["elapsed"]] - t0)
  message(utils::capture.output(print(out, row.names = FALSE))[2])
  out
}

# Criterion "which": every mechanism re-validated, explain_bias() on them.
explain_row <- function(fit, tb, hidden, all_runs, wave, reg) {
  refits <- lapply(stats::setNames(nm = testbed_mechanisms()), function(m) {
    iu_m <- iu_add(tb$iu, paste0("s_", m), lower = 0, upper = 1, nominal = 0.5)
    r <- simulate_suspension(design_maximin(iu_m, 66L, seed = 2), mechanism = m)
    if (reuse) {
      off <- all_runs
      off$design[[paste0("s_", m)]] <- 0
      r <- c(off, r)
    }
    if (register_runs) r <- reg(r, wave)
    em <- suppressWarnings(fit_emulators(r, fit$basis))
    suppressWarnings(calibrate(em, fit$field, iu_m, n_draws = n_draws, n_inner = n_inner, chains = 1, seed = 1,
                               quiet = TRUE, pool_levels = pool_levels))
  })
  ex <- as.data.frame(unclass(explain_bias(fit, refits, n_draws = 50)))
  mech <- ex[!startsWith(ex$candidate, "shift:"), ]
  which_ok <- if (hidden == "none") {
    all(ex$inclusion_prob < 0.5)
  } else {
    mech$candidate[1] == hidden && mech$inclusion_prob[1] >= 0.9 && all(mech$inclusion_prob[-1] < 0.5)
  }
  data.frame(first = mech$candidate[1], prob = signif(mech$inclusion_prob[1], 3),
             second = signif(mech$inclusion_prob[2], 3), which_ok = which_ok)
}

cat(sprintf("full workflow: second wave of %d runs, field%s registered to its mean, %d x %d draws, 1 chain%s%s\n",
            n_add, if (register_runs) " and every run" else "", n_draws, n_inner,
            if (reuse) "; re-validated models reuse the runs at strength 0" else "",
            if (is.null(pool_levels)) "" else paste0("; levels ", opts$pool_levels, " pooled")))
res <- parallel::mclapply(cases, function(k) tryCatch(one(k), error = function(e) {
  out <- data.frame(case = k, where = conditionMessage(e), where_ok = NA, credible = NA)
  if (explain) out <- cbind(out, data.frame(first = NA, prob = NA, second = NA, which_ok = NA))
  out$seconds <- NA
  out
}), mc.cores = cores, mc.preschedule = FALSE)
res <- do.call(rbind, res)
print(res, row.names = FALSE)
cat(sprintf("where: %d of %d pass", sum(res$where_ok, na.rm = TRUE), nrow(res)))
if (explain) cat(sprintf("; which: %d of %d pass", sum(res$which_ok, na.rm = TRUE), nrow(res)))
cat("\n")
