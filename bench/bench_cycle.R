# The sampler's cost per Metropolis-Hastings cycle against this machine's
# limit for the same work, on Site 1 of the suspension test bed (seed 1,
# condition A), with the per-coefficient emulators (engine "gasp") and the
# default per-level ones (engine "gasp_level", whose coefficients of a level
# share one correlation vector and one triangular solve).
#
# The work of one cycle (adaptive proposal, one thread): one emulator
# prediction at the proposed inputs (the distances to the design, K x p
# values with their logs; for every distinct correlation a correlation vector,
# K exp calls per input whose exponent is neither 1 nor 2 and K more; a dot
# product of K per coefficient for the means; a forward substitution on the
# packed Cholesky factor of every distinct correlation, K (K + 1) / 2 values
# read with one multiply-add each) and four passes of the likelihood over the
# coefficients (one log each: the proposal's, the two of each tau2 group step
# and the current one).
#
# The limit: the same numbers of exp and log calls in a tight vectorised loop
# (Eigen, by blocks of K values as the sampler evaluates them), a pass with
# one multiply-add per value over packed factors of the same size and number,
# and the dot products of the means on data held in cache; the fastest of
# several repetitions of each, summed. The sampler's cost: the difference of
# two calibrations that differ only in their number of cycles (start search
# and burn-in cancel), the fastest of `reps` pairs. Also printed: the time of
# each stage of the prediction (distances, correlation vectors and means,
# variances) measured alone on prior draws of the inputs.
#
# Run from the package root: R_LIBS=<lib> Rscript bench/bench_cycle.R
# [reps=3] [cycles=20000]. The timing loops (bench/cpp/limit.cpp) are
# compiled here against the package's headers in src/.
#
# With a third argument `large`: the same at the large size of
# bench/bench_scale.R (4 sites x 4096 points x 200 runs, a second experiment
# with x1 changed; its synthetic problem, read from that script), engine
# "gasp_level" only, every site of both experiments in the sampler: the limit
# is the sum over the 8 site-experiments of each one's limit (an
# experiment's site evaluates the base site's emulators at its own inputs),
# and the cycle is also measured with the base experiment alone, so that the
# second experiment's cost is the difference.
library(wavevalid)
options(wavevalid.quiet = TRUE)
args <- commandArgs(trailingOnly = TRUE)
reps <- if (length(args) >= 1) as.integer(args[1]) else 3L
n_cycles <- if (length(args) >= 2) as.integer(args[2]) else 20000L
large <- length(args) >= 3 && args[3] == "large"

# the package's flags (src/Makevars); make expands $(SHLIB_OPENMP_CXXFLAGS)
Sys.setenv(PKG_CPPFLAGS = paste0("-I", shQuote(normalizePath("src"))),
           PKG_CXXFLAGS = paste("-DEIGEN_PERMANENTLY_DISABLE_STUPID_WARNINGS -DEIGEN_DONT_PARALLELIZE",
                                "-Wno-ignored-attributes $(SHLIB_OPENMP_CXXFLAGS)"),
           PKG_LIBS = "$(SHLIB_OPENMP_CXXFLAGS)")
Rcpp::sourceCpp(file.path("bench", "cpp", "limit.cpp"))

if (large) {
  t0 <- proc.time()[["elapsed"]]
  defs <- parse(file.path("bench", "bench_scale.R"))
  keep <- c("sizes_all", "inputs", "u_true", "x_nom", "event_at", "windows", "doublet", "model", "lhs", "field_of",
            "problem", "register_all_experiments")
  for (e in defs) {
    if (is.call(e) && identical(e[[1]], as.name("<-")) && as.character(e[[2]]) %in% keep) eval(e, globalenv())
  }
  d <- sizes_all$large
  pr <- problem(d[["S"]], d[["T"]], d[["K"]], d[["E"]])
  ke <- diff(range(pr$field$t)) / 32
  field <- register_curves(pr$field, pr$runs, pr$windows, features = c("min", "max"), knots_every = ke)
  basis <- wavelet_basis(pr$runs, field)
  em <- suppressWarnings(fit_emulators(pr$runs, basis, "gasp_level"))
  ex <- register_all_experiments(pr$experiments, em, pr$runs, field, pr$iu, pr$windows,
                                 features = c("min", "max"), knots_every = ke)
  cat(sprintf("Large size: %d sites x %d coefficients, %d runs, %d inputs, 2 experiments (built in %.0f s)\n\n",
              length(em$banks), length(basis$index), nrow(em$design), length(em$inputs),
              proc.time()[["elapsed"]] - t0))
  prior <- as.data.frame(pr$iu)[match(em$inputs, pr$iu$name), ]
  set.seed(1)
  Z <- t(replicate(50, prior$lower + stats::runif(nrow(prior)) * (prior$upper - prior$lower)))
  lims <- lapply(em$banks, function(bank) {
    st <- bank_stage_times_cpp(bank, Z, 3L)
    K <- st[["K"]]
    n <- st[["n"]]
    lim <- cycle_limit_cpp(st[["n_exp"]], K * st[["p"]] + 4 * n, K, st[["n_uniq"]], n * K, K, 10L)
    c(lim, st[c("distances", "means", "variances", "n_uniq", "n")])
  })
  lim_site <- Reduce(`+`, lims)
  per_cycle_large <- function(experiments) {
    run <- function(n_draws) {
      system.time(suppressWarnings(calibrate(em, field, pr$iu, experiments = experiments, chains = 1, seed = 1,
                                             sampler = sampler_control(n_draws = n_draws, n_inner = 50, burnin = 1000,
                                                                       threads = 1, quiet = TRUE))))[["elapsed"]]
    }
    extra <- max(1L, n_cycles %/% 50L)
    d <- vapply(seq_len(reps), function(r) run(5L + extra) - run(5L), 0)
    min(d) / (extra * 50)
  }
  cyc1 <- per_cycle_large(NULL)
  cyc2 <- per_cycle_large(ex)
  cat(sprintf("per site (sum of 4): %.0f distinct correlations, %.0f coefficients\n", lim_site[["n_uniq"]], lim_site[["n"]]))
  cat(sprintf("  limit of one experiment: exp %.0f us + log %.0f us + factors %.0f us + means %.0f us = %.0f us\n",
              1e6 * lim_site[["exp"]], 1e6 * lim_site[["log"]], 1e6 * lim_site[["stream"]], 1e6 * lim_site[["dot"]],
              1e6 * sum(lim_site[c("exp", "log", "stream", "dot")])))
  cat(sprintf("  prediction alone, one experiment: distances %.0f us, correlation vectors and means %.0f us, variances %.0f us\n",
              1e6 * lim_site[["distances"]], 1e6 * lim_site[["means"]], 1e6 * lim_site[["variances"]]))
  one <- sum(lim_site[c("exp", "log", "stream", "dot")])
  out <- data.frame(experiments = c(1, 2), limit_us = 1e6 * c(one, 2 * one), cycle_us = 1e6 * c(cyc1, cyc2))
  out$ratio <- out$cycle_us / out$limit_us
  print(out, row.names = FALSE, digits = 3)
  cat(sprintf("the second experiment costs %.2f x the first (its coefficients: 1.00 x)\n", (cyc2 - cyc1) / cyc1))
  quit(save = "no")
}

