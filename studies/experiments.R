# Does a second experiment separate a missing mechanism from the inputs that
# mimic it? The suspension test bed with a mechanism hidden, calibrated on
# condition A alone and on condition A with the added-mass experiment
# (experiment(), its x1 raised by 0.15, n_mass replicates), both with the
# default protocol (landmarks min and max in the event windows, knots every
# 1/32 of the record, default basis and emulators; one chain of
# n_draws x n_inner, seed 1). Per case and condition:
#   dist       rms distance (coded) of the posterior mean inputs from the truth
#   in95       true inputs inside their 95% posterior intervals (of 9)
#   absorbed_A share of the mechanism's effect in condition A that the move of
#              the inputs from the truth to the posterior mean reproduces, in
#              the simulator: the projection <d, e> / |e|^2 of that move's
#              effect d = model(z_hat) - model(z*) on the mechanism's effect
#              e = reality - model(z*), over both sites (1: the inputs mimic
#              the mechanism fully; 0: not at all)
#   absorbed_M the same in the added-mass condition (inputs plus the change)
#   fit_A      1 - |reality - model(z_hat)|^2 / |e|^2 in condition A: how much
#              closer to reality the model is at the posterior mean than at the
#              truth (negative: farther)
#   c1_A       a localised interval of where_fails() at a site of condition A
#              overlaps where the mechanism acts there (flagged_share() of its
#              effect at the true inputs)
#   p_hidden, top, other, p_none
#              explain_bias() with the model re-validated with each mechanism
#              (explain=TRUE): the hidden mechanism's probability, the leading
#              mechanism, the largest other probability, P(no mechanism). The
#              re-validated models are calibrated on the same experiments as
#              the fit.
# conditions: A (condition A alone), A+added_mass (one bias per experiment,
# level variances shared: the default), A+added_mass_shared (one bias shared
# by the two experiments).
#   Rscript studies/experiments.R [hidden=digressive_damper,progressive_bumpstop] [seeds=1:5]
#                                 [n_mass=4] [explain=TRUE] [n_draws=150] [n_inner=20]
#                                 [conditions=A,A+added_mass] [out=studies/experiments.csv]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(hidden = "digressive_damper,progressive_bumpstop", seeds = "1:5", n_mass = "4",
                       explain = "TRUE", n_draws = "150", n_inner = "20", conditions = "A,A+added_mass",
                       out = "studies/experiments.csv"))
conditions <- arg_names(opt$conditions)
stopifnot(all(conditions %in% c("A", "A+added_mass", "A+added_mass_shared")))
hidden <- arg_names(opt$hidden)
seeds <- arg_numbers(opt$seeds)
n_mass <- as.integer(opt$n_mass)
with_explain <- arg_flag(opt$explain)
n_draws <- as.integer(opt$n_draws)
n_inner <- as.integer(opt$n_inner)
options(wavevalid.quiet = TRUE)

features <- testbed_beds()$suspension$features
flat <- function(curves) unlist(curves, use.names = FALSE)
model_at <- function(z) flat(simulate_suspension(as.data.frame(t(z)))$curves)

