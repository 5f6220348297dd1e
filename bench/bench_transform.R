# Curves to retained wavelet coefficients and back: the dense product with the
# basis matrix Psi against one wavethresh transform per curve, side by side,
# at several points x retained coefficients; the largest difference between
# the two. basis_coef() and basis_curves() take the transform above
# transform_min_work multiply-adds per curve.
#   Rscript bench/bench_transform.R [n_curves]
suppressMessages(library(wavevalid))
args <- commandArgs(trailingOnly = TRUE)
n_curves <- if (length(args)) as.integer(args[1]) else 200L
ns <- asNamespace("wavevalid")
set.seed(1)
rows <- list()
for (n in c(1024, 2048, 4096, 8192)) {
  s <- ns$basis_settings(n, 2, "DaubExPhase", 0:3, 0.025)
  Y <- matrix(rnorm(n_curves * n), n_curves)
  for (k in c(128, 512, 2048)) {
    if (k >= n) next
    idx <- sort(c(1:16, sample(17:n, k - 16)))
    bas <- ns$new_wv_basis(idx, ns$index_level(idx), ns$basis_matrix(idx, s), seq_len(n), "a", s)
    tm <- function(e) unname(system.time(e)[["elapsed"]])
    t_dc <- tm(Wd <- Y %*% bas$Psi)
    t_tc <- tm(Wt <- ns$transform_coef(bas, Y))
    t_dr <- tm(Yd <- tcrossprod(Wd, bas$Psi))
    t_tr <- tm(Yt <- ns$transform_curves(bas, Wd))
    rows[[length(rows) + 1L]] <- data.frame(
      points = n, coefs = k, work = n * k, uses_transform = ns$basis_uses_transform(bas),
      coef_dense = t_dc, coef_transform = t_tc, coef_ratio = round(t_dc / t_tc, 2),
      curves_dense = t_dr, curves_transform = t_tr, curves_ratio = round(t_dr / t_tr, 2),
      max_diff = signif(max(abs(Wd - Wt), abs(Yd - Yt)), 2))
  }
}
cat(sprintf("%d curves; seconds elapsed; ratio = dense / transform\n", n_curves))
print(do.call(rbind, rows), row.names = FALSE)
