# False findings of a right model with a learned noise, one curve on its own
# points (the setting of digitised_noise.R: sin(2 pi t (1 + a)) + b t at a =
# 0.4, b = 0.6, noise sd 0.05, 25 runs, one chain of 300 x 20), 15 to 40
# points and 10 points (few points covering the grid), on 64 and 128 grid
# points. Prints by seed, grid and points the learned sd over the truth and
# what where_fails() reports (every finding is false).
#   Rscript studies/own_points_findings.R [seeds=1:5]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
args <- study_args(list(seeds = "1:5"))
options(wavevalid.quiet = TRUE)
s <- 0.05
f <- function(t, a, b) sin(2 * pi * t * (1 + a)) + b * t
jt <- function(m) sort(c(0, 1, (seq_len(m - 2) - stats::runif(m - 2, 0.1, 0.9)) / (m - 2)))
rows <- list()
for (seed in arg_value(args$seeds)) for (n_grid in c(64L, 128L)) for (few in c(FALSE, TRUE)) {
  tg <- seq(0, 1, length.out = n_grid)
  set.seed(seed)
  design <- data.frame(a = runif(25), b = runif(25))
  runs <- model_runs(design, t(apply(design, 1, function(z) f(tg, z[1], z[2]))), tg)
  iu <- iu_map(c("a", "b"), c("calibration", "calibration"), c(0, 0), c(1, 1))
  m <- if (few) 10L else sample(15:40, 1)
  xs <- jt(m)
  y <- f(xs, 0.4, 0.6) + rnorm(m, sd = s)
  field <- suppressMessages(field_runs(list(site1 = y), list(site1 = xs), grid = tg))
  fit <- suppressWarnings(suppressMessages(validate(runs, field, iu, chains = 1, seed = 1,
                 sampler = sampler_control(n_draws = 300, n_inner = 20, quiet = TRUE))))
  wf <- suppressWarnings(suppressMessages(where_fails(fit)))
  ev <- fit$noise_evidence$site1
  rows[[length(rows) + 1]] <- data.frame(seed = seed, grid = n_grid, points = m,
    sd_over_truth = round(median(sqrt(fit$sigma2$site1[, 1] / ev$mult[1])) / s, 2),
    findings = nrow(wf), kinds = if (nrow(wf)) paste(unique(wf$kind), collapse = ",") else "")
}
print(do.call(rbind, rows), row.names = FALSE)
