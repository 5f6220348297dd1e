# Are the calibrated inputs honest when the model is right because the
# missing mechanism was added? Each test bed with one mechanism hidden; the
# model re-validated with that mechanism added as a calibration input (its
# strength s_<m> on [0, 1], 66 runs at a maximin design joined by the model's
# own runs with the strength at 0, the default emulators on the fit's basis,
# calibrated on the fit's registered field: the protocol of explain_bias()'s
# re-validated models), 2 chains of n_draws x n_inner, seed 1, with the
# inputs' likelihood independent (the default) and adjusted. Per bed,
# mechanism, seed and variant:
#   inputs_in  the model's own inputs (not the strength) inside their 95%
#              intervals, of 9 (suspension) or 6 (dosing)
#   outside    which were not
#   s_mean     posterior mean of the strength (reality's is 1, the bound of
#              its range, so no central interval holds it)
#   sd_ratio   median posterior sd / prior sd over the model's own inputs
#   weight     the inputs' likelihood weight
#   Rscript studies/shared_errors_added.R [beds=suspension,dosing] [seeds=1:2]
#       [hidden=tire_liftoff,strut_friction,digressive_damper,progressive_bumpstop,saturable_elimination,enterohepatic_recycling,induction]
#       [n_draws=300] [n_inner=30] [out=studies/shared_errors_added.csv]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(beds = "suspension,dosing", seeds = "1:2",
                       hidden = paste("tire_liftoff,strut_friction,digressive_damper,progressive_bumpstop",
                                      "saturable_elimination,enterohepatic_recycling,induction", sep = ","),
                       n_draws = "300", n_inner = "30", out = "studies/shared_errors_added.csv"))
beds <- arg_names(opt$beds)
seeds <- arg_numbers(opt$seeds)
hidden <- arg_names(opt$hidden)
n_draws <- as.integer(opt$n_draws)
n_inner <- as.integer(opt$n_inner)
options(wavevalid.quiet = TRUE)
future::plan(future::sequential)

one_case <- function(bed, hd, seed) {
  B <- testbed_beds()[[bed]]
  tb <- B$make(seed, hd)
  fit <- testbed_default_fit(tb, B$features, n_draws = 50L, n_inner = 5L)
  s_name <- paste0("s_", hd)
  iu_m <- iu_add(tb$iu, s_name, lower = 0, upper = 1, nominal = 0.5)
  runs <- B$simulate(design_maximin(iu_m, 66L, seed = 2), mechanism = hd)
  off <- tb$A$runs$design
  off[[s_name]] <- 0
  runs <- c(model_runs(off, tb$A$runs$curves, tb$A$runs$t), runs)
  em <- suppressWarnings(fit_emulators(runs, fit$basis))
  z_true <- true_inputs(tb)
  do.call(rbind, lapply(c("independent", "adjusted"), function(lik) {
    f <- suppressWarnings(calibrate(em, fit$field, iu_m, chains = 2, seed = 1,
                                    bias = bias_control(input_likelihood = lik),
                                    sampler = sampler_control(n_draws = n_draws, n_inner = n_inner)))
    X <- as.matrix(f$draws)
    own <- setdiff(f$inputs, s_name)
    inside <- inputs_inside(X, z_true, own)
    tab <- summary(f)$inputs
    data.frame(bed = bed, hidden = hd, seed = seed, variant = lik, inputs_in = sum(inside), p = length(own),
               outside = paste(names(inside)[!inside], collapse = ","), s_mean = round(mean(X[, s_name]), 3),
               sd_ratio = round(stats::median(tab$sd_ratio[tab$input %in% own]), 3),
               weight = round(f$shared_errors$weight %||% 1, 3))
  }))
}

rows <- list()
for (bed in beds) for (hd in hidden) {
  if (!hd %in% testbed_beds()[[bed]]$mechanisms()) next
  for (seed in seeds) {
    x <- one_case(bed, hd, seed)
    rows[[length(rows) + 1L]] <- x
    print(x, row.names = FALSE)
  }
}
out <- do.call(rbind, rows)
utils::write.csv(out, opt$out, row.names = FALSE)
cat("\n== by bed and variant\n")
agg <- do.call(rbind, lapply(split(out, list(out$bed, out$variant), drop = TRUE), function(d) {
  data.frame(bed = d$bed[1], variant = d$variant[1], cases = nrow(d),
             inputs_in = sprintf("%d of %d (min %d)", sum(d$inputs_in), sum(d$p), min(d$inputs_in)),
             share_in = round(sum(d$inputs_in) / sum(d$p), 2), s_mean = round(mean(d$s_mean), 2),
             sd_ratio = round(mean(d$sd_ratio), 2), weight = round(mean(d$weight), 3))
}))
print(agg, row.names = FALSE)
