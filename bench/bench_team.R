# The chains of a calibration together in one process, a thread each, their
# emulator predictions made in step (sampler_control(together = TRUE)),
# against the same chains apart, each in a worker of a multisession plan
# (together = FALSE), run in turn on the synthetic problem of
# bench/bench_scale.R (its parts as validate() builds them: registered with
# a check on 5 model runs, so with the registration's shifts; the
# experiments registered to the runs). Prints, for each pair, the sampling
# time per cycle of each chain and the ratio apart / together, and checks
# that the two give the same draws.
#
# Run from the package root:
#   R_LIBS=<lib> Rscript bench/bench_team.R [size=large] [pairs=3] [n_draws=200] [n_inner=50] [burnin=1000]
# `size` one of bench_scale.R's named sizes (base, sites, points, runs,
# experiments, large). Two chains, seed 1, no start search.
library(wavevalid)
options(wavevalid.quiet = TRUE)
args <- commandArgs(trailingOnly = TRUE)
arg <- function(k, default) if (length(args) >= k) args[k] else default
size <- arg(1, "large")
pairs <- as.integer(arg(2, "3"))
n_draws <- as.integer(arg(3, "200"))
n_inner <- as.integer(arg(4, "50"))
burnin <- as.integer(arg(5, "1000"))

defs <- parse(file.path("bench", "bench_scale.R"))
keep <- c("sizes_all", "inputs", "u_true", "x_nom", "event_at", "windows", "doublet", "model", "lhs", "field_of",
          "problem", "register_all_experiments")
for (e in defs) {
  if (is.call(e) && identical(e[[1]], as.name("<-")) && as.character(e[[2]]) %in% keep) eval(e, globalenv())
}
d <- sizes_all[[size]]
if (is.null(d)) stop("unknown size ", size)
options(wavevalid.workers = 1)
t0 <- proc.time()[["elapsed"]]
pr <- problem(d[["S"]], d[["T"]], d[["K"]], d[["E"]])
ke <- diff(range(pr$field$t)) / 32
field <- suppressWarnings(register_curves(pr$field, pr$runs, pr$windows, features = c("min", "max"),
                                          knots_every = ke, check_runs = 5, landmark_site = "all"))
em <- suppressWarnings(fit_emulators(pr$runs, wavelet_basis(pr$runs, field), "gasp_level"))
ex <- NULL
if (!is.null(pr$experiments)) {
  ex <- register_all_experiments(pr$experiments, em, pr$runs, field, pr$iu, pr$windows,
                                 features = c("min", "max"), knots_every = ke)
}
cat(sprintf("%s: %d sites x %d points x %d runs x %d experiments, parts built in %.0f s\n", size, d[["S"]],
            d[["T"]], d[["K"]], d[["E"]], proc.time()[["elapsed"]] - t0))

run <- function(together) {
  if (together) future::plan(future::sequential) else future::plan(future::multisession, workers = 2)
  on.exit(future::plan(future::sequential))
  suppressWarnings(calibrate(em, field, pr$iu, experiments = ex, seed = 1, chains = 2,
                             sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, burnin = burnin,
                                                       n_search = 0, quiet = TRUE, together = together)))
}
cycles <- burnin + n_draws * n_inner
rows <- list()
ref <- NULL
for (i in seq_len(pairs)) {
  apart <- run(FALSE)
  together <- run(TRUE)
  for (f in list(apart, together)) {
    if (is.null(ref)) ref <- f$draws
    if (!identical(f$draws, ref)) stop("the draws differ between runs")
  }
  ms <- 1e3 * c(apart$sampling_seconds, together$sampling_seconds) / cycles
  rows[[i]] <- data.frame(pair = i, apart_ms = round(ms[1], 2), together_ms = round(ms[2], 2),
                          ratio = round(ms[1] / ms[2], 2))
}
cat(sprintf("two chains of %d draws x %d cycles after a burn-in of %d; ms per cycle of each chain (the same draws in every run):\n",
            n_draws, n_inner, burnin))
print(do.call(rbind, rows), row.names = FALSE)
