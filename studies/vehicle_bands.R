# Do the bands for new vehicles hold their share of vehicles, by emulator
# engine? Test bed with nothing hidden (seed `seed`), condition A's field
# registered to the runs as the diagnosis tests do (testbed_register()), the
# report's basis of runs and field, emulators of each engine, one chain of
# 150 x 20 (testbed_calibrate()). Then 200 vehicles drawn from the population
# (the true calibration inputs, variations from their prior around the
# nominal values, AR(1) noise) at condition A's nominal inputs and at
# condition B's, and per engine and site the share of their points inside
#   new vehicle at A   the 90% band of predict(type = "new_vehicle")
#   new nominal at B   the 90% band of predict(type = "new_nominal") from B's runs
#   B's replicates     the same band, the test bed's own B replicates (registered)
#   added-mass run     the 90% band of predict(type = "added_load") from the two added-mass runs
# with the bands' median widths.
#   Rscript studies/vehicle_bands.R [seed=1] [engines=gasp_level,gasp] [n_vehicles=200]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(seed = "1", engines = "gasp_level,gasp", n_vehicles = "200"))
seed <- as.integer(opt$seed)
n_veh <- as.integer(opt$n_vehicles)
options(wavevalid.quiet = TRUE)
future::plan(future::sequential)

tb <- testbed_suspension(seed = seed, hidden = "none")
field <- testbed_register(tb, tb$A$runs)
basis <- wavelet_basis(tb$A$runs, field)
xn <- names(tb$B$x_nom)
vehicles <- function(nominal, vseed) {
  testbed_with_seed(vseed, {
    d <- as.data.frame(iu_prior_sample(tb$iu, n_veh, nominal = nominal))
    d$u1 <- tb$truth$u[["u1"]]
    d$u2 <- tb$truth$u[["u2"]]
    curves <- simulate_suspension(d[c("u1", "u2", xn)])$curves
    lapply(curves, function(y) y + t(replicate(n_veh, testbed_noise(ncol(y)))))
  })
}
# share of the points of each row of curves (by site) inside the band, averaged over rows
inside <- function(curves, pred) {
  p <- as.data.frame(pred)
  vapply(names(curves), function(s) {
    ps <- p[p$site == s, ]
    mean(sweep(curves[[s]], 2, ps$lower, `>=`) & sweep(curves[[s]], 2, ps$upper, `<=`))
  }, numeric(1))
}
width <- function(pred) {
  p <- as.data.frame(pred)
  stats::median(p$upper - p$lower)
}
y_A <- vehicles(stats::setNames(tb$iu$nominal, tb$iu$name)[xn], 4)
y_B <- vehicles(tb$B$x_nom, 3)
f_B <- testbed_register(tb, tb$A$runs, "B")
f_M <- testbed_register(tb, tb$A$runs, "added_mass")

cat(sprintf("== bands for new vehicles: test bed seed %d, nothing hidden, %d vehicles per condition\n", seed, n_veh))
for (engine in arg_names(opt$engines)) {
  em <- suppressWarnings(fit_emulators(tb$A$runs, basis, engine = engine))
  fit <- testbed_calibrate(em, field, tb$iu)
  p_A <- suppressWarnings(predict(fit, type = "new_vehicle", level = 0.9, seed = 1))
  p_B <- suppressWarnings(predict(fit, type = "new_nominal", new_runs = tb$B$runs, x_nom = tb$B$x_nom,
                                  level = 0.9, seed = 1))
  p_M <- suppressWarnings(predict(fit, type = "added_load", new_runs = tb$added_mass$runs, seed = 1))
  cat(sprintf(paste("%-10s new vehicle at A %s (width %.3f) | new nominal at B %s (width %.3f) |",
                    "B's replicates %s | added-mass run %s (width %.3f)\n"), engine,
              by_site(inside(y_A, p_A)), width(p_A), by_site(inside(y_B, p_B)), width(p_B),
              by_site(inside(f_B$curves, p_B)), by_site(inside(f_M$curves, p_M)), width(p_M)))
}
