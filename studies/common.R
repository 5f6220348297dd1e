# Pieces shared by the studies, on the package's exported functions. Source
# from the package's root after library(wavevalid); it sources the argument
# parser (studies/args.R) and the test bed protocol the diagnosis tests use
# (tests/testthat/helper-protocol.R).
source("studies/args.R")
source("tests/testthat/helper-protocol.R")

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

# Longest flagged interval of a where_fails() table, in grid steps (as the
# verdict of criterion 1 measures it).
longest_steps <- function(fails) testbed_where_verdict(fails, "none")$longest

# Values by site, two significant figures, joined by "/".
by_site <- function(x) if (is.null(x)) NA_character_ else paste(formatC(x, digits = 2, format = "fg"), collapse = "/")

# Evaluates `code` with R's random number generator (default kinds) seeded by
# `seed`, restoring the caller's state.
testbed_with_seed <- function(seed, code) {
  withr::with_seed(seed, code, .rng_kind = "Mersenne-Twister", .rng_normal_kind = "Inversion",
                   .rng_sample_kind = "Rejection")
}

# The field of condition A with every replicate warped by the mean of the
# replicates' true warps: replicates aligned with each other, not with the
# model.
mean_warp_field <- function(tb, seed) {
  w <- tb$truth$warps
  w <- w[w$condition == "A", ]
  testbed_unwarped_field(tb, seed, warp = stats::aggregate(w ~ t, data = w, FUN = mean))
}
