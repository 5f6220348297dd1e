# To what is a further experiment's field data registered? validate() with
# an experiment that has no `reference` registers its field data to the
# model in the experiment's own condition, as the emulators predict it (the
# runs with their retained coefficients moved to the emulators' means at the
# runs' inputs plus the change). The suspension test bed with nothing
# hidden, the added mass with n_mass replicates, validate() with the default
# protocol (landmarks min and max in the event windows, knots every 1/32 of
# the record, default basis and emulators; chains x n_draws x n_inner,
# seed 1). Conditions:
#   A               condition A alone
#   A+default       A and experiment(field, change = delta), as on the help
#                   page: registered to the emulators' prediction (the default)
#   A+true_runs     A and the experiment with reference = the simulator's runs
#                   of condition A's design with the change
#   A+base_runs     A and the experiment with reference = condition A's runs
#                   (what validate() did before the default changed)
# Per seed and condition:
#   in95            true inputs inside their 95% posterior intervals (of 9)
#   u1_in, u2_in    the true u1, u2 inside their 95% intervals
#   var_u1, var_u2  posterior variance of u1, u2 over that of condition A alone
#   u1_lo ... u2_hi the 95% intervals of u1 and u2
#   knot_dt         registration of the experiment's replicates against the
#                   one to the true runs with the change: largest difference of
#                   the warps' knot times (0 for A+true_runs, NA for A)
#   reg_rms         rms difference of the registered curves from those
#                   registered to the true runs with the change, both sites
# With choices=TRUE, per seed (no further fit: the emulators of condition
# A's fit, which are those validate() uses for the added mass), the
# registration of the added mass's replicates to references built otherwise,
# against the one to the true runs with the change:
#   base_runs       condition A's runs
#   default         the emulators at every run's inputs plus the change, each
#                   run's part outside the basis kept (validate()'s default)
#   clamped         the same, the changed inputs moved back into the runs'
#                   range
#   left_out        the same, the runs the change moves outside the range
#                   left out
#   basis_only      the emulators at every run's inputs plus the change,
#                   without the runs' part outside the basis
#   lm_dt           largest difference of the reference's landmark times
#                   (sub-grid, refine = TRUE) from the true runs' (the
#                   registration's own, on the grid, agree for every choice)
#   knot_mean, knot_max  mean and largest difference of the warps' knot times
#   reg_rms         as above
#   Rscript studies/experiment_reference.R [seeds=1:5] [n_mass=4] [chains=2] [n_draws=400]
#                                          [n_inner=100] [conditions=A,A+default,A+true_runs]
#                                          [choices=TRUE] [out=studies/experiment_reference.csv]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(seeds = "1:5", n_mass = "4", chains = "2", n_draws = "400", n_inner = "100",
                       conditions = "A,A+default,A+true_runs", choices = "TRUE",
                       out = "studies/experiment_reference.csv"))
conditions <- arg_names(opt$conditions)
stopifnot("A" %in% conditions, all(conditions %in% c("A", "A+default", "A+true_runs", "A+base_runs")))
seeds <- arg_numbers(opt$seeds)
n_mass <- as.integer(opt$n_mass)
chains <- as.integer(opt$chains)
n_draws <- as.integer(opt$n_draws)
n_inner <- as.integer(opt$n_inner)
with_choices <- arg_flag(opt$choices)
options(wavevalid.quiet = TRUE)

rms_sites <- function(a, b) sqrt(mean(unlist(Map(function(x, y) (x - y)^2, a, b))))

# Condition A's runs with their retained coefficients at the emulators' means
# at `design` (rows: the runs'), their part outside the basis added unless
# `outside` is FALSE; rows `keep` only.
emulated_runs <- function(fit, runs, design, outside = TRUE, keep = TRUE) {
  out <- runs
  for (s in names(runs$curves)) {
    y <- runs$curves[[s]]
    m <- wavelet_reconstruct(fit$basis, predict(fit$emulators, design, site = s)$mean)
    # (in validate()'s order of operations: the knot search can turn on the last bit)
    if (outside) m <- m + (y - wavelet_reconstruct(fit$basis, wavelet_coef(fit$basis, y)))
    out$curves[[s]] <- m[keep, , drop = FALSE]
  }
  out$design <- design[keep, , drop = FALSE]
  out
}

# The registration of the added mass's replicates to each reference choice
# against the one to the true runs `true_runs` (see the header).
reference_choices <- function(tb, fit, d, true_runs, knots) {
  runs <- tb$A$runs
  moved <- rep(FALSE, nrow(d))
  dc <- d
  for (p in names(tb$added_mass$delta)) {
    r <- range(runs$design[[p]])
    moved <- moved | d[[p]] < r[1] | d[[p]] > r[2]
    dc[[p]] <- pmin(pmax(d[[p]], r[1]), r[2])
  }
  refs <- list(base_runs = runs, default = emulated_runs(fit, runs, d), clamped = emulated_runs(fit, runs, dc),
               left_out = emulated_runs(fit, runs, d, keep = !moved),
               basis_only = emulated_runs(fit, runs, d, outside = FALSE))
  reg <- function(ref, refine = FALSE) {
    register_curves(tb$added_mass$field, ref, tb$windows, knots_every = knots, refine = refine)
  }
  to_true <- reg(true_runs)
  lm_true <- reg(true_runs, refine = TRUE)$warps
  lm_true <- lm_true[lm_true$feature != "fitted" & lm_true$replicate == 1, ]
  do.call(rbind, lapply(names(refs), function(nm) {
    r <- reg(refs[[nm]])
    lm <- reg(refs[[nm]], refine = TRUE)$warps
    lm <- lm[lm$feature != "fitted" & lm$replicate == 1, ]
    dt <- abs(r$warps$t_before - to_true$warps$t_before)
    data.frame(seed = tb$truth$seed, choice = nm, runs = nrow(refs[[nm]]$design),
               lm_dt = max(abs(lm$t_after - lm_true$t_after)), knot_mean = mean(dt), knot_max = max(dt),
               reg_rms = rms_sites(r$curves, to_true$curves))
  }))
}

