# What does where_fails() flag on the test bed with nothing hidden, and how
# much of it is the registration? For each seed the model is validated on
# condition A (66 runs, 150 x 20 draws, one chain) with the field data
#   registered  registered to the mean of the runs (knots_every = 2), as the
#               tests do it;
#   unwarped    reality plus the replicates' noise without time warps (what a
#               perfect registration would leave);
#   mean_warp   reality warped by the mean of the replicates' true warps, plus
#               noise: replicates perfectly aligned with each other but not
#               with the model, as registering the field to its own
#               consensus would leave them at best;
# and the emulators as fitted or rescaled (rescale_emulators() on 30 held-out
# runs), with or without pooling levels 0-3 and the registration variance
# (registered field only). Printed: flagged grid steps (both sites), the
# longest flagged interval (the issue asks for no more than a few steps) and
# the largest credible bias (kN).
#   Rscript bench/check_none_flags.R [seeds=1:5] [field=registered,unwarped,mean_warp]
#                                    [emulators=fitted,rescaled] [pool_levels=NULL,0:3]
#                                    [registration_variance=FALSE]
suppressPackageStartupMessages(library(wavevalid))
source("bench/args.R")
opt <- list(seeds = "1:5", field = "registered,unwarped,mean_warp", emulators = "fitted,rescaled",
            pool_levels = "NULL,0:3", registration_variance = "FALSE")
opt <- bench_args(opt)
seeds <- eval(parse(text = paste0("c(", opt$seeds, ")")))
fields <- strsplit(opt$field, ",")[[1]]
emulators <- strsplit(opt$emulators, ",")[[1]]
pools <- lapply(strsplit(opt$pool_levels, ",")[[1]], function(p) eval(parse(text = p)))
rv <- as.logical(opt$registration_variance)
stopifnot(all(fields %in% c("registered", "unwarped", "mean_warp")),
          all(emulators %in% c("fitted", "rescaled")), !is.na(rv))
options(wavevalid.quiet = TRUE)
ns <- asNamespace("wavevalid")

field_data <- function(tb, seed, kind) {
  if (kind == "registered") return(register_curves(tb$A$field, tb$A$runs, tb$windows, knots_every = 2))
  if (kind == "unwarped") return(ns$unwarped_field(tb, seed))
  w <- tb$truth$warps
  w <- w[w$condition == "A", ]
  ns$unwarped_field(tb, seed, warp = stats::aggregate(w ~ t, data = w, FUN = mean))
}

check <- NULL
if ("rescaled" %in% emulators) {
  check <- simulate_suspension(design_maximin(testbed_suspension(1)$iu, 30, nominal = FALSE, seed = 9))
}
res <- NULL
for (seed in seeds) {
  tb <- testbed_suspension(seed = seed, hidden = "none")
  for (fk in fields) {
    field <- field_data(tb, seed, fk)
    em0 <- suppressWarnings(fit_emulators(tb$A$runs, wavelet_basis(tb$A$runs, field)))
    for (ek in emulators) {
      em <- if (ek == "rescaled") rescale_emulators(em0, check) else em0
      for (pool in pools) {
        fit <- suppressWarnings(calibrate(em, field, tb$iu, n_draws = 150, n_inner = 20, chains = 1, seed = 1,
                                          pool_levels = pool, registration_variance = rv && fk == "registered",
                                          quiet = TRUE))
        wf <- where_fails(fit)
        dt <- diff(fit$basis$t[1:2])
        row <- data.frame(seed = seed, field = fk, emulators = ek,
                          pool_levels = if (is.null(pool)) "none" else paste(range(pool), collapse = "-"),
                          registration_variance = rv && fk == "registered",
                          steps = round(sum(wf$end - wf$start) / dt),
                          longest = if (nrow(wf)) round(max(wf$end - wf$start) / dt) else 0,
                          credible = signif(max(attr(wf, "credible")$credible_bias), 3))
        print(row, row.names = FALSE)
        res <- rbind(res, row)
      }
    }
  }
}
cat("\nlongest flagged interval (grid steps) by seed\n")
res$case <- paste(res$field, res$emulators, res$pool_levels, sep = " / ")
print(stats::xtabs(longest ~ case + seed, res))
