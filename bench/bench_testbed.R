# Time to simulate the model runs of the suspension test bed.
#   R_LIBS=<lib> Rscript bench/bench_testbed.R
suppressPackageStartupMessages(library(wavevalid))
tb <- testbed_suspension(seed = 1, hidden = "none")
time_runs <- function(design, reps = 3L) {
  min(vapply(seq_len(reps), function(i) system.time(simulate_suspension(design))[["elapsed"]], numeric(1)))
}
tA <- time_runs(tb$A$runs$design)
tB <- time_runs(tb$B$runs$design)
one <- time_runs(tb$A$runs$design[66, , drop = FALSE], reps = 20L)
cat(sprintf("condition A: %3d runs in %.3f s (%.2f ms per run; target < 2 s)\n",
            nrow(tb$A$runs$design), tA, 1000 * tA / nrow(tb$A$runs$design)))
cat(sprintf("condition B: %3d runs in %.3f s (%.2f ms per run; target < 2 s)\n",
            nrow(tb$B$runs$design), tB, 1000 * tB / nrow(tb$B$runs$design)))
cat(sprintf("single run: %.2f ms\n", 1000 * one))
d <- data.frame(s_strut_friction = rep(1, 65))
tf <- min(replicate(3, system.time(simulate_suspension(d, mechanism = "strut_friction"))[["elapsed"]]))
cat(sprintf("65 runs with strut friction switched on: %.3f s (ratio to A: %.2f)\n", tf, tf / tA * 66 / 65))
tt <- min(replicate(3, system.time(testbed_suspension(seed = 2, hidden = "tire_liftoff"))[["elapsed"]]))
cat(sprintf("whole test bed (design search, 133 runs, reality, field data): %.2f s\n", tt))
