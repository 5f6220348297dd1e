# How many numbers an emulator's mean needs: the rank of each correlation
# group's weights. The means of the coefficients that share a correlation
# (a wavelet level's, with the default gasp_level engine) are
# mu_i + r(z)' w_i, r(z) the group's correlation vector at the K runs; the
# K x n weights W of the group cost K n multiply-adds per prediction. Where W
# is close to a matrix of rank k, W = U C (U: K x k orthonormal, C = U'W),
# the means cost K k + n k, and the error of coefficient i's mean is at most
# |r(z)| |w_i - U U' w_i| <= sqrt(K) |w_i - U U' w_i| (each correlation at
# most 1). For each group this prints the smallest k whose bound is at most
# eps times every coefficient's prior standard deviation (1 / sqrt(lambda_i)),
# and the multiply-adds of the means, full and at rank k, over all banks;
# beside it, the number of W's singular values above eps times its largest
# (the rank by the usual relative threshold, which bounds no coefficient's
# error).
#
# The problem is bench/bench_scale.R's synthetic one (its definitions are read
# from that file), at one of its sizes; the emulators are fitted as
# validate() fits them (registration, basis, fit_emulators()).
#
#   Rscript studies/weights_rank.R [size=large] [eps=1e-9,1e-6]
suppressPackageStartupMessages(library(wavevalid))
source("studies/args.R")
args <- study_args(list(size = "large", eps = "1e-9,1e-6"))
options(wavevalid.quiet = TRUE)
defs <- parse(file.path("bench", "bench_scale.R"))
keep <- c("sizes_all", "inputs", "u_true", "x_nom", "event_at", "windows", "doublet", "model", "lhs", "field_of",
          "problem")
for (e in defs) if (is.call(e) && identical(e[[1]], as.name("<-")) && as.character(e[[2]]) %in% keep) eval(e)
d <- sizes_all[[args$size]]
pr <- problem(d[["S"]], d[["T"]], d[["K"]], d[["E"]])
field <- suppressWarnings(register_curves(pr$field, pr$runs, pr$windows, features = c("min", "max"),
                                          knots_every = diff(range(pr$field$t)) / 32, landmark_site = "all"))
basis <- wavelet_basis(pr$runs, field)
em <- suppressWarnings(fit_emulators(pr$runs, basis))
eps <- arg_numbers(args$eps)
rows <- list()
for (s in names(em$banks)) {
  b <- em$banks[[s]]
  K <- nrow(b$weights)
  for (g in sort(unique(b$chol_of))) {
    j <- which(b$chol_of == g)
    W <- b$weights[, j, drop = FALSE]
    sv <- svd(W)
    C <- crossprod(sv$u, W)
    # |w_i - U_k U_k' w_i|^2 for every k: the tail sums of C's squared rows
    tail <- apply(C^2, 2L, function(c2) rev(cumsum(rev(c(c2, 0))))[-1L])
    tail <- matrix(tail, ncol = length(j))
    bound <- sqrt(K * pmax(tail, 0)) * rep(sqrt(b$lambda[j]), each = nrow(tail))
    for (e in eps) {
      k <- which(apply(bound, 1L, max) <= e)[1]
      rows[[length(rows) + 1L]] <- data.frame(site = s, group = g, n = length(j), K = K, eps = e, rank = k,
                                              rel_rank = sum(sv$d > e * sv$d[1]),
                                              full = K * length(j), low = min(K * length(j), k * (K + length(j))))
    }
  }
}
tab <- do.call(rbind, rows)
for (e in eps) {
  x <- tab[tab$eps == e, ]
  cat(sprintf("\n== eps %g: rank of each group's weights (site 1), coefficients in brackets\n", e))
  x1 <- x[x$site == x$site[1], ]
  cat(paste(sprintf("%d (%d)", x1$rank, x1$n), collapse = ", "), "\n")
  cat("singular values above eps times the largest (site 1):", paste(x1$rel_rank, collapse = ", "), "\n")
  cat(sprintf("largest rank over all sites: %d of K = %d\n", max(x$rank), x$K[1]))
  cat(sprintf("the means' multiply-adds per prediction, all banks: full %.3g, at the ranks %.3g (%.2f x fewer)\n",
              sum(x$full), sum(x$low), sum(x$full) / sum(x$low)))
}
