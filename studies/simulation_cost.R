# Is the suspension test bed cheap enough for the studies and tests that
# simulate it again and again (target: under 2 s for a condition's runs)?
# Times the simulation of condition A's 66 and condition B's runs (the best of
# `reps`), one run, 65 runs with strut friction switched on, and the whole
# test bed (design search, runs, reality, field data).
#   Rscript studies/simulation_cost.R [reps=3]
suppressPackageStartupMessages(library(wavevalid))
source("studies/args.R")
opt <- study_args(list(reps = "3"))
reps <- as.integer(opt$reps)
tb <- testbed_suspension(seed = 1, hidden = "none")
time_runs <- function(design, reps) {
  min(vapply(seq_len(reps), function(i) system.time(simulate_suspension(design))[["elapsed"]], numeric(1)))
}
tA <- time_runs(tb$A$runs$design, reps)
tB <- time_runs(tb$B$runs$design, reps)
one <- time_runs(tb$A$runs$design[66, , drop = FALSE], reps = 20L)
cat(sprintf("condition A: %3d runs in %.3f s (%.2f ms per run; target < 2 s)\n",
            nrow(tb$A$runs$design), tA, 1000 * tA / nrow(tb$A$runs$design)))
cat(sprintf("condition B: %3d runs in %.3f s (%.2f ms per run; target < 2 s)\n",
            nrow(tb$B$runs$design), tB, 1000 * tB / nrow(tb$B$runs$design)))
cat(sprintf("single run: %.2f ms\n", 1000 * one))
d <- data.frame(s_strut_friction = rep(1, 65))
tf <- min(replicate(reps, system.time(simulate_suspension(d, mechanism = "strut_friction"))[["elapsed"]]))
cat(sprintf("65 runs with strut friction switched on: %.3f s (ratio to A: %.2f)\n", tf, tf / tA * 66 / 65))
tt <- min(replicate(reps, system.time(testbed_suspension(seed = 2, hidden = "tire_liftoff"))[["elapsed"]]))
cat(sprintf("whole test bed (design search, 133 runs, reality, field data): %.2f s\n", tt))