t0 <- proc.time()[["elapsed"]]
tb <- testbed_suspension(seed = 1)
field <- register_curves(tb$A$field, tb$A$runs, tb$windows)
basis <- wavelet_basis(tb$A$runs, field)
field$curves <- field$curves["site1"]
iu <- tb$iu
engines <- c("gasp", "gasp_level")
emus <- lapply(stats::setNames(nm = engines), function(e) {
  em <- fit_emulators(tb$A$runs, basis, engine = e)
  em$banks <- em$banks["site1"]
  em
})
cat(sprintf("Test bed, Site 1: %d coefficients, %d runs, %d inputs (built in %.0f s)\n\n",
            length(basis$index), nrow(emus[[1]]$design), length(emus[[1]]$inputs),
            proc.time()[["elapsed"]] - t0))

prior <- as.data.frame(iu)[match(emus[[1]]$inputs, iu$name), ]
set.seed(1)
Z <- t(replicate(200, prior$lower + stats::runif(nrow(prior)) * (prior$upper - prior$lower)))

per_cycle <- function(em) {
  run <- function(n_draws) {
    system.time(calibrate(em, field, iu, chains = 1, seed = 1,
                          sampler = sampler_control(n_draws = n_draws, n_inner = 100, burnin = 1000, threads = 1, quiet = TRUE)))[["elapsed"]]
  }
  extra <- n_cycles %/% 100L
  d <- vapply(seq_len(reps), function(r) run(5L + extra) - run(5L), 0)
  min(d) / (extra * 100)
}

rows <- lapply(engines, function(e) {
  em <- emus[[e]]
  bank <- em$banks$site1
  st <- bank_stage_times_cpp(bank, Z, 5L)
  K <- st[["K"]]
  n <- st[["n"]]
  p <- st[["p"]]
  n_log <- K * p + 4 * n
  lim <- cycle_limit_cpp(st[["n_exp"]], n_log, K, st[["n_uniq"]], n * K, K, 20L)
  limit <- sum(lim)
  cyc <- per_cycle(em)
  cat(sprintf("engine \"%s\": %d coefficients, %d distinct correlations; per cycle %.0f exp, %.0f log, %.2f MB of packed factors\n",
              e, n, st[["n_uniq"]], st[["n_exp"]], n_log, 8 * st[["n_packed"]] / 1e6))
  cat(sprintf("  limit: exp %.1f us + log %.1f us + factors %.1f us + means %.1f us = %.1f us\n",
              1e6 * lim[["exp"]], 1e6 * lim[["log"]], 1e6 * lim[["stream"]], 1e6 * lim[["dot"]], 1e6 * limit))
  cat(sprintf("  prediction alone: distances %.1f us, correlation vectors and means %.1f us, variances %.1f us\n",
              1e6 * st[["distances"]], 1e6 * st[["means"]], 1e6 * st[["variances"]]))
  cat(sprintf("  sampler: %.1f us per cycle = %.2f x the limit\n\n", 1e6 * cyc, cyc / limit))
  data.frame(engine = e, limit_us = 1e6 * limit, cycle_us = 1e6 * cyc, ratio = cyc / limit)
})
print(do.call(rbind, rows), row.names = FALSE, digits = 3)
