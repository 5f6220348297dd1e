# Time and memory of a validation at many test conditions: the dosing test
# bed with the dose amount a condition of the I/U map (testbed_dosing(doses
# = ), 80 model runs over the six inputs and the dose), validated with
# validate() at 1, 3 and 10 dose amounts (the base experiment at 400 mg and
# the others through experiments_at(), one bias per experiment, landmarks in
# the dose windows), then the band at an untested amount (predict(type =
# "new_condition")) and where_fails().
#
# The peer is the same validation at one condition: the table gives each
# phase's time at 3 and 10 conditions and its ratio to the time at 1, and
# the ratio per added condition.
#
# Per size, in its own R process (so that one size's heap does not count in
# the next one's): the phases' times as validate() records them
# (fit$timing: preflight, the base field's registration, basis, emulators,
# the experiments' registration, calibration; elapsed and CPU seconds), with
# a short sampler (two chains of 100 x 20, validate()'s default chains);
# the cost of one Metropolis-Hastings cycle from the calibration phase of a
# second validate() of the same problem with n_inner = 120 (both have the
# burn-in max(5000, n_draws x n_inner / 4) = 5000, so the set-up cancels) and the default sampler_control() projected from it (as in
# bench_scale.R: 2 x 250,000 cycles); predict() at 425 mg (no field there)
# and where_fails(); R's high-water mark of memory over the whole size
# (gc(reset = TRUE), the second validate() included) and the process's peak resident set (VmHWM).
#
# Run: R_LIBS=<lib> Rscript bench/bench_conditions.R [conditions=1,3,10]
#
# Measured on a 2-core machine shared with another job (R 4.2, reference
# BLAS), CPU seconds at 1, 3 and 10 conditions: calibration (2 x 100 x 20)
# 15.3, 42.9, 147.4; per 1000 cycles 0.93, 2.29, 9.16 (0.99 of one
# condition's per added condition); the default sampler projected 466, 1158,
# 4601 s; registration 2.6, 5.1, 14.2; fit_emulators() 9.7, 11.7, 9.7; peak
# RSS 181, 203, 249 MiB. The table is in bench/README.md.
library(wavevalid)
options(wavevalid.quiet = TRUE)

others <- c(250, 275, 300, 325, 350, 450, 500, 525, 550)  # besides the base 400 mg
pick <- list(`1` = numeric(0), `3` = c(250, 550), `10` = others)
untested <- 425
default_cycles <- 2 * (1000 * 200 + max(5000, 1000 * 200 / 4))

args <- commandArgs(trailingOnly = TRUE)
child <- length(args) >= 1L && args[1] == "--one"

status_mib <- function(key) {
  st <- readLines("/proc/self/status")
  as.numeric(sub(sprintf("^%s:\\s*(\\d+).*", key), "\\1", grep(sprintf("^%s", key), st, value = TRUE))) / 1024
}
cpu_of <- function(st) sum(st[c("user.self", "sys.self", "user.child", "sys.child")], na.rm = TRUE)

run_one <- function(n_cond, out_file) {
  doses <- pick[[as.character(n_cond)]]
  tb <- testbed_dosing(1, "none", doses = c(others, untested))
  exps <- if (length(doses)) experiments_at(tb$doses$fields[paste0("dose_", doses)], data.frame(dose = doses))
  short <- sampler_control(n_draws = 100, n_inner = 20, quiet = TRUE)
  invisible(gc(reset = TRUE))
  fit <- suppressWarnings(validate(tb$doses$runs, tb$A$field, tb$doses$iu, windows = tb$windows,
                                   experiments = exps, sampler = short, chains = 2, seed = 1))
  # the same validation with a longer calibration: the cost of a cycle
  longer <- sampler_control(n_draws = 100, n_inner = 120, quiet = TRUE)
  fit_long <- suppressWarnings(validate(tb$doses$runs, tb$A$field, tb$doses$iu, windows = tb$windows,
                                        experiments = exps, sampler = longer, chains = 2, seed = 1))
  cal_long <- fit_long$timing[fit_long$timing$phase == "calibration", ]
  st_pred <- system.time(p <- predict(fit, type = "new_condition", condition = c(dose = untested), seed = 1))
  st_fails <- system.time(wf <- suppressWarnings(where_fails(fit)))
  g <- gc()
  saveRDS(list(n_cond = n_cond, timing = fit$timing, long = c(elapsed = cal_long$elapsed, cpu = cal_long$cpu),
               predict = c(elapsed = st_pred[["elapsed"]], cpu = cpu_of(st_pred)),
               where_fails = c(elapsed = st_fails[["elapsed"]], cpu = cpu_of(st_fails)),
               r_peak = sum(g[, ncol(g)]), rss_peak = status_mib("VmHWM"), n_coef = length(fit$emulators$basis$index),
               burnin = fit$settings$burnin, n_findings = nrow(as.data.frame(wf))),
          out_file)
}

if (child) {
  run_one(as.integer(args[2]), args[3])
  quit(save = "no")
}

sizes <- if (length(args) >= 1L) as.integer(strsplit(args[1], ",", fixed = TRUE)[[1]]) else c(1L, 3L, 10L)
bad <- setdiff(as.character(sizes), names(pick))
if (length(bad)) stop("conditions must be among ", paste(names(pick), collapse = ", "))
script <- sub("^--file=", "", grep("^--file=", commandArgs(FALSE), value = TRUE))
rscript <- file.path(R.home("bin"), "Rscript")
res <- list()
for (n in sizes) {
  f <- tempfile(fileext = ".rds")
  status <- system2(rscript, c(script, "--one", n, f))
  if (status != 0L || !file.exists(f)) {
    cat(sprintf("%d conditions: failed (exit status %d)\n", n, status))
    next
  }
  res[[as.character(n)]] <- readRDS(f)
}
row_of <- function(r, w) {
  tm <- r$timing
  get <- function(p) if (p %in% tm$phase) tm[[w]][tm$phase == p] else 0
  cal <- get("calibration")
  per_cycle <- (r$long[[w]] - cal) / (2 * 100 * (120 - 20))
  proj_cal <- cal + (default_cycles - 2 * (100 * 20 + r$burnin)) * per_cycle
  before <- sum(tm[[w]][tm$phase != "calibration"])
  c(registration = get("registration") + get("experiments"), emulators = get("emulators"),
    calibration_100x20 = cal, s_per_1000_cycles = 1000 * per_cycle, default_calibration_proj = proj_cal,
    validate_default_proj = before + proj_cal, predict_new = r$predict[[w]], where_fails = r$where_fails[[w]])
}
for (w in c("cpu", "elapsed")) {
  tab <- sapply(res, row_of, w = w)
  colnames(tab) <- paste(names(res), "cond.")
  cat(sprintf("\nSeconds (%s) by phase, dosing bed, 80 runs, %d coefficients:\n", w, res[[1]]$n_coef))
  print(round(tab, 2))
  if ("1" %in% names(res) && ncol(tab) > 1L) {
    cat(sprintf("\nRatio to one condition (%s), and per added condition:\n", w))
    ratio <- tab[, -1, drop = FALSE] / tab[, 1]
    print(round(ratio, 2))
    n <- as.integer(names(res))[-1]
    print(round(sweep(ratio - 1, 2, n - 1, `/`), 2))
  }
}
mem <- sapply(res, function(r) c(R_peak_MiB = r$r_peak, RSS_peak_MiB = r$rss_peak, findings = r$n_findings))
colnames(mem) <- paste(names(res), "cond.")
cat("\nMemory (whole size) and findings:\n")
print(round(mem, 0))
