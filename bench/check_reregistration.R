# The diagnosis criteria on the test bed when the field data are registered a
# second time, to a run of the model at the calibrated inputs. For each case
# (hidden mechanism, seed), condition A as the tests run it (66 runs, 150 x
# 20 draws, one chain), with the emulators rescaled on 30 held-out runs
# (rescale_emulators()) and levels 0-3 pooled:
#   pass 1  field registered to the mean of the runs, calibrated;
#   pass 2  field registered to the model run at the posterior mean inputs of
#           pass 1 (the same emulators and basis), calibrated again.
# Printed for pass 2 (and the longest flag of pass 1): criterion 1, recall
# and precision of where_fails() against where the mechanism acts (as
# bench/check_localization.R), with nothing hidden the longest flagged
# interval; criterion 2, explain_bias() with the four signatures at the
# posterior mean inputs and the automatic shifts (sig_ok), and with the four
# mechanisms re-validated (refit_ok: each mechanism's strength a calibration
# input on [0, 1], 66 runs, emulators on the same basis rescaled on 30
# held-out runs of that model, calibrated on the pass-2 field data with the
# same prior); err_in, root mean square error of the posterior mean inputs
# against the truth (coded).
#   Rscript bench/check_reregistration.R [hidden=none,digressive_damper,...] [seeds=1:5]
#                                        [pool_levels=0:3] [rescale=TRUE] [explain=signatures,refits]
suppressPackageStartupMessages(library(wavevalid))
opt <- list(hidden = paste(c("none", testbed_mechanisms()), collapse = ","), seeds = "1:5",
            pool_levels = "0:3", rescale = "TRUE", explain = "signatures,refits")
for (a in commandArgs(trailingOnly = TRUE)) {
  kv <- strsplit(a, "=", fixed = TRUE)[[1]]
  if (length(kv) != 2L || !kv[1] %in% names(opt)) stop("unknown argument: ", a)
  opt[[kv[1]]] <- kv[2]
}
hidden <- strsplit(opt$hidden, ",")[[1]]
seeds <- eval(parse(text = paste0("c(", opt$seeds, ")")))
pool <- eval(parse(text = opt$pool_levels))
rescale <- as.logical(opt$rescale)
explain <- strsplit(opt$explain, ",")[[1]]
stopifnot(!is.na(rescale), all(explain %in% c("signatures", "refits", "none")))
options(wavevalid.quiet = TRUE)
clock <- function() as.numeric(proc.time()[["elapsed"]])
iu0 <- testbed_suspension(1)$iu
check0 <- if (rescale) simulate_suspension(design_maximin(iu0, 30, nominal = FALSE, seed = 9)) else NULL

emulate <- function(runs, basis, check) {
  em <- suppressWarnings(fit_emulators(runs, basis))
  if (rescale) rescale_emulators(em, check) else em
}
cal <- function(em, field, iu) {
  suppressWarnings(calibrate(em, field, iu, n_draws = 150, n_inner = 20, chains = 1, seed = 1,
                             pool_levels = pool, quiet = TRUE))
}
longest <- function(fails, fit) {
  if (nrow(fails)) round(max(fails$end - fails$start) / diff(fit$basis$t[1:2])) else 0
}
revalidate <- function(fit) {
  fits <- lapply(testbed_mechanisms(), function(m) {
    iu_m <- iu_add(fit$iu, paste0("s_", m), lower = 0, upper = 1, nominal = 0.5)
    runs <- simulate_suspension(design_maximin(iu_m, 66L, seed = 2), mechanism = m)
    check <- if (rescale) simulate_suspension(design_maximin(iu_m, 30, nominal = FALSE, seed = 9), mechanism = m)
    cal(emulate(runs, fit$basis, check), fit$field, iu_m)
  })
  stats::setNames(fits, testbed_mechanisms())
}

res <- NULL
for (h in hidden) {
  for (seed in seeds) {
    t0 <- clock()
    tb <- testbed_suspension(seed = seed, hidden = h)
    features <- if (h == "tire_liftoff") "max" else c("min", "max")
    truth <- c(tb$truth$u, 0.5 + tb$truth$delta)
    field1 <- register_curves(tb$A$field, tb$A$runs, tb$windows, features = features, knots_every = 2)
    basis <- wavelet_basis(tb$A$runs, field1)
    em <- emulate(tb$A$runs, basis, check0)
    fit1 <- cal(em, field1, tb$iu)
    run <- simulate_suspension(as.data.frame(as.list(colMeans(as.matrix(fit1$draws))[fit1$inputs])))
    field2 <- register_curves(tb$A$field, run, tb$windows, features = features, knots_every = 2)
    fit <- cal(em, field2, tb$iu)
    fails <- where_fails(fit)
    z_hat <- colMeans(as.matrix(fit$draws))[fit$inputs]
    row <- data.frame(hidden = h, seed = seed, longest1 = longest(where_fails(fit1), fit1),
                      longest = longest(fails, fit), recall = NA_character_, precision = NA_character_,
                      base = NA_character_, where_ok = NA, localised = NA,
                      err_in = signif(sqrt(mean((z_hat - truth[fit$inputs])^2)), 2), stringsAsFactors = FALSE)
    if (h == "none") {
      row$where_ok <- row$localised <- row$longest <= 3
    } else {
      sig <- testbed_signatures(truth[fit$inputs], h)[[1]]
      rec <- flagged_share(fails, sig)
      pre <- flagged_share(fails, sig, of = "flags")
      pre[is.na(pre)] <- 0
      base <- attr(pre, "acting")
      f2 <- function(x) paste(formatC(x, digits = 2, format = "fg"), collapse = "/")
      row$recall <- f2(rec)
      row$precision <- f2(pre)
      row$base <- f2(base)
      row$where_ok <- all(rec > 0.2)
      row$localised <- row$where_ok && all(if (h == "strut_friction") pre > base else pre > 2 * base)
    }
    judge <- function(ex) {
      ex <- as.data.frame(unclass(ex))
      mech <- ex[!startsWith(ex$candidate, "shift:"), ]
      if (h == "none") return(c(top = sprintf("%s %.3f", ex$candidate[1], ex$inclusion_prob[1]),
                                ok = all(ex$inclusion_prob < 0.5)))
      p <- mech$inclusion_prob[mech$candidate == h]
      c(top = sprintf("%s %.3f", mech$candidate[1], mech$inclusion_prob[1]),
        ok = mech$candidate[1] == h && p >= 0.9 && all(mech$inclusion_prob[mech$candidate != h] < 0.5))
    }
    if ("signatures" %in% explain) {
      j <- judge(explain_bias(fit, testbed_signatures(z_hat), n_draws = 50, seed = 1))
      row$sig_top <- j[["top"]]
      row$sig_ok <- as.logical(j[["ok"]])
    }
    if ("refits" %in% explain) {
      j <- judge(explain_bias(fit, revalidate(fit), n_draws = 50))
      row$refit_top <- j[["top"]]
      row$refit_ok <- as.logical(j[["ok"]])
    }
    row$secs <- round(clock() - t0)
    print(row, row.names = FALSE)
    res <- rbind(res, row)
  }
}
cat("\npool_levels =", opt$pool_levels, " rescale =", rescale, "\n")
print(res, row.names = FALSE)
cat("\ncases meeting each criterion\n")
ok <- intersect(c("where_ok", "localised", "sig_ok", "refit_ok"), names(res))
print(stats::aggregate(res[ok], res["hidden"], sum), row.names = FALSE)
