# How strongly the inputs and the log bias variances move together in the
# chains. With the default adjusted likelihood the inputs' steps take the
# likelihood to the power of the shared-error weight and the bias
# variances' steps take it whole; the two blocks are updated in turn, so a
# strong coupling between them slows the inputs. validate() with every
# default (two chains, the stopping rule) on the test beds, nothing hidden
# and the first mechanism hidden; with input_likelihood = "independent"
# (weight 1) beside it. For each case:
#   weight        the inputs' likelihood weight (1 when independent)
#   slowest       the slowest input, ess_per_draw its effective draws per
#                 saved draw (all chains), draws the draws per chain
#   cancor1/2     the two largest canonical correlations between the inputs
#                 and the log bias variances, over all saved draws
#   chance        what the largest would be by chance for that many draws
#                 and columns, about sqrt((p + q) / n)
#   r2_slowest    R^2 of the slowest input on the log bias variances
#   Rscript studies/coupling.R [beds=dosing,suspension] [seeds=1,2] [hidden=none,first]
#                              [likelihoods=adjusted,independent] [out=coupling.csv]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
args <- study_args(list(beds = "dosing,suspension", seeds = "1,2", hidden = "none,first",
                        likelihoods = "adjusted,independent", out = "coupling.csv"))
options(wavevalid.quiet = TRUE)
bed <- testbed_beds()
for (b in arg_names(args$beds)) for (h in arg_names(args$hidden)) for (seed in arg_numbers(args$seeds))
  for (lk in arg_names(args$likelihoods)) {
  hd <- if (h == "first") bed[[b]]$mechanisms()[1] else h
  tb <- bed[[b]]$make(seed = seed, hidden = hd)
  fit <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, features = bed[[b]]$features,
                                   bias = bias_control(input_likelihood = lk),
                                   sampler = sampler_control(quiet = TRUE), chains = 2, seed = 1))
  D <- as.matrix(fit$draws)
  z <- D[, fit$inputs, drop = FALSE]
  z <- z[, apply(z, 2, stats::sd) > 0, drop = FALSE]
  tcols <- grep("^tau2\\[", colnames(D), value = TRUE)
  lt <- log(D[, tcols, drop = FALSE])
  lt <- lt[, apply(lt, 2, stats::sd) > 0, drop = FALSE]
  cc <- stats::cancor(z, lt)$cor
  ess <- fit$ess[colnames(z)]
  slow <- names(which.min(ess))
  r2 <- summary(stats::lm(z[, slow] ~ lt))$r.squared
  row <- data.frame(bed = b, hidden = hd, seed = seed, likelihood = lk,
                    weight = round(fit$shared_errors$weight %||% 1, 3),
                    slowest = slow, ess_per_draw = round(min(ess) / nrow(D), 2), draws = nrow(fit$draws[[1]]),
                    cancor1 = round(cc[1], 2), cancor2 = round(cc[2], 2),
                    chance = round(sqrt((ncol(z) + ncol(lt)) / nrow(D)), 2), r2_slowest = round(r2, 2),
                    stringsAsFactors = FALSE)
  print(row, row.names = FALSE)
  utils::write.table(row, args$out, sep = ",", row.names = FALSE, append = file.exists(args$out),
                     col.names = !file.exists(args$out))
}