one_seed <- function(seed) {
  tb <- testbed_suspension(seed, "none", n_added_mass = n_mass)
  dm <- tb$added_mass$delta
  d <- tb$A$runs$design
  for (p in names(dm)) d[[p]] <- d[[p]] + dm[[p]]
  true_runs <- simulate_suspension(d)
  knots <- diff(range(tb$A$field$t)) / 32
  to_true <- register_curves(tb$added_mass$field, true_runs, tb$windows, knots_every = knots)
  z_star <- true_inputs(tb)
  rows <- list()
  var_A <- NULL
  choices <- NULL
  for (cond in conditions) {
    t0 <- clock()
    reference <- switch(cond, "A+true_runs" = true_runs, "A+base_runs" = tb$A$runs, NULL)
    exps <- if (cond != "A") list(added_mass = experiment(tb$added_mass$field, change = dm, reference = reference))
    fit <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, chains = chains,
                                     seed = 1, experiments = exps,
                                     sampler = sampler_control(n_draws = n_draws, n_inner = n_inner)))
    X <- as.matrix(fit$draws)[, fit$inputs]
    q <- apply(X, 2, stats::quantile, c(0.025, 0.975))
    zs <- z_star[fit$inputs]
    inside <- zs >= q[1, ] & zs <= q[2, ]
    v <- apply(X[, c("u1", "u2")], 2, stats::var)
    if (cond == "A") var_A <- v
    if (cond == "A" && with_choices) choices <- reference_choices(tb, fit, d, true_runs, knots)
    row <- data.frame(seed = seed, condition = cond, in95 = sum(inside), u1_in = inside[["u1"]],
                      u2_in = inside[["u2"]], var_u1 = v[["u1"]] / var_A[["u1"]], var_u2 = v[["u2"]] / var_A[["u2"]],
                      u1_lo = q[1, "u1"], u1_hi = q[2, "u1"], u2_lo = q[1, "u2"], u2_hi = q[2, "u2"],
                      u1_true = zs[["u1"]], u2_true = zs[["u2"]], knot_dt = NA_real_, reg_rms = NA_real_)
    if (cond != "A") {
      # the experiment's field data as validate() registered them (the fit
      # keeps the curves, not the warps: the warps come from registering
      # again to the same reference)
      reg <- lapply(names(to_true$curves), function(s) fit$field$curves[[paste0("added_mass/", s)]])
      row$reg_rms <- rms_sites(reg, to_true$curves)
      # the default reference rebuilt on the exported API
      ref <- if (is.null(reference)) emulated_runs(fit, tb$A$runs, d) else reference
      again <- register_curves(tb$added_mass$field, ref, tb$windows, knots_every = knots)
      stopifnot(isTRUE(all.equal(again$curves, setNames(reg, names(to_true$curves)), check.attributes = FALSE)))
      row$knot_dt <- max(abs(again$warps$t_before - to_true$warps$t_before))
    }
    row$seconds <- round(clock() - t0)
    print(row, row.names = FALSE, digits = 3)
    rows[[cond]] <- row
  }
  list(fits = do.call(rbind, rows), choices = choices)
}

append_csv <- function(x, file) {
  utils::write.table(x, file, sep = ",", row.names = FALSE, append = file.exists(file), col.names = !file.exists(file))
}
out_choices <- sub("(\\.csv)?$", "_choices.csv", opt$out)
res <- list()
choices <- list()
for (seed in seeds) {
  r <- one_seed(seed)
  append_csv(r$fits, opt$out)
  if (!is.null(r$choices)) {
    print(r$choices, row.names = FALSE, digits = 3)
    append_csv(r$choices, out_choices)
  }
  res[[length(res) + 1L]] <- r$fits
  choices[[length(choices) + 1L]] <- r$choices
}
res <- do.call(rbind, res)
if (with_choices) {
  choices <- do.call(rbind, choices)
  cat("\nReference choices, over the seeds: median of lm_dt, knot_mean, knot_max, reg_rms\n")
  print(stats::aggregate(cbind(lm_dt, knot_mean, knot_max, reg_rms) ~ choice, choices, stats::median),
        row.names = FALSE, digits = 3)
}
cat("\nInputs covered (of 9) and posterior variance of u1, u2 over condition A's, by seed:\n")
tab <- res[, c("seed", "condition", "in95", "u1_in", "u2_in", "var_u1", "var_u2", "knot_dt", "reg_rms")]
print(tab, row.names = FALSE, digits = 3)
cat("\nBy condition: inputs covered, true u1 / u2 covered, median variance ratio of u1 / u2:\n")
print(do.call(rbind, lapply(split(res, factor(res$condition, conditions)), function(r) {
  data.frame(condition = r$condition[1], in95 = sprintf("%d of %d", sum(r$in95), 9L * nrow(r)),
             u1_in = sum(r$u1_in), u2_in = sum(r$u2_in), var_u1 = stats::median(r$var_u1),
             var_u2 = stats::median(r$var_u2))
})), row.names = FALSE, digits = 3)
