# More data, tighter inputs? The suspension test bed with nothing hidden,
# calibrated on condition A alone and on A with the added-mass experiment
# (4 replicates, its x1 raised by 0.15), the same registered fields, basis
# and emulators; one chain of n_draws x n_inner, seed 1. Per seed and case:
#   var_u, var_all  summed posterior variance of the calibration inputs, of
#                   every input
#   in95            true inputs inside their 95% intervals (of 9)
#   weight          the inputs' likelihood weight for shared errors
#   reg_M           the registration variance the added-mass experiment's
#                   coefficients take, summed over its sites and coefficients
#   bias=independent: the inputs' likelihood unweighted (bias_control(input_likelihood =)).
#   check=base: the added-mass field without its own registration check, so
#   that it takes the base field's (as validate() gave experiments before it
#   checked their own registration).
#   Rscript studies/more_data.R [seeds=1:5] [n_draws=300] [n_inner=20] [bias=] [check=own]
#                               [out=studies/more_data.csv]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(seeds = "1:5", n_draws = "300", n_inner = "20", out = "studies/more_data.csv",
                       bias = "", check = "own"))
options(wavevalid.quiet = TRUE)
features <- testbed_beds()$suspension$features
rows <- list()
for (seed in arg_numbers(opt$seeds)) {
  tb <- testbed_suspension(seed, "none", n_added_mass = 4)
  knots <- diff(range(tb$A$field$t)) / 32
  dm <- tb$added_mass$delta
  field_A <- register_curves(tb$A$field, tb$A$runs, tb$windows, features = features, knots_every = knots,
                             check_runs = 5)
  d <- tb$A$runs$design
  for (p in names(dm)) d[[p]] <- d[[p]] + dm[[p]]
  field_M <- register_curves(tb$added_mass$field, simulate_suspension(d), tb$windows, features = features,
                             knots_every = knots, check_runs = 5)
  if (identical(opt$check, "base")) field_M$registration_check <- NULL
  basis <- wavelet_basis(tb$A$runs, field_A)
  em <- suppressWarnings(fit_emulators(tb$A$runs, basis))
  z_star <- true_inputs(tb)
  for (cond in c("A", "A+added_mass")) {
    exps <- if (cond == "A") NULL else list(added_mass = experiment(field_M, change = dm))
    bias <- if (nzchar(opt$bias)) bias_control(input_likelihood = opt$bias) else bias_control()
    fit <- suppressWarnings(calibrate(em, field_A, tb$iu, chains = 1, seed = 1, experiments = exps, bias = bias,
                                      sampler = sampler_control(n_draws = as.integer(opt$n_draws),
                                                                n_inner = as.integer(opt$n_inner), quiet = TRUE)))
    X <- as.matrix(fit$draws)[, fit$inputs]
    q <- apply(X, 2, stats::quantile, c(0.025, 0.975))
    zs <- z_star[fit$inputs]
    u <- fit$inputs[fit$iu$type[match(fit$inputs, fit$iu$name)] == "calibration"]
    v <- apply(X, 2, stats::var)
    rows[[length(rows) + 1L]] <- data.frame(seed = seed, case = cond, var_u = sum(v[u]), var_all = sum(v),
                                            in95 = sum(zs >= q[1, ] & zs <= q[2, ]),
                                            out = paste(fit$inputs[!(zs >= q[1, ] & zs <= q[2, ])], collapse = " "),
                                            weight = fit$shared_errors$weight %||% NA_real_,
                                            reg_M = if (is.null(exps)) NA_real_ else
                                              sum(unlist(fit$registration_var[grep("^added_mass/",
                                                                                   names(fit$registration_var))])))
    print(utils::tail(do.call(rbind, rows), 1))
  }
}
out <- do.call(rbind, rows)
utils::write.csv(out, opt$out, row.names = FALSE)
print(out, digits = 3)
