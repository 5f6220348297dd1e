# How well the field replicates are registered on the suspension test bed,
# whose true time warps are known. For each test-bed seed and each way of
# placing the knots between the event windows (register_curves(knots_to =):
# against the mean of the model runs, or against the replicates' own
# consensus), with landmarks at grid points or refined:
#   knot_err   rms error of the fitted knots against the true warps, in grid
#              steps; knot_max, the largest such error;
#   fine, coarse  energy (sum of squared retained wavelet coefficients) of the
#              registered field mean minus the noise-free truth, at levels >= 7
#              and below, by site;
#   oracle     the same fine-level energy with the true warps.
# With nothing hidden the model at the true inputs is the truth, so what is
# left is the registration's own error (and the noise).
#   Rscript studies/registration.R [seeds=1] [hidden=none] [refine=FALSE] [knots_every=2]
suppressPackageStartupMessages(library(wavevalid))
source("studies/args.R")
opt <- study_args(list(seeds = "1", hidden = "none", refine = "FALSE", knots_every = "2"))
seeds <- arg_numbers(opt$seeds)
hidden <- opt$hidden
refine <- arg_flag(opt$refine)
every <- as.numeric(opt$knots_every)

one <- function(seed) {
  tb <- testbed_suspension(seed = seed, hidden = hidden)
  t <- tb$A$field$t
  dt <- diff(t[1:2])
  basis <- wavelet_basis(tb$A$runs, tb$A$field)
  fine <- basis$level >= 7
  features <- if (hidden == "tire_liftoff") "max" else c("min", "max")
  true_w <- tb$truth$warps[tb$truth$warps$condition == "A", ]
  tt <- seq(min(t), max(t), length.out = 40001)
  # measured time of registered time x for replicate r: the inverse of the true warp
  inverse <- function(r, x) {
    k <- true_w[true_w$replicate == r, ]
    stats::approx(stats::splinefun(k$t, k$w, method = "monoH.FC")(tt), tt, xout = x, rule = 2)$y
  }
  energy <- function(curves, s, keep) {
    w <- drop(wavelet_coef(basis, colMeans(curves[[s]]) - tb$truth$reality[[s]]))
    sum(w[keep]^2)
  }
  # the replicates registered with their true warps
  oracle <- tb$A$field$curves
  for (r in seq_len(nrow(oracle[[1]]))) {
    src <- inverse(r, t)
    for (s in names(oracle)) oracle[[s]][r, ] <- stats::splinefun(t, tb$A$field$curves[[s]][r, ], method = "fmm")(src)
  }
  do.call(rbind, lapply(c("reference", "replicates"), function(to) {
    reg <- register_curves(tb$A$field, tb$A$runs, tb$windows, features = features, knots_every = every,
                           refine = refine, knots_to = to)
    w <- as.data.frame(reg$warps)
    w <- w[w$feature == "fitted", ]
    err <- (w$t_before - vapply(seq_len(nrow(w)), function(i) inverse(w$replicate[i], w$t_after[i]), 1)) / dt
    out <- data.frame(seed = seed, knots_to = to, knot_err = sqrt(mean(err^2)), knot_max = max(abs(err)))
    for (s in names(reg$curves)) {
      out[[paste0("fine_", s)]] <- energy(reg$curves, s, fine)
      out[[paste0("coarse_", s)]] <- energy(reg$curves, s, !fine)
      out[[paste0("oracle_", s)]] <- energy(oracle, s, fine)
    }
    out
  }))
}

cat(sprintf("registration on the test bed: hidden = %s, refine = %s, knots_every = %g\n", hidden, refine, every))
res <- do.call(rbind, lapply(seeds, one))
num <- vapply(res, is.double, logical(1))
res[num] <- lapply(res[num], round, 2)
print(res, row.names = FALSE)
