# False findings on a right model, and the power left for a wrong one: what
# where_fails() reports on both test beds with nothing hidden (every finding
# is false there) and with each mechanism hidden, under the bias prior's
# grouping of the coarse levels (`pool_levels`) and the variance the
# registration adds to the field mean (`registration_variance`). For each case:
#   longest, n_int  the longest localised interval (grid steps) and how many
#   held_longest    the same for the bias read with the inputs in conflict held
#   overlap         a localised interval of the fit or of the held reading
#                   overlaps where the hidden mechanism acts (C1)
#   wide, offset    whether the record-wide part is credibly non-zero, and its
#                   mean by site
#   conflicts       the inputs in conflict with their prior
#   inside90        how many true inputs lie inside their 90% intervals
#   reg_share       the share of the field mean's variance the registration
#                   adds (averaged over sites)
#   timing          the landmarks whose timing differs credibly between the
#                   field and the model at the calibrated inputs (findings of
#                   kind "timing")
#   top             the kind of the first finding
# With `c3=TRUE`, for a hidden mechanism, the loop of the user: the mechanism
# added to the model (its strength a new input on [0, 1], the fit's runs at
# strength 0 and 66 more), validated again with update(), and compared with
# compare_validations() at a held-out condition (the suspension's added-mass
# run; the dosing bed's condition B as a change of the nominal inputs):
#   after_false     a false finding after the fix (a localised interval over
#                   5 steps, a credible record-wide part or an input in conflict)
#   model_ratio, corrected_ratio  the held-out error after / before of the
#                   model alone and of the bias-corrected prediction
#   verdict         compare_validations()'s verdict
# With `truth=TRUE` (suspension only) it also prints, for nothing hidden, the
# registered field mean's error against reality and the sampling error the
# replicates' scatter gives it.
#   Rscript studies/false_findings.R [beds=suspension,dosing] [seeds=1:5] [hidden=none,all]
#                                    [pool_levels=coarse] [registration_variance=check]
#                                    [n_draws=150] [n_inner=20] [chains=1] [out=false_findings.csv]
#                                    (n_draws=default: sampler_control()'s defaults)
#                                    [strength_upper=1] (c3: the range [0, strength_upper] of the added strength)
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
args <- study_args(list(beds = "suspension,dosing", seeds = "1:5", hidden = "none,all", pool_levels = "coarse",
                        registration_variance = "check", n_draws = "150", n_inner = "20", chains = "1",
                        out = "false_findings.csv", truth = "FALSE", c3 = "FALSE", strength_upper = "1"))
args$strength_upper <- as.numeric(args$strength_upper)
options(wavevalid.quiet = TRUE)
pool <- if (args$pool_levels == "coarse") "coarse" else arg_value(args$pool_levels)
rv <- if (args$registration_variance %in% c("auto", "check", "shifts")) args$registration_variance else arg_flag(args$registration_variance)
bed <- testbed_beds()
# n_draws=default: sampler_control()'s defaults (chains that stop on their
# targets, a draw every 50 cycles); else a fixed length
sampler_of <- function(args) {
  if (identical(args$n_draws, "default")) return(sampler_control(quiet = TRUE))
  sampler_control(n_draws = as.integer(args$n_draws), n_inner = as.integer(args$n_inner), quiet = TRUE)
}
steps <- function(wf, dt) {
  wf <- wf[wf$kind %in% c("interval", "covered"), ]
  if (!nrow(wf)) 0 else max(round((wf$end - wf$start) / dt))
}

