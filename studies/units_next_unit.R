# The next unit's band on the cooling bed (testbed_units()): does
# predict(type = "new_vehicle") cover the curves of specimens not tested?
# validate() with every default on condition A (six specimens, four tests
# each), then the 90% band of a new vehicle (its variation inputs drawn
# from the I/U map's prior) against 40 new specimens of the same population
# (their inputs drawn as the bed draws its units, the true u*): the share of
# their noise-free curves' points inside the band without noise, and of
# their noisy tests' points inside the band with it; the band's median
# width; beside it, the same for the tested population's mean (type
# "reality" against the bed's reality).
#   Rscript studies/units_next_unit.R [seeds=1:3] [hidden=none]
suppressPackageStartupMessages(library(wavevalid))
source("studies/args.R")
opt <- study_args(list(seeds = "1:3", hidden = "none"))
options(wavevalid.quiet = TRUE)
rows <- list()
for (seed in arg_numbers(opt$seeds)) {
  tb <- testbed_units(seed = seed, hidden = opt$hidden)
  fit <- suppressMessages(suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, seed = 1)))
  iu <- tb$iu
  xn <- iu$name[iu$type == "variation"]
  new <- withr::with_seed(100 + seed, {
    d <- t(replicate(40, stats::rnorm(length(xn), iu$nominal[iu$type == "variation"],
                                      iu$prior_sd[iu$type == "variation"])))
    d <- pmin(pmax(d, 0.2), 0.8)
    colnames(d) <- xn
    cbind(matrix(tb$truth$u, 40, length(tb$truth$u), byrow = TRUE,
                 dimnames = list(NULL, names(tb$truth$u))), d)
  })
  curves <- simulate_units(as.data.frame(new), mechanism = if (opt$hidden != "none") opt$hidden)$curves$site1
  noisy <- curves + withr::with_seed(200 + seed, t(replicate(40, testbed_noise(ncol(curves), sd = 0.2, phi = 0.6))))
  p0 <- predict(fit, type = "new_vehicle", noise = FALSE, seed = 1)$summary
  p1 <- predict(fit, type = "new_vehicle", noise = TRUE, seed = 1)$summary
  inside <- function(p, Y) mean(sweep(Y, 2, p$lower, ">=") & sweep(Y, 2, p$upper, "<="))
  pr <- predict(fit, type = "reality", noise = FALSE, seed = 1)$summary
  rows[[length(rows) + 1L]] <- data.frame(
    seed = seed, next_unit = round(inside(p0, curves), 3), next_test = round(inside(p1, noisy), 3),
    width = signif(stats::median(p0$upper - p0$lower), 3),
    population = round(mean(tb$truth$reality$site1 >= pr$lower & tb$truth$reality$site1 <= pr$upper), 3),
    population_width = signif(stats::median(pr$upper - pr$lower), 3))
  print(rows[[length(rows)]], row.names = FALSE)
}
print(do.call(rbind, rows), row.names = FALSE)
