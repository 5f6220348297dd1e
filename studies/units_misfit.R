# Replicates that are units: does the package find a small smooth misfit
# that nested least squares on each unit finds? Six units (subjects), each
# measured twelve times (noise sd 0.01), y = a_u exp(-k t) + c (t / 10)^2
# on 128 points of [0, 10], a_u drawn N(1, 0.25) by unit (the units' spread
# is 0.25 at t = 0 and 0.005 at t = 10: it shrinks 50-fold along the
# record), k = 0.4; the model lacks the term c (t / 10)^2. The package gets
# the 72 curves as one site's replicates and 40 runs of a exp(-k t) over
# a in [0.5, 1.5], k in [0.3, 0.5] (both calibration inputs); validate()
# with every default (no windows: no registration). The nested test: for
# each unit, least squares of its 12 curves on a exp(-k t) (nls) and on
# a exp(-k t) + c (t / 10)^2, the F test of c, the units' p-values joined
# by Fisher's method. Per seed and c: the F test's combined p, whether
# where_fails() has a finding (and of which kinds), misfit_check()'s p.
#   Rscript studies/units_misfit.R [seeds=1:5] [c=0,0.01,0.03]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(seeds = "1:5", c = "0,0.01,0.03", units = "TRUE", runs = "40"))
declare_units <- as.logical(opt$units)
options(wavevalid.quiet = TRUE)
t <- seq(0, 10, length.out = 128)
f <- function(a, k) a * exp(-k * t)

nested_p <- function(Y, unit) {
  p <- vapply(unique(unit), function(u) {
    y <- as.vector(t(Y[unit == u, , drop = FALSE]))
    tt <- rep(t, sum(unit == u))
    m0 <- stats::nls(y ~ a * exp(-k * tt), start = list(a = 1, k = 0.4))
    m1 <- stats::nls(y ~ a * exp(-k * tt) + c * (tt / 10)^2, start = c(as.list(stats::coef(m0)), c = 0),
                     control = stats::nls.control(minFactor = 1e-10, maxiter = 200))
    stats::anova(m0, m1)[2, "Pr(>F)"]
  }, numeric(1))
  stats::pchisq(-2 * sum(log(p)), 2 * length(p), lower.tail = FALSE)
}

rows <- list()
for (seed in arg_numbers(opt$seeds)) {
  set.seed(seed)
  n_runs <- as.integer(opt$runs)
  design <- data.frame(a = 0.5 + (sample(n_runs) - stats::runif(n_runs)) / n_runs,
                       k = 0.3 + 0.2 * (sample(n_runs) - stats::runif(n_runs)) / n_runs)
  runs <- model_runs(design, t(mapply(f, design$a, design$k)), t)
  iu <- iu_map(c("a", "k"), c("calibration", "calibration"), lower = c(0.5, 0.3), upper = c(1.5, 0.5))
  a_u <- stats::rnorm(6, 1, 0.25)
  unit <- rep(1:6, each = 12)
  noise <- matrix(stats::rnorm(72 * length(t), sd = 0.01), 72)
  for (cc in arg_numbers(opt$c)) {
    Y <- t(vapply(unit, function(u) f(a_u[u], 0.4) + cc * (t / 10)^2, numeric(length(t)))) + noise
    field <- field_runs(Y, t, units = if (declare_units) unit)
    fit <- suppressWarnings(validate(runs, field, iu, seed = 1))
    wf <- where_fails(fit)
    mc <- attr(wf, "misfit")
    rows[[length(rows) + 1L]] <- data.frame(
      seed = seed, c = cc, f_test_p = signif(nested_p(Y, unit), 3), f_test_finds = nested_p(Y, unit) < 0.01,
      findings = nrow(wf), kinds = paste(unique(wf$kind), collapse = ","), check_p = signif(attr(mc, "p_value"), 3),
      spread_ratio = signif(max(apply(Y[, 1:8], 2, stats::sd)) /
                              min(apply(Y[, 121:128], 2, stats::sd)), 3))
    print(utils::tail(rows[[length(rows)]], 1), row.names = FALSE)
  }
}
out <- do.call(rbind, rows)
print(out, row.names = FALSE)
agg <- stats::aggregate(cbind(f_test = f_test_finds, package = findings > 0) ~ c, data = out, FUN = mean)
print(agg, row.names = FALSE)