# The mechanism added and validated again; the comparison at the held-out
# condition.
loop_after <- function(tb, fit, b, hd, dt) {
  s_name <- paste0("s_", hd)
  # the lift-off's strength cannot pass 1 (the tire's force in tension is gone)
  top <- if (hd == "tire_liftoff") min(1, args$strength_upper) else args$strength_upper
  iu2 <- iu_add(tb$iu, s_name, lower = 0, upper = top, nominal = top / 2)
  off <- tb$A$runs$design
  off[[s_name]] <- 0
  runs2 <- c(model_runs(off, tb$A$runs$curves, tb$A$runs$t),
             bed[[b]]$simulate(design_maximin(iu2, 66L, seed = 2), mechanism = hd))
  fit2 <- suppressWarnings(update(fit, runs = runs2, iu = iu2))
  wf2 <- where_fails(fit2)
  cf2 <- attr(wf2, "conflicts")
  false_after <- steps(wf2[wf2$kind == "interval", ], dt) > 5 || any(attr(wf2, "record_wide")$credible) ||
    any(cf2$conflict) || any(wf2$kind == "timing")
  ex <- if (b == "suspension") {
    experiment(tb$added_mass$field, change = tb$added_mass$delta)
  } else {
    experiment(tb$B$field, change = tb$B$x_nom - tb$iu$nominal[match(names(tb$B$x_nom), tb$iu$name)])
  }
  cmp <- suppressWarnings(compare_validations(fit, fit2, holdout = ex, seed = 1))
  get <- function(m) cmp$after[cmp$metric == m] / cmp$before[cmp$metric == m]
  data.frame(after_false = false_after, after_conflicts = paste(cf2$input[cf2$conflict], collapse = "+"),
             model_ratio = round(get("holdout_rmse_model"), 3), corrected_ratio = round(get("holdout_rmse"), 3),
             local_ratio = round(get("bias_rms_local"), 3), verdict = attr(cmp, "verdict"), stringsAsFactors = FALSE)
}

for (b in arg_names(args$beds)) {
  hidden <- unlist(lapply(arg_names(args$hidden), function(h) if (h == "all") bed[[b]]$mechanisms() else h))
  for (hd in hidden) for (seed in arg_numbers(args$seeds)) {
    t0 <- clock()
    tb <- bed[[b]]$make(seed = seed, hidden = hd)
    fit <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, features = bed[[b]]$features,
                                     bias = bias_control(pool_levels = pool, registration_variance = rv),
                                     sampler = sampler_of(args),
                                     chains = as.integer(args$chains), seed = 1))
    dt <- diff(fit$basis$t[1:2])
    wf <- where_fails(fit)
    rw <- attr(wf, "record_wide")
    cf <- attr(wf, "conflicts")
    h <- attr(wf, "held")
    overlap <- NA
    if (hd != "none") {
      eff <- bed[[b]]$signatures(true_inputs(tb, fit$inputs), hd)[[1]]
      overlap <- any(flagged_share(wf, eff) > 0, na.rm = TRUE) ||
        (!is.null(h) && any(flagged_share(h$fails, eff) > 0, na.rm = TRUE))
    }
    tm <- attr(wf, "timing")
    z <- true_inputs(tb, fit$inputs)
    X <- as.matrix(fit$draws)[, fit$inputs]
    q <- apply(X, 2, stats::quantile, c(0.05, 0.95))
    share <- if (is.null(fit$registration_var)) 0 else mean(vapply(names(fit$wb), function(s) {
      r <- fit$registration_var[[s]]
      sum(r) / sum(r + colMeans(fit$sigma2[[s]]) / fit$n_rep[[s]])
    }, numeric(1)))
    row <- data.frame(bed = b, hidden = hd, seed = seed, pool_levels = args$pool_levels,
                      registration_variance = args$registration_variance, longest = steps(wf[wf$kind == "interval", ], dt),
                      n_int = sum(wf$kind == "interval"), held_longest = if (is.null(h)) NA else steps(h$fails, dt),
                      overlap = overlap, wide = any(rw$credible), offset = by_site(rw$offset),
                      conflicts = paste(cf$input[cf$conflict], collapse = "+"),
                      timing = if (is.null(tm)) 0L else sum(tm$flagged),
                      inside90 = sum(z >= q[1, ] & z <= q[2, ]), n_inputs = length(z), reg_share = round(share, 3),
                      top = if (nrow(wf)) wf$kind[1] else "none", secs = round(clock() - t0), stringsAsFactors = FALSE)
    if (arg_flag(args$c3) && hd != "none") row <- cbind(row, loop_after(tb, fit, b, hd, dt))
    print(row, row.names = FALSE)
    utils::write.table(row, args$out, sep = ",", row.names = FALSE, append = file.exists(args$out),
                       col.names = !file.exists(args$out))
    if (arg_flag(args$truth) && hd == "none") {
      for (s in names(fit$wb)) {
        Y <- fit$field$curves[[s]]
        err <- colMeans(Y) - tb$truth$reality[[s]]
        cat(sprintf("  %s: registered field mean against reality, rms %.3f; sampling error the scatter gives, %.3f\n",
                    s, sqrt(mean(err^2)), sqrt(mean(apply(Y, 2, stats::var) / nrow(Y)))))
      }
    }
  }
}
