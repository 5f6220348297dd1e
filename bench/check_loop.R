# The diagnosis loop on the suspension test bed (seed 1) for one hidden
# mechanism, printed: the validation of the model without it (where_fails,
# explain_bias with all mechanism signatures and the automatic shifts), then
# the model with the mechanism, its strength an extra calibration input on
# [0, 1], re-validated on the same field data, and compare_validations() with
# condition B held out (new nominal inputs, field replicates never used).
# The emulators are fitted to n_runs runs of the simulator: a maximin Latin
# hypercube of n_runs - 1 points on the I/U ranges (and on [0, 1] for the
# strength) plus the nominal point; n_runs = 66 is the size of the test bed's
# condition A design. With register_after = "after" (the default) the model
# with the mechanism is validated on the field data registered to its own
# runs (and so are its held-out data); with "before" both models use the
# registration to the runs of the model without it. The condition B runs of
# the model with the mechanism spread its strength over the 99% posterior
# interval of the strength from condition A. refine = TRUE (the default)
# locates the landmarks between grid points (register_curves(refine = TRUE)).
#   Rscript bench/check_loop.R [hidden] [n_runs] [n_draws] [n_inner] [threads] [register_after] [refine]
suppressPackageStartupMessages(library(wavevalid))
args <- commandArgs(trailingOnly = TRUE)
hidden <- if (length(args) >= 1) args[1] else "progressive_bumpstop"
n_runs <- if (length(args) >= 2) as.integer(args[2]) else 200L
n_draws <- if (length(args) >= 3) as.integer(args[3]) else 300L
n_inner <- if (length(args) >= 4) as.integer(args[4]) else 50L
threads <- if (length(args) >= 5) as.integer(args[5]) else 1L
register_after <- if (length(args) >= 6) match.arg(args[6], c("after", "before")) else "after"
refine <- if (length(args) >= 7) as.logical(args[7]) else TRUE
options(wavevalid.quiet = TRUE, wavevalid.threads = threads)
clock <- function() as.numeric(proc.time()[["elapsed"]])
t00 <- clock()

tb <- testbed_suspension(seed = 1, hidden = hidden)
register <- function(field, ref) {
  tryCatch(register_curves(field, ref, tb$windows, knots_every = 2, refine = refine),
           wavevalid_error_input = function(e) {
             register_curves(field, ref, tb$windows, features = "max", knots_every = 2, refine = refine)
           })
}
field <- register(tb$A$field, tb$A$runs)
iu <- tb$iu
s_name <- paste0("s_", hidden)
iu_after <- iu_add(iu, s_name, lower = 0, upper = 1, nominal = 0.5)
design_after <- design_maximin(iu_after, n_runs, seed = 2)
design <- design_after[iu$name]

# before: the model without the mechanism
runs <- simulate_suspension(design)
em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs, field)))
before <- suppressWarnings(calibrate(em, field, iu, n_draws = n_draws, n_inner = n_inner, chains = 2, seed = 1))
print(before)
t <- before$basis$t
truth <- c(tb$truth$u, 0.5 + tb$truth$delta)[before$inputs]
post <- colMeans(as.matrix(before$draws))[before$inputs]
fails <- where_fails(before)
steps <- round((fails$end - fails$start) / diff(t[1:2]))
cat(sprintf("\n%s, %d runs: where_fails %d intervals, longest %d grid steps\n", hidden, n_runs, nrow(fails),
            max(c(0L, steps))))
if (hidden != "none") {
  effect <- testbed_signatures(truth, hidden)[[1]]
  for (s in names(effect)) {
    acts <- abs(effect[[s]]) > 0.1 * max(abs(effect[[s]]))
    w <- fails[fails$site == s, ]
    flagged <- Reduce(`|`, lapply(seq_len(nrow(w)), function(k) t >= w$start[k] & t < w$end[k]),
                      rep(FALSE, length(t)))
    cat(sprintf("  %s: flagged at %.1f%% of the points where it acts, %.1f%% elsewhere\n", s,
                100 * mean(flagged[acts]), 100 * mean(flagged[!acts])))
  }
}
ex <- explain_bias(before, testbed_signatures(post), seed = 1)
print(ex)
if (hidden == "none") quit(save = "no")

# after: the model with the mechanism, its strength calibrated
runs_after <- simulate_suspension(design_after, mechanism = hidden)
field_after <- if (register_after == "after") register(tb$A$field, runs_after) else field
em_after <- suppressWarnings(fit_emulators(runs_after, wavelet_basis(runs_after, field_after)))
after <- suppressWarnings(calibrate(em_after, field_after, iu_after, n_draws = n_draws, n_inner = n_inner,
                                    chains = 2, seed = 1))
print(after)

# condition B held out
set.seed(3)
design_B <- tb$B$runs$design
s_range <- stats::quantile(as.matrix(after$draws)[, s_name], c(0.005, 0.995))
design_B[[s_name]] <- s_range[1] + diff(s_range) * (sample(nrow(design_B)) - 0.5) / nrow(design_B)
runs_B <- simulate_suspension(design_B, mechanism = hidden)
p_before <- predict(before, type = "new_nominal", new_runs = tb$B$runs, x_nom = tb$B$x_nom, seed = 1)
p_after <- predict(after, type = "new_nominal", new_runs = runs_B, x_nom = tb$B$x_nom, seed = 1)
field_B <- register(tb$B$field, tb$B$runs)
field_B_after <- if (register_after == "after") register(tb$B$field, runs_B) else field_B
cat(sprintf("\n%s, %d runs, after-model registered to the %s-model runs\n", hidden, n_runs, register_after))
print(compare_validations(before, after, holdout = list(field = list(before = field_B, after = field_B_after),
                                                        before = p_before, after = p_after)))
cat(sprintf("total %.0f s\n", clock() - t00))
