# What explain_bias() says of each mechanism's signature on the suspension
# test bed: the share of it that the parameter shifts span (the attribute
# `absorbed`, in the regression's metric, at the fit's posterior mean inputs),
# next to its inclusion probability. Each case is validated as the diagnosis
# tests validate it (testbed_validation(): registered once, one chain of 150
# draws; pool_levels as given), the signatures simulated at the posterior mean
# inputs (n_draws = 50, seed 1). One row per seed, hidden mechanism and
# candidate; `hidden` marks the hidden one. Compare `absorbed` with the share
# of the true effect that the model's inputs absorb in the simulator itself
# (bench/check_identifiability.R).
#   Rscript bench/check_absorbed.R seeds=1:5 pool_levels=NULL
suppressPackageStartupMessages(library(wavevalid))
source("bench/args.R")
opts <- bench_args(list(seeds = "1:5", pool_levels = "NULL",
                        hidden = paste(c("none", testbed_mechanisms()), collapse = ",")))
seeds <- eval(parse(text = opts$seeds))
pool <- eval(parse(text = opts$pool_levels))
hidden_all <- strsplit(opts$hidden, ",", fixed = TRUE)[[1]]
options(wavevalid.quiet = TRUE)
ns <- asNamespace("wavevalid")

rows <- NULL
for (seed in seeds) {
  for (h in hidden_all) {
    fit <- ns$testbed_validation(h, seed, pool_levels = pool)$fit
    ex <- explain_bias(fit, testbed_signatures(ns$posterior_mean_inputs(fit)), n_draws = 50, seed = 1)
    ab <- attr(ex, "absorbed")
    ab$inclusion_prob <- ex$inclusion_prob[match(ab$candidate, ex$candidate)]
    ab <- cbind(seed = seed, hidden = h, ab[c("candidate", "absorbed", "inclusion_prob", "inputs")])
    ab$is_hidden <- ab$candidate == h
    rows <- rbind(rows, ab)
    cat(sprintf("seed %d, %-20s: %s\n", seed, h, paste(sprintf("%s %.2f (%.2f)", ab$candidate, ab$absorbed,
                                                               ab$inclusion_prob), collapse = "; ")))
  }
}
cat("\nabsorbed (inclusion probability) by candidate; * the hidden mechanism\n")
rows$cell <- sprintf("%.2f (%.2f)%s", rows$absorbed, rows$inclusion_prob, ifelse(rows$is_hidden, "*", ""))
wide <- stats::reshape(rows[c("seed", "hidden", "candidate", "cell")], idvar = c("seed", "hidden"),
                       timevar = "candidate", direction = "wide")
names(wide) <- sub("^cell\\.", "", names(wide))
print(wide, row.names = FALSE)
cat("\nmean absorbed share of each signature over all cases:\n")
print(round(tapply(rows$absorbed, rows$candidate, mean), 2))