one_case <- function(hd, seed) {
  tb <- testbed_suspension(seed, hd, n_added_mass = n_mass)
  knots <- diff(range(tb$A$field$t)) / 32
  dm <- tb$added_mass$delta
  field_A <- register_curves(tb$A$field, tb$A$runs, tb$windows, features = features, knots_every = knots)
  d <- tb$A$runs$design
  for (p in names(dm)) d[[p]] <- d[[p]] + dm[[p]]
  field_M <- register_curves(tb$added_mass$field, simulate_suspension(d), tb$windows, features = features,
                             knots_every = knots)
  basis <- wavelet_basis(tb$A$runs, field_A)
  em <- suppressWarnings(fit_emulators(tb$A$runs, basis))
  z_star <- true_inputs(tb)
  e_A <- flat(tb$truth$reality) - model_at(z_star)
  z_star_M <- z_star
  z_star_M[names(dm)] <- z_star_M[names(dm)] + dm
  e_M <- flat(tb$truth$reality_added_mass) - model_at(z_star_M)
  mech <- testbed_mechanisms()
  refit_em <- NULL
  if (with_explain) {
    refit_em <- lapply(mech, function(m) {
      s_name <- paste0("s_", m)
      iu_m <- iu_add(tb$iu, s_name, lower = 0, upper = 1, nominal = 0.5)
      runs <- simulate_suspension(design_maximin(iu_m, 66L, seed = 2), mechanism = m)
      off <- tb$A$runs$design
      off[[s_name]] <- 0
      runs <- c(model_runs(off, tb$A$runs$curves, tb$A$runs$t), runs)
      list(iu = iu_m, em = suppressWarnings(fit_emulators(runs, basis)))
    })
    names(refit_em) <- mech
  }
  rows <- list()
  for (cond in conditions) {
    t0 <- clock()
    exps <- if (cond == "A") NULL else list(added_mass = experiment(field_M, change = dm))
    eb <- if (cond == "A+added_mass_shared") "shared" else "own"
    fit <- suppressWarnings(calibrate(em, field_A, tb$iu, chains = 1, seed = 1, experiments = exps,
                                      bias = bias_control(experiment_bias = eb),
                                      sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, quiet = TRUE)))
    X <- as.matrix(fit$draws)[, fit$inputs]
    zhat <- colMeans(X)
    q <- apply(X, 2, stats::quantile, c(0.025, 0.975))
    zs <- z_star[fit$inputs]
    zhat_M <- zhat
    zhat_M[names(dm)] <- zhat_M[names(dm)] + dm
    r_A <- flat(tb$truth$reality) - model_at(zhat)
    r_M <- flat(tb$truth$reality_added_mass) - model_at(zhat_M)
    row <- data.frame(hidden = hd, seed = seed, condition = cond, n_mass = if (cond == "A") 0L else n_mass,
                      dist = sqrt(mean((zhat - zs)^2)), in95 = sum(zs >= q[1, ] & zs <= q[2, ]),
                      absorbed_A = sum((e_A - r_A) * e_A) / sum(e_A^2),
                      absorbed_M = sum((e_M - r_M) * e_M) / sum(e_M^2), fit_A = 1 - sum(r_A^2) / sum(e_A^2),
                      p_hidden = NA_real_, top = NA_character_, other = NA_real_, p_none = NA_real_)
    if (with_explain) {
      refits <- lapply(refit_em, function(r) {
        suppressWarnings(calibrate(r$em, field_A, r$iu, chains = 1, seed = 1, experiments = exps,
                                   bias = bias_control(experiment_bias = eb),
                                   sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, quiet = TRUE)))
      })
      ex <- explain_bias(fit, refits)
      tab <- as.data.frame(unclass(ex))
      row$p_hidden <- tab$inclusion_prob[tab$candidate == hd]
      row$top <- tab$candidate[1]
      row$other <- max(tab$inclusion_prob[tab$candidate != hd])
      row$p_none <- with(attr(ex, "subsets"), probability[subset == "(none)"])
    }
    eff <- testbed_signatures(z_star, hd)[[1]]
    row$c1_A <- any(flagged_share(where_fails(fit), eff) > 0, na.rm = TRUE)
    row$seconds <- round(clock() - t0)
    print(row, row.names = FALSE)
    rows[[cond]] <- row
  }
  do.call(rbind, rows)
}

# A case whose registration or fit fails is recorded with the error's first line.
for (hd in hidden) for (seed in seeds) {
  res <- tryCatch(one_case(hd, seed), error = function(e) {
    message(hd, " seed ", seed, ": ", conditionMessage(e))
    data.frame(hidden = hd, seed = seed, condition = "error", n_mass = n_mass, dist = NA, in95 = NA,
               absorbed_A = NA, absorbed_M = NA, fit_A = NA, p_hidden = NA, top = NA, other = NA, p_none = NA,
               c1_A = NA, seconds = NA, error = strsplit(conditionMessage(e), "\n")[[1]][1])
  })
  if (is.null(res$error)) res$error <- NA_character_
  utils::write.table(res, opt$out, sep = ",", row.names = FALSE, append = file.exists(opt$out),
                     col.names = !file.exists(opt$out))
}
