# Pieces shared by the studies, on the package's exported functions. Source
# from the package's root after library(wavevalid); it sources the test bed
# protocol the diagnosis tests use (tests/testthat/helper-testbed.R) and the
# argument parser (studies/args.R).
source("tests/testthat/helper-testbed.R")
source("studies/args.R")

clock <- function() as.numeric(proc.time()[["elapsed"]])

# The true inputs of test bed `tb` (coded), in the order of `inputs`.
true_inputs <- function(tb, inputs = tb$iu$name) c(tb$truth$u, 0.5 + tb$truth$delta)[inputs]

`%||%` <- function(a, b) if (is.null(a)) b else a

# Share of the points of `curves` (a list by site, one row each) inside the
# band (a data frame with site, lower, upper: reality(), say).
band_cover <- function(band, curves) {
  hit <- unlist(lapply(names(curves), function(s) {
    b <- band[band$site == s, ]
    y <- curves[[s]][1, ]
    y >= b$lower & y <= b$upper
  }))
  mean(hit)
}

# For each of `inputs`, whether its true value `z_true[[p]]` lies inside the
# central 95% interval of the draws X (a matrix with a column per input).
inputs_inside <- function(X, z_true, inputs) {
  vapply(inputs, function(p) {
    q <- stats::quantile(X[, p], c(0.025, 0.975))
    z_true[[p]] >= q[1] && z_true[[p]] <= q[2]
  }, logical(1))
}

# Longest flagged interval of a where_fails() table, in grid steps.
longest_steps <- function(fails) {
  t <- attr(fails, "bias")$t
  if (nrow(fails)) round(max(fails$end - fails$start) / (t[2] - t[1])) else 0
}

# Values by site, two significant figures, joined by "/".
by_site <- function(x) if (is.null(x)) NA_character_ else paste(formatC(x, digits = 2, format = "fg"), collapse = "/")

# The test bed's field noise: AR(1) with standard deviation `sd` and
# coefficient `phi` (as testbed_suspension() draws it).
testbed_noise <- function(n, sd = 0.03, phi = 0.95) {
  e <- stats::rnorm(n, sd = sd * sqrt(1 - phi^2))
  as.numeric(stats::filter(e, phi, method = "recursive", init = stats::rnorm(1, sd = sd)))
}

# Condition A's field data of test bed `tb` as a perfect registration would
# leave them: the noise-free truth plus the same kind of noise as the
# replicates (seeded by `seed`), one curve per replicate, no time warps. With
# `warp` (knots t, w), the truth is first warped by it (monotone spline), as
# every replicate by the same warp.
unwarped_field <- function(tb, seed, warp = NULL) {
  f <- tb$A$field
  t <- f$t
  reality <- tb$truth$reality
  if (!is.null(warp)) {
    at <- pmin(pmax(stats::splinefun(warp$t, warp$w, method = "monoH.FC")(t), t[1]), t[length(t)])
    reality <- lapply(reality, function(y) stats::splinefun(t, y, method = "fmm")(at))
  }
  testbed_with_seed(seed, for (s in names(f$curves)) {
    f$curves[[s]] <- t(vapply(seq_len(nrow(f$curves[[s]])), function(r) reality[[s]] + testbed_noise(length(t)),
                              numeric(length(t))))
  })
  f
}

# The field of condition A with every replicate warped by the mean of the
# replicates' true warps: replicates aligned with each other, not with the
# model.
mean_warp_field <- function(tb, seed) {
  w <- tb$truth$warps
  w <- w[w$condition == "A", ]
  unwarped_field(tb, seed, warp = stats::aggregate(w ~ t, data = w, FUN = mean))
}
