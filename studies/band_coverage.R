# Do the reality bands and the posterior of the inputs cover the truth, by
# emulator engine? Test bed with nothing hidden (the model at the true inputs
# is reality), per seed: condition A's field registered to the runs (knots
# every 2 time units), the wavelet basis of runs and field, the emulators of
# each engine, calibrate() with two chains of n_draws x n_inner. Per seed and
# engine:
#   cover      share of the points (all sites) where the 90% reality band
#              (reality(fit)) covers the noise-free truth tb$truth$reality,
#              registered like the field data (knots every 2 time units)
#   cover_raw  the same for the truth as simulated, not registered
#   width      median width of the 90% reality band
#   inputs_in  true inputs (c(tb$truth$u, 0.5 + tb$truth$delta), coded) inside
#              their central 95% posterior intervals, of 9
#   fit_s, cal_s  seconds to fit the emulators and to calibrate
# then the averages by engine. With n_runs other than 66 the emulators are
# fitted to simulate_suspension(design_maximin(tb$iu, n_runs, seed = 2)) and
# the field registered to those runs.
# With register_runs=TRUE the model runs are registered to the same reference
# as the field (the mean of the runs, same windows and knots) and the
# emulators fitted to the registered runs: model and field on one time axis.
# Targets of an honest engine: cover 85-95% on average and no seed below 75%,
# at least 8 of 9 inputs inside on average, median width at most twice the
# per-coefficient engine's.
#   Rscript studies/band_coverage.R [seeds=1:5] [engines=gasp,gasp_level] [n_draws=400] [n_inner=50] [n_runs=66] [register_runs=FALSE]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(seeds = "1:5", engines = "gasp,gasp_level", n_draws = "400", n_inner = "50", n_runs = "66", register_runs = "FALSE"))
seeds <- arg_numbers(opt$seeds)
engines <- arg_names(opt$engines)
n_draws <- as.integer(opt$n_draws)
n_inner <- as.integer(opt$n_inner)
n_runs <- as.integer(opt$n_runs)
register_runs <- as.logical(opt$register_runs)
options(wavevalid.quiet = TRUE)
future::plan(future::sequential)

band_case <- function(seed, engine) {
  tb <- testbed_suspension(seed = seed, hidden = "none")
  runs <- if (n_runs == 66L) tb$A$runs else simulate_suspension(design_maximin(tb$iu, n_runs, seed = 2))
  field <- register_curves(tb$A$field, runs, tb$windows, knots_every = 2)
  reference <- runs
  if (register_runs) runs <- register_curves(runs, reference, tb$windows, knots_every = 2)
  t0 <- clock()
  em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, field), engine = engine))
  t1 <- clock()
  fit <- suppressWarnings(calibrate(em, field, tb$iu, chains = 2, seed = 1,
                                    sampler = sampler_control(n_draws = n_draws, n_inner = n_inner)))
  t2 <- clock()
  truth <- field_runs(lapply(tb$truth$reality, function(y) matrix(y, nrow = 1)), tb$A$field$t)
  truth_reg <- register_curves(truth, reference, tb$windows, knots_every = 2)
  r <- reality(fit)
  X <- as.matrix(fit$draws)
  true_in <- true_inputs(tb, fit$inputs)
  stopifnot(all(fit$inputs %in% colnames(X)), all(X[, fit$inputs] >= 0 & X[, fit$inputs] <= 1))
  inside <- inputs_inside(X, true_in, fit$inputs)
  data.frame(seed = seed, engine = engine, cover = band_cover(r, truth_reg$curves),
             cover_raw = band_cover(r, truth$curves), width = stats::median(r$upper - r$lower),
             inputs_in = sum(inside), outside = paste(names(inside)[!inside], collapse = ","),
             fit_s = round(t1 - t0, 1), cal_s = round(t2 - t1, 1))
}

cat(sprintf("== band coverage: nothing hidden, seeds %s, %d model runs%s, 2 chains of %d x %d\n",
            opt$seeds, n_runs, if (register_runs) " (registered)" else "", n_draws, n_inner))
rows <- list()
for (seed in seeds) {
  for (engine in engines) {
    rows[[length(rows) + 1L]] <- band_case(seed, engine)
    x <- rows[[length(rows)]]
    cat(sprintf("seed %d %-11s cover %.3f (raw %.3f)  width %.3f  inputs in %d of 9 %s  fit %.1f s  calibration %.1f s\n",
                x$seed, x$engine, x$cover, x$cover_raw, x$width, x$inputs_in,
                if (nzchar(x$outside)) paste0("(out: ", x$outside, ")") else "", x$fit_s, x$cal_s))
  }
}
res <- do.call(rbind, rows)
cat("\naverages by engine:\n")
avg <- do.call(rbind, lapply(split(res, res$engine), function(d) {
  data.frame(engine = d$engine[1], cover = mean(d$cover), min_cover = min(d$cover), cover_raw = mean(d$cover_raw),
             width = stats::median(d$width), inputs_in = mean(d$inputs_in), fit_s = sum(d$fit_s),
             cal_s = sum(d$cal_s))
}))
avg$width_ratio <- avg$width / avg$width[avg$engine == engines[1]]
print(avg[match(engines, avg$engine), ], row.names = FALSE, digits = 3)
