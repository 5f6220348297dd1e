# The suspension bed's added-mass experiment entered as a test condition (x1
# a "condition" input, the experiment at x1 = 0.5 + the added mass) and as
# experiment(change =) with x1 held at its nominal: the same emulators, field
# data, sampler and seed must give identical draws and bias coefficients.
#   Rscript studies/conditions_added_mass.R
suppressPackageStartupMessages(library(wavevalid))
options(wavevalid.quiet = TRUE)
tb <- load_testbed()
em <- fit_emulators(tb$A$runs, wavelet_basis(tb$A$runs, tb$A$field))
iu_c <- tb$iu
iu_c$type[iu_c$name == "x1"] <- "condition"
iu_c$prior[iu_c$name == "x1"] <- "none"
iu_c$prior_sd[iu_c$name == "x1"] <- NA_real_
iu_c$prior_mean[iu_c$name == "x1"] <- NA_real_
sc <- sampler_control(n_draws = 100, n_inner = 20, quiet = TRUE)
at <- 0.5 + tb$added_mass$delta[["x1"]]
fit_c <- suppressWarnings(calibrate(em, tb$A$field, iu_c, chains = 1, seed = 1, sampler = sc,
                                    experiments = list(added_mass = experiment(tb$added_mass$field,
                                                                               condition = c(x1 = at)))))
fit_h <- suppressWarnings(calibrate(em, tb$A$field, iu_hold(tb$iu, c(x1 = 0.5)), chains = 1,
                                    seed = 1, sampler = sc,
                                    experiments = list(added_mass = experiment(tb$added_mass$field,
                                                                               change = c(x1 = at - 0.5)))))
cat(sprintf("draws identical: %s; bias coefficients identical: %s\n",
            identical(as.matrix(fit_c$draws), as.matrix(fit_h$draws)), identical(fit_c$wb, fit_h$wb)))
