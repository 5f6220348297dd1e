# The noise learned when the model misses something, one curve per site on
# its own points: flow-stress-like curves at six temperatures (20 to 500),
# one each on 43, 35, 28, 22, 18 and 15 uneven strains on [0, 0.3], noise sd
# 1 at levels 100 to 600. The model is Voce hardening, (1 - T / 600) (s0 +
# (ssat - s0)(1 - exp(-e / ec))), 30 runs on s0, ssat, ec; the truth (s0 =
# 120, ssat = 600, ec = 0.05) adds 10 and a softening that grows with the
# temperature past e = 0.1, which the model lacks. validate() with every
# default but the sampler (one chain of 300 x 20). Prints by seed and site
# the posterior median and 95% quantile of the learned sd of one
# measurement, the difference-based sd (MAD) of the curve's points, and the
# sd their capped difference residuals give (the chi-square evidence), and
# how many findings where_fails() reports at the site (the softening acts
# from T100 up, most at the hottest sites).
#   Rscript studies/misfit_noise.R [seeds=3]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
args <- study_args(list(seeds = "3"))
options(wavevalid.quiet = TRUE)
temps <- c(20, 100, 200, 300, 400, 500)
npts <- c(43, 35, 28, 22, 18, 15)
sites <- paste0("T", temps)
voce <- function(e, temp, s0, ssat, ec) (1 - temp / 600) * (s0 + (ssat - s0) * (1 - exp(-e / ec)))
truth <- function(e, temp) voce(e, temp, 120, 600, 0.05) * (1 - 0.25 * (temp / 500) * pmax(e - 0.1, 0) / 0.2) + 10
tg <- seq(0, 0.3, length.out = 64)
rows <- list()
for (seed in arg_value(args$seeds)) {
  set.seed(seed)
  design <- data.frame(s0 = runif(30, 50, 200), ssat = runif(30, 400, 800), ec = runif(30, 0.02, 0.1))
  runs <- model_runs(design, stats::setNames(lapply(temps, function(temp) {
    t(apply(design, 1, function(z) voce(tg, temp, z[1], z[2], z[3])))
  }), sites), tg)
  iu <- iu_map(c("s0", "ssat", "ec"), rep("calibration", 3), c(50, 400, 0.02), c(200, 800, 0.1))
  xs <- stats::setNames(lapply(npts, function(m) sort(c(0, 0.3, runif(m - 2, 0, 0.3)))), sites)
  ys <- stats::setNames(lapply(seq_along(temps), function(k) truth(xs[[k]], temps[k]) + rnorm(npts[k], sd = 1)), sites)
  field <- suppressMessages(field_runs(ys, xs, grid = tg))
  fit <- suppressWarnings(suppressMessages(validate(runs, field, iu, chains = 1, seed = 1,
                                                    sampler = sampler_control(n_draws = 300, n_inner = 20, quiet = TRUE))))
  wf <- suppressWarnings(suppressMessages(where_fails(fit)))
  for (s in sites) {
    ev <- fit$noise_evidence[[s]]
    sdl <- sqrt(fit$sigma2[[s]][, 1] / ev$mult[1])
    ddf <- ev$detail_df %||% 0
    rows[[length(rows) + 1L]] <- data.frame(seed = seed, site = s, points = length(xs[[s]]), level = round(max(ys[[s]])),
                                            learned_sd = signif(stats::median(sdl), 3),
                                            q95 = signif(stats::quantile(sdl, 0.95, names = FALSE), 3),
                                            detail_sd = signif(ev$detail_sd, 3),
                                            points_sd = if (ddf > 0) signif(sqrt(ev$detail_ss / ddf), 3) else NA,
                                            findings = sum(wf$site == s))
  }
}
print(do.call(rbind, rows), row.names = FALSE)
