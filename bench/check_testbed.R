# Statistical checks of the whole method on the suspension test bed, printed:
# coverage of the noise-free truth by the reality band, true inputs inside their
# posterior intervals, held-out coverage of predictions in new settings, band
# widths, and (with a hidden mechanism) whether the bias band excludes zero
# where the mechanism acts.
# With n_runs, the emulators are fitted to a larger design of the same
# simulator (a maximin Latin hypercube of n_runs - 1 points on the I/U ranges
# plus the nominal point) instead of the test bed's 66 runs of condition A;
# the registration reference stays condition A's runs.
#   Rscript bench/check_testbed.R [hidden] [n_draws] [n_inner] [n_runs]
suppressPackageStartupMessages(library(wavevalid))
options(wavevalid.quiet = TRUE)
args <- commandArgs(trailingOnly = TRUE)
hidden <- if (length(args) >= 1) args[1] else "none"
n_draws <- if (length(args) >= 2) as.integer(args[2]) else 500L
n_inner <- if (length(args) >= 3) as.integer(args[3]) else 100L
n_runs <- if (length(args) >= 4) as.integer(args[4]) else NA_integer_
clock <- function() as.numeric(proc.time()[["elapsed"]])
tb <- testbed_suspension(seed = 1, hidden = hidden)
w <- tb$windows
field <- register_curves(tb$A$field, tb$A$runs, w, knots_every = 2)
t0 <- clock()
runs <- tb$A$runs
if (!is.na(n_runs)) runs <- simulate_suspension(design_maximin(tb$iu, n_runs, seed = 2))
basis <- wavelet_basis(runs, field)
em <- fit_emulators(runs, basis)
t1 <- clock()
fit <- calibrate(em, field, tb$iu, n_draws = n_draws, n_inner = n_inner, chains = 2, seed = 1)
t2 <- clock()
cat(sprintf("hidden = %s; %d model runs; |I| = %d; emulators %.1f s; calibration %d x %d x 2 chains %.1f s\n", hidden,
            nrow(runs$design), length(basis$index), t1 - t0, n_draws, n_inner, t2 - t1))
print(fit)

# truth in registered time: the noise-free curve registered like the field data
truth <- field_runs(lapply(tb$truth$reality, function(y) matrix(y, nrow = 1)), tb$A$field$t)
truth_reg <- register_curves(truth, tb$A$runs, w, knots_every = 2)
r <- reality(fit)
cover <- function(band, curves) {
  vapply(names(curves), function(s) {
    b <- band[band$site == s, ]
    y <- curves[[s]]
    mean(sweep(y, 2, b$lower, ">=") & sweep(y, 2, b$upper, "<="))
  }, numeric(1))
}
proj <- lapply(truth_reg$curves, function(y) y %*% basis$Psi %*% t(basis$Psi))
cat("90% reality band covers the noise-free truth (registered) at:",
    sprintf("%s %.1f%%", names(truth_reg$curves), 100 * cover(r, truth_reg$curves)),
    "\n  and its projection on the retained basis at:",
    sprintf("%s %.1f%%", names(proj), 100 * cover(r, proj)), "\n")
X <- as.matrix(fit$draws)
true_in <- c(tb$truth$u, 0.5 + tb$truth$delta)
inside <- vapply(names(true_in), function(p) {
  q <- stats::quantile(X[, p], c(0.025, 0.975))
  true_in[[p]] >= q[1] && true_in[[p]] <= q[2]
}, logical(1))
cat(sprintf("true inputs inside their 95%% posterior intervals: %d of %d (%s outside)\n", sum(inside),
            length(inside), paste(names(inside)[!inside], collapse = ", ")))

pr <- predict(fit, type = "reality", seed = 1)
fr <- predict(fit, type = "field_run", seed = 1)
nv <- predict(fit, type = "new_vehicle", seed = 1)
med_width <- function(p) stats::median(p$summary$upper - p$summary$lower)
cat(sprintf("median 90%% band widths: new_vehicle %.3f > field_run %.3f > reality %.3f\n",
            med_width(nv), med_width(fr), med_width(pr)))
fB <- register_curves(tb$B$field, tb$A$runs, w, knots_every = 2)
for (b in c("additive", "multiplicative")) {
  pB <- predict(fit, type = "new_nominal", bias = b, new_runs = tb$B$runs, x_nom = tb$B$x_nom, seed = 1)
  cat(sprintf("condition B held-out replicates inside the 90%% new_nominal band (%s): %s\n", b,
              paste(sprintf("%s %.1f%%", names(fB$curves), 100 * cover(pB$summary, fB$curves)), collapse = ", ")))
}
fM <- register_curves(tb$added_mass$field, tb$A$runs, w, knots_every = 2)
pM <- predict(fit, type = "added_load", new_runs = tb$added_mass$runs, seed = 1)
cat(sprintf("added-mass field run inside the 90%% added_load band (D from the two runs): %s\n",
            paste(sprintf("%s %.1f%%", names(fM$curves), 100 * cover(pM$summary, fM$curves)), collapse = ", ")))
pE <- predict(fit, type = "added_load", delta = tb$added_mass$delta, seed = 1)
cat(sprintf("added-mass field run inside the 90%% added_load band (D from the emulators at each draw): %s\n",
            paste(sprintf("%s %.1f%%", names(fM$curves), 100 * cover(pE$summary, fM$curves)), collapse = ", ")))

wf <- where_fails(fit)
cat(sprintf("where_fails: %d intervals; longest %d grid steps\n", nrow(wf),
            if (nrow(wf)) as.integer(round(max(wf$end - wf$start) / diff(tb$A$field$t[1:2]))) else 0L))
print(utils::head(as.data.frame(wf), 8))
if (hidden != "none") {
  # where the mechanism acts: the difference it makes to reality
  eff <- testbed_signatures(true_in, hidden)[[1]]
  for (s in names(eff)) {
    acts <- abs(eff[[s]]) > 0.1 * max(abs(eff[[s]]))
    b <- bias(fit)
    b <- b[b$site == s, ]
    excl <- b$lower > 0 | b$upper < 0
    cat(sprintf("%s: bias band excludes zero at %.1f%% of the points where the mechanism acts, %.1f%% elsewhere\n",
                s, 100 * mean(excl[acts]), 100 * mean(excl[!acts])))
  }
  expl <- explain_bias(fit, testbed_signatures(colMeans(X)[fit$inputs]), seed = 1)
  print(expl)
}
