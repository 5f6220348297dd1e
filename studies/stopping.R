# Chains that stop when they have enough, against the former fixed length
# (sampler_control(n_draws = 1000, n_inner = 200)): validate() with every
# other default, two chains, on the test beds, nothing hidden and one
# mechanism hidden. For each case and sampler:
#   secs          validate()'s wall time; sampling, the chains' alone
#   draws, rounds the draws per chain and the rounds they took
#   min_ess       the slowest input's ESS (all chains), max_rhat the largest R-hat
#   ess_per_sec   the slowest input's effective draws per second of sampling
#   inside90      the true inputs inside their 90% intervals
#   top           the first finding's kind; conflicts, timing, wide, longest as
#                 in studies/false_findings.R
#   Rscript studies/stopping.R [beds=dosing,suspension] [seeds=1] [hidden=none,first]
#                              [samplers=stopping,fixed_1000] [out=stopping.csv]
# samplers: stopping (the default), fixed_1000 (1000 x 200), stopping_<k>
# (the stopping rule with n_inner = k).
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
args <- study_args(list(beds = "dosing,suspension", seeds = "1", hidden = "none,first",
                        samplers = "stopping,fixed_1000", out = "stopping.csv"))
options(wavevalid.quiet = TRUE)
bed <- testbed_beds()
samplers <- lapply(stats::setNames(nm = arg_names(args$samplers)), function(nm) {
  if (nm == "stopping") return(sampler_control(quiet = TRUE))
  if (nm == "fixed_1000") return(sampler_control(n_draws = 1000, n_inner = 200, quiet = TRUE))
  sampler_control(n_inner = as.integer(sub("^stopping_", "", nm)), quiet = TRUE)
})
for (b in arg_names(args$beds)) {
  hidden <- unlist(lapply(arg_names(args$hidden), function(h) if (h == "first") bed[[b]]$mechanisms()[1] else h))
  for (hd in hidden) for (seed in arg_numbers(args$seeds)) for (sm in names(samplers)) {
    tb <- bed[[b]]$make(seed = seed, hidden = hd)
    t0 <- clock()
    fit <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, features = bed[[b]]$features,
                                     sampler = samplers[[sm]], chains = 2, seed = 1))
    secs <- clock() - t0
    wf <- where_fails(fit)
    cf <- attr(wf, "conflicts")
    tm <- attr(wf, "timing")
    dt <- diff(fit$basis$t[1:2])
    iv <- wf[wf$kind == "interval", ]
    ess <- fit$ess[fit$inputs]
    z <- true_inputs(tb, fit$inputs)
    X <- as.matrix(fit$draws)[, fit$inputs]
    q <- apply(X, 2, stats::quantile, c(0.05, 0.95))
    row <- data.frame(bed = b, hidden = hd, seed = seed, sampler = sm, secs = round(secs), sampling = round(fit$sampling_seconds),
                      draws = nrow(fit$draws[[1]]), rounds = fit$stopping$rounds %||% 1L,
                      min_ess = round(min(ess)), max_rhat = round(max(fit$rhat[fit$inputs]), 3),
                      ess_per_sec = round(min(ess) / fit$sampling_seconds, 2),
                      inside90 = sum(z >= q[1, ] & z <= q[2, ]), n_inputs = length(z),
                      longest = if (nrow(iv)) max(round((iv$end - iv$start) / dt)) else 0,
                      wide = any(attr(wf, "record_wide")$credible), conflicts = paste(cf$input[cf$conflict], collapse = "+"),
                      timing = if (is.null(tm)) 0L else sum(tm$flagged), top = if (nrow(wf)) wf$kind[1] else "none",
                      stringsAsFactors = FALSE)
    print(row, row.names = FALSE)
    utils::write.table(row, args$out, sep = ",", row.names = FALSE, append = file.exists(args$out),
                       col.names = !file.exists(args$out))
  }
}
