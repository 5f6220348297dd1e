# Are the emulators honest away from the design points? Site 1 of the test
# bed (seed 1, condition A's 66 runs, registered field, wavelet basis of runs
# and field), emulators fitted by the per-coefficient engine ("gasp"), the
# shared-parameter engine by level ("gasp_level", with its Student-t
# predictive variance and with the plug-in one) and RobustGaSP's ppgasp, one
# fit per wavelet level (power-exponential kernel, its defaults), as the peer.
# At 40 held-out runs (design_maximin(tb$iu, 40, nominal = FALSE, seed = 9),
# simulated with simulate_suspension()), per level group (0-5, 6-9, 10-12):
#   msse   mean squared studentised error (w - m) / sd (1 is honest)
#   cov90  share of the errors inside m +- 1.645 sd (target 0.85-0.95)
#   rel    root mean square of the errors, each coefficient's scaled by its
#          standard deviation across the design runs, relative to "gasp"'s
# Then the fitting time of each (one core, sequential) and its ratio to "gasp".
# Targets of the shared-parameter engine: msse in [0.8, 1.3] and cov90 in
# [0.85, 0.95] in every group, rel <= 1.1.
#   Rscript bench/bench_emulator_honesty.R
suppressPackageStartupMessages(library(wavevalid))
options(wavevalid.quiet = TRUE)
future::plan(future::sequential)
has_peer <- requireNamespace("RobustGaSP", quietly = TRUE)

tb <- testbed_suspension(seed = 1)
f <- register_curves(tb$A$field, tb$A$runs, tb$windows, knots_every = 2)
basis <- wavelet_basis(tb$A$runs, f)
runs <- tb$A$runs
runs$curves <- runs$curves["site1"]
new <- simulate_suspension(design_maximin(tb$iu, 40, nominal = FALSE, seed = 9))
new$curves <- new$curves["site1"]
W_new <- wavelet_coef(basis, new)$site1
cat(sprintf("test bed seed 1, condition A, site 1: %d runs, %d inputs, %d coefficients; %d held-out runs\n",
            nrow(runs$design), ncol(runs$design), length(basis$index), nrow(new$design)))

groups <- list("0-5" = 0:5, "6-9" = 6:9, "10-12" = 10:12)
fits <- list()
timed <- function(expr) {
  t0 <- proc.time()[["elapsed"]]
  val <- force(expr)
  list(value = val, time = proc.time()[["elapsed"]] - t0)
}

# predictions (mean, sd) at the held-out runs, K_new x n
em_pred <- function(em) {
  pr <- predict(em, new$design[em$inputs], site = "site1")
  list(mean = pr$mean, sd = sqrt(pr$var))
}

r <- timed(suppressWarnings(fit_emulators(runs, basis, engine = "gasp")))
em_gasp <- r$value
fits$gasp <- c(em_pred(em_gasp), time = r$time)
r <- timed(suppressWarnings(fit_emulators(runs, basis, engine = "gasp_level")))
fits$gasp_level <- c(em_pred(r$value), time = r$time)
withr::with_options(list(wavevalid.gasp_level = list(predictive = "plugin")), {
  r <- timed(suppressWarnings(fit_emulators(runs, basis, engine = "gasp_level")))
})
fits$gasp_level_plugin <- c(em_pred(r$value), time = r$time)

flat <- !is.finite(em_gasp$params$loglik)
level <- basis$level
bank <- em_gasp$banks$site1
if (has_peer) {
  Xs <- bank$X
  Zs <- sweep(sweep(as.matrix(new$design[em_gasp$inputs]), 2L, bank$lower, "-"), 2L, bank$width, "/")
  t0 <- proc.time()[["elapsed"]]
  m <- s <- matrix(NA_real_, nrow(Zs), length(level))
  for (lv in unique(level[!flat])) {
    cols <- which(level == lv & !flat)
    utils::capture.output(fit <- RobustGaSP::ppgasp(design = Xs, response = bank$y[, cols, drop = FALSE],
                                                    kernel_type = "pow_exp"))
    pr <- RobustGaSP::predict(fit, Zs)
    m[, cols] <- pr$mean
    s[, cols] <- pr$sd
  }
  fits$ppgasp_level <- list(mean = m, sd = s, time = proc.time()[["elapsed"]] - t0)
}

scale_coef <- apply(bank$y, 2L, stats::sd)
stats_of <- function(fit) {
  z <- (W_new - fit$mean) / fit$sd
  e <- sweep(W_new - fit$mean, 2L, scale_coef, "/")
  sapply(groups, function(g) {
    cols <- which(level %in% g & !flat)
    zz <- z[, cols]
    c(msse = mean(zz^2), cov90 = mean(abs(zz) <= stats::qnorm(0.95)), rms = sqrt(mean(e[, cols]^2)))
  })
}
tab <- lapply(fits, stats_of)
ref <- tab$gasp["rms", ]
cat("\nheld-out: mean squared studentised error / 90% coverage / rms error relative to gasp, by level group\n")
out <- do.call(rbind, lapply(names(tab), function(nm) {
  x <- tab[[nm]]
  data.frame(engine = nm, t(sapply(names(groups), function(g) {
    sprintf("%.2f / %.2f / %.2f", x["msse", g], x["cov90", g], x["rms", g] / ref[g])
  })), time_s = round(fits[[nm]]$time, 2), time_ratio = round(fits[[nm]]$time / fits$gasp$time, 3),
  check.names = FALSE)
}))
names(out)[2:4] <- paste("levels", names(groups))
print(out, row.names = FALSE)
n_per <- sapply(groups, function(g) sum(level %in% g & !flat))
cat(sprintf("coefficients per group: %s\n", paste(names(n_per), n_per, sep = ": ", collapse = ", ")))
