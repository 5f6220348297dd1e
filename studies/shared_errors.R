# Are the calibrated inputs honest when the model is right, and what do the
# errors that many coefficients share do to them? Both test beds with nothing
# hidden, condition A, the default protocol (landmarks in the event windows,
# a knot every 1/32 of the record, default basis and emulators), two chains
# of n_draws x n_inner, seed 1. Variants:
#   independent   the defaults: the method's likelihood, coefficients independent
#   adjusted      calibrate(input_likelihood = "adjusted"): the inputs'
#                 likelihood weighted by the magnitude adjustment for shared errors
#   reg_indep     the model runs registered to the same reference as the field
#                 (their mean, same windows and knots) and the emulators fitted
#                 to them: model and field on one time axis; independent
#   reg_adjusted  the same, with input_likelihood = "adjusted"
# Per bed, seed and variant:
#   inputs_in  true inputs inside their 95% posterior intervals (of p)
#   outside    which inputs were not
#   sd_ratio   median over the inputs of posterior sd / prior sd
#   weight     the inputs' likelihood weight (1: independent)
#   cover      share of points where the 90% reality band covers the noise-free
#              truth registered like the field
#   width      median width of that band
#   secs       seconds for the fit (registration, basis, emulators, calibration)
#   longest    where_fails(): the longest localised interval, in grid steps
#   record     where_fails(): a credible record-wide bias at some site
#   overlap    with a mechanism hidden: a localised interval overlaps where it acts
# With hidden=<mechanisms>, each bed's mechanisms named there are hidden in
# turn (the inputs are then not expected inside their intervals; the columns
# of where_fails() tell what the weight does to the diagnosis).
#   Rscript studies/shared_errors.R [beds=suspension,dosing] [seeds=1:5] [hidden=none]
#       [variants=independent,adjusted,reg_indep,reg_adjusted] [n_draws=300] [n_inner=30]
#       [out=studies/shared_errors.csv]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(beds = "suspension,dosing", seeds = "1:5", hidden = "none",
                       variants = "independent,adjusted,reg_indep,reg_adjusted", n_draws = "300",
                       n_inner = "30", out = "studies/shared_errors.csv"))
beds <- arg_names(opt$beds)
seeds <- arg_numbers(opt$seeds)
variants <- arg_names(opt$variants)
hidden <- arg_names(opt$hidden)
n_draws <- as.integer(opt$n_draws)
n_inner <- as.integer(opt$n_inner)
options(wavevalid.quiet = TRUE)
future::plan(future::sequential)


one_case <- function(bed, seed, variant, hd) {
  B <- testbed_beds()[[bed]]
  tb <- B$make(seed, hd)
  knots <- diff(range(tb$A$field$t)) / 32
  t0 <- clock()
  field <- register_curves(tb$A$field, tb$A$runs, tb$windows, features = B$features, knots_every = knots)
  runs <- tb$A$runs
  if (startsWith(variant, "reg_")) {
    runs <- suppressWarnings(register_curves(runs, tb$A$runs, tb$windows, features = B$features,
                                             knots_every = knots))
  }
  em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, field)))
  lik <- if (variant %in% c("adjusted", "reg_adjusted")) "adjusted" else "independent"
  fit <- suppressWarnings(calibrate(em, field, tb$iu, chains = 2, seed = 1,
                                    bias = bias_control(input_likelihood = lik),
                                    sampler = sampler_control(n_draws = n_draws, n_inner = n_inner)))
  secs <- clock() - t0
  truth <- field_runs(lapply(tb$truth$reality, function(y) matrix(y, nrow = 1)), tb$A$field$t)
  truth_reg <- register_curves(truth, tb$A$runs, tb$windows, features = B$features, knots_every = knots)
  r <- reality(fit)
  X <- as.matrix(fit$draws)
  z_true <- true_inputs(tb, fit$inputs)
  inside <- inputs_inside(X, z_true, fit$inputs)
  tab <- summary(fit)$inputs
  wf <- where_fails(fit)
  overlap <- NA
  if (hd != "none") {
    eff <- B$signatures(true_inputs(tb, fit$inputs), hd)[[1]]
    overlap <- any(flagged_share(wf, eff) > 0, na.rm = TRUE)
  }
  data.frame(bed = bed, hidden = hd, seed = seed, variant = variant, inputs_in = sum(inside), p = length(inside),
             outside = paste(names(inside)[!inside], collapse = ","),
             sd_ratio = round(stats::median(tab$sd_ratio), 3),
             weight = round(fit$shared_errors$weight %||% 1, 3),
             cover = round(band_cover(r, truth_reg$curves), 3), width = signif(stats::median(r$upper - r$lower), 3),
             secs = round(secs), longest = longest_steps(wf), record = any(attr(wf, "record_wide")$credible),
             overlap = overlap)
}

rows <- list()
for (bed in beds) for (hd in hidden) for (seed in seeds) for (variant in variants) {
  if (hd != "none" && !hd %in% testbed_beds()[[bed]]$mechanisms()) next
  x <- one_case(bed, seed, variant, hd)
  rows[[length(rows) + 1L]] <- x
  print(x, row.names = FALSE)
}
out <- do.call(rbind, rows)
utils::write.csv(out, opt$out, row.names = FALSE)
cat("\n== by bed and variant\n")
agg <- do.call(rbind, lapply(split(out, list(out$bed, out$hidden, out$variant), drop = TRUE), function(d) {
  data.frame(bed = d$bed[1], hidden = d$hidden[1], variant = d$variant[1], seeds = nrow(d),
             inputs_in = sprintf("%d of %d (min %d)", sum(d$inputs_in), sum(d$p), min(d$inputs_in)),
             share_in = round(sum(d$inputs_in) / sum(d$p), 2), sd_ratio = round(mean(d$sd_ratio), 2),
             weight = round(mean(d$weight), 3), cover = round(mean(d$cover), 3), cover_min = min(d$cover),
             width = signif(mean(d$width), 3), longest = paste(d$longest, collapse = ","),
             record = sum(d$record), overlap = sum(d$overlap))
}))
print(agg, row.names = FALSE)
