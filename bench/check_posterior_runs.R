# What a second wave of model runs at design_posterior() does on the
# suspension test bed. Per case (hidden mechanism, seed): the model is
# validated on condition A with the test bed's 66 runs, then n_add runs are
# simulated at design_posterior(fit, n_add) and added with c(), the emulators
# fitted again on the same basis and the model calibrated again; `rounds`
# times. field = "registered": the replicates registered to the mean of the
# first runs (grid landmarks, knots every 2 time units, as the tests);
# "unwarped": the same kind of noise on reality without the time warps (a
# perfect registration). Columns: longest, the longest interval where_fails()
# flags (grid steps); credible, the largest credible bias (kN); cover90, the
# share of the nine inputs whose true value is inside the central 90%
# posterior interval; err, the root mean square of posterior mean - truth
# (coded units); sd, the mean posterior sd; share, the flagged share of the
# hidden mechanism's region at each site. registration_variance is
# calibrate()'s (registered field only). reference = "posterior" registers
# the field replicates anew after each round, to the mean of that round's
# runs (all at posterior draws), and builds the wavelet basis anew on all
# the runs; "first" (default) keeps them registered to the mean of the first
# runs. refine is register_curves()'s (landmarks between grid points).
# register_runs = TRUE (with reference = "posterior") registers every model
# run, first and new, to the same mean of the new runs as the replicates.
#   Rscript bench/check_posterior_runs.R [cases=none:1,...,none:5] [field=unwarped] [n_add=30] [rounds=1]
#                                        [spread=0.05] [cores=2] [registration_variance=FALSE]
#                                        [reference=first|posterior] [refine=FALSE] [register_runs=FALSE]
suppressPackageStartupMessages(library(wavevalid))
source("bench/args.R")
opts <- list(cases = paste0("none:", 1:5, collapse = ","), field = "unwarped", n_add = "30", rounds = "1",
             spread = "0.05", cores = "2", registration_variance = "FALSE", reference = "first",
             refine = "FALSE", register_runs = "FALSE")
opts <- bench_args(opts)
cases <- strsplit(opts$cases, ",")[[1]]
field_kind <- match.arg(opts$field, c("registered", "unwarped"))
n_add <- as.integer(opts$n_add)
rounds <- as.integer(opts$rounds)
spread <- as.numeric(opts$spread)
cores <- as.integer(opts$cores)
reg_var <- as.logical(opts$registration_variance)
reference <- match.arg(opts$reference, c("first", "posterior"))
refine <- as.logical(opts$refine)
register_runs <- as.logical(opts$register_runs)
if (register_runs && reference != "posterior") stop("register_runs = TRUE needs reference = \"posterior\"")
if (reference == "posterior" && field_kind != "registered") stop("reference = \"posterior\" needs field = \"registered\"")
options(wavevalid.quiet = TRUE)

one <- function(case) {
  hidden <- sub(":.*", "", case)
  seed <- as.integer(sub(".*:", "", case))
  t0 <- proc.time()[["elapsed"]]
  tb <- testbed_suspension(seed = seed, hidden = hidden)
  features <- if (hidden == "tire_liftoff") "max" else c("min", "max")
  reg <- function(curves, reference) {
    register_curves(curves, reference, tb$windows, features = features, knots_every = 2, refine = refine)
  }
  field <- if (field_kind == "unwarped") {
    wavevalid:::unwarped_field(tb, seed)
  } else {
    reg(tb$A$field, tb$A$runs)
  }
  runs <- tb$A$runs
  basis <- wavelet_basis(runs, field)
  validate_runs <- function(runs) {
    em <- suppressWarnings(fit_emulators(runs, basis))
    suppressWarnings(calibrate(em, field, tb$iu, n_draws = 150, n_inner = 20, chains = 1, seed = 1, quiet = TRUE,
                               registration_variance = reg_var))
  }
  truth <- c(tb$truth$u, 0.5 + tb$truth$delta)
  row <- function(fit, round) {
    wf <- where_fails(fit)
    d <- as.matrix(fit$draws)[, fit$inputs]
    z <- truth[fit$inputs]
    lo <- apply(d, 2, stats::quantile, 0.05)
    hi <- apply(d, 2, stats::quantile, 0.95)
    share <- if (hidden == "none") NA_character_ else
      paste(round(flagged_share(wf, testbed_signatures(z, hidden)[[1]]), 2), collapse = "/")
    data.frame(hidden = hidden, seed = seed, runs = nrow(fit$emulators$design), round = round,
               longest = max(c(0, round((wf$end - wf$start) / diff(fit$basis$t[1:2])))),
               credible = max(attr(wf, "credible")$credible_bias), cover90 = mean(z >= lo & z <= hi),
               err = sqrt(mean((colMeans(d) - z)^2)), sd = mean(apply(d, 2, stats::sd)), share = share,
               seconds = round(proc.time()[["elapsed"]] - t0))
  }
  fit <- validate_runs(runs)
  out <- row(fit, 0L)
  all_runs <- runs
  for (r in seq_len(rounds)) {
    wave <- simulate_suspension(design_posterior(fit, n_add, spread = spread, seed = r))
    all_runs <- c(all_runs, wave)
    runs <- all_runs
    if (reference == "posterior") {
      field <- reg(tb$A$field, wave)
      if (register_runs) runs <- reg(all_runs, wave)
      basis <- wavelet_basis(runs, field)
    }
    fit <- validate_runs(runs)
    out <- rbind(out, row(fit, r))
  }
  out
}

cat(sprintf("second-wave runs at design_posterior(): field %s, %d runs x %d round(s), spread %g, registration variance %s, reference %s, refine %s, register_runs %s, 150 x 20 draws, 1 chain\n",
            field_kind, n_add, rounds, spread, reg_var, reference, refine, register_runs))
res <- parallel::mclapply(cases, one, mc.cores = cores, mc.preschedule = FALSE)
bad <- vapply(res, inherits, logical(1), "try-error")
if (any(bad)) stop("failed: ", paste(vapply(res[bad], as.character, ""), collapse = "\n"))
res <- do.call(rbind, res)
num <- vapply(res, is.double, logical(1))
res[num] <- lapply(res[num], signif, 3)
print(res, row.names = FALSE)
