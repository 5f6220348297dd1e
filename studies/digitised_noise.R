# The noise learned from one digitised curve: a smooth curve observed at 15
# to 40 uneven points with noise sd s = 0.05, (a) given on its own points
# (onto a 64- or 128-point grid by field_runs()), (b) interpolated by the user
# onto a 64-point grid (and 128) before it came in. validate() with every
# default but the sampler (one chain of 300 x 20), the model at 25 runs of
# sin(2 pi t (1 + a)) + b t, the truth at a = 0.4, b = 0.6. Prints, by seed,
# the number of points and the posterior median of the learned sd over s
# (NA: refused, the curve's noise cannot be told; see ?field_runs).
#   Rscript studies/digitised_noise.R [seeds=1:5] [s=0.05]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
args <- study_args(list(seeds = "1:5", s = "0.05"))
options(wavevalid.quiet = TRUE)
s <- as.numeric(args$s)
f <- function(t, a, b) sin(2 * pi * t * (1 + a)) + b * t
jittered_times <- function(m) sort(c(0, 1, (seq_len(m - 2) - stats::runif(m - 2, 0.1, 0.9)) / (m - 2)))
learned <- function(runs, field, iu) {
  fit <- tryCatch(suppressWarnings(suppressMessages(validate(runs, field, iu, chains = 1, seed = 1,
                    sampler = sampler_control(n_draws = 300, n_inner = 20, quiet = TRUE)))),
                  wavevalid_error = function(e) NULL)
  if (is.null(fit)) return(NA_real_)
  ev <- fit$noise_evidence$site1
  stats::median(sqrt(fit$sigma2$site1[, 1] / (ev$mult %||% 1)[1])) / s
}
rows <- list()
for (seed in arg_value(args$seeds)) {
  for (n_grid in c(64L, 128L)) {
    tg <- seq(0, 1, length.out = n_grid)
    set.seed(seed)
    design <- data.frame(a = stats::runif(25), b = stats::runif(25))
    runs <- model_runs(design, t(apply(design, 1, function(z) f(tg, z[1], z[2]))), tg)
    iu <- iu_map(c("a", "b"), c("calibration", "calibration"), c(0, 0), c(1, 1))
    m <- sample(15:40, 1)
    xs <- jittered_times(m)
    y <- f(xs, 0.4, 0.6) + stats::rnorm(m, sd = s)
    own <- suppressMessages(field_runs(list(site1 = y), list(site1 = xs), grid = tg))
    by_hand <- suppressWarnings(suppressMessages(field_runs(rbind(stats::approx(xs, y, tg)$y), tg)))
    rows[[length(rows) + 1L]] <- data.frame(seed = seed, points = m, grid = n_grid,
                                            own_points = learned(runs, own, iu),
                                            interpolated = learned(runs, by_hand, iu))
  }
}
out <- do.call(rbind, rows)
print(format(out, digits = 2), row.names = FALSE)
