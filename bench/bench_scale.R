# Time and memory of a validation by phase, on synthetic problems of growing
# size: S sites x T time points x K model runs x E experiments. The phases
# are those validate() runs (R/validate.R), called one by one as it calls
# them: preflight(), register_curves() of the field curves (windows on the
# events, knots_every = "auto"), wavelet_basis(), fit_emulators() (engine
# "gasp_level"), for E >= 2 the registration of the other experiments' field
# data (the package's register_experiments(), as validate() calls it:
# register_all_experiments() below), calibrate() with a short
# sampler, sampler_control(n_draws = 100, n_inner = 20), two chains
# (validate()'s default), then the reality band (predict(fit, type =
# "reality")), where_fails() and validation_report() (to a temporary file;
# skipped with a message without pandoc).
#
# The cost of one Metropolis-Hastings cycle is the difference of two
# calibrations that differ only in n_inner (20, and n_inner_long: 200, 60 at
# the large size; the burn-in is max(5000, n_draws * n_inner / 4) = 5000
# cycles for both, so the start's search, the burn-in and the set-up cancel):
# (t_long - t_20) / (2 chains x 100 draws x (n_inner_long - 20) cycles), the
# longer one being the phase "calibrate_longer". The default
# sampler_control() (n_draws = 1000, n_inner = 200, burn-in max(5000, 1000 *
# 200 / 4) = 50,000: 250,000 cycles per chain, two chains, one after the
# other under future's default plan) is projected as the short calibration's
# time plus 2 x (250,000 - 7,000) cycles at that cost; it is never run.
# validate() with the default sampler is projected as the sum of the phases
# before calibrate() plus the projected calibration.
#
# Memory, per phase: R's high-water mark of memory (gc(reset = TRUE) before,
# "max used" after, Ncells + Vcells) above what was in use before the phase,
# and the process's peak resident set (VmHWM of /proc/self/status, reset
# before the phase through /proc/self/clear_refs where the kernel allows it),
# absolute. Times are elapsed (wall) and CPU (user + system of the process
# and its children: pandoc for the report); with the machine shared, CPU
# time is the steadier measure of the work. The phases other than
# fit_emulators(), calibrate() and the report are run up to three times
# while they have taken less than 10 s, and their fastest time kept. Each
# size runs in its own R process (one after the other, never two at once),
# so that one size's heap does not count in the next one's.
#
# The synthetic problem: t in [0, 1] on T points; 6 inputs on [0, 1], u1-u3
# calibration, x1-x3 variation (nominal 0.5); K runs from a Latin hypercube.
# At site s the model is a slow oscillation, three sharp events (each a peak
# and a dip about 0.006 of the record apart, the derivative of a Gaussian)
# and a steep step; the events' amplitudes and, slightly, their times depend
# on the inputs, differently at each site. The field at each site is 3
# replicates of the model at u = (0.3, 0.6, 0.45) and the nominal x, plus a
# small bump the model lacks, noise (sd 0.02) and a smooth time warp of each
# replicate (up to 0.002 of the record, the same at every site). With E = 2,
# a second experiment: the same unit with x1 changed by +0.1
# (experiment(field2, change = c(x1 = 0.1))), its own 3 replicates.
# Registration windows: one around each peak-and-dip event (features min and
# max). The basis keeps about 350 coefficients per site at 1024 points.
#
# Sizes: base = 2 sites x 1024 points x 50 runs x 1 experiment; sites,
# points, runs, experiments = the base with that factor doubled alone;
# large = 4 x 4096 x 200 x 2 (the issue "Scale: a large validation in minutes
# on two cores": validate() there within 5 minutes and 4 GB). The growth
# exponent of a phase in a factor is log2(its time at the doubled size / its
# time at the base).
#
# Run: R_LIBS=<lib> Rscript bench/bench_scale.R [sizes=base,sites,points,runs,experiments,large]
#   e.g. Rscript bench/bench_scale.R base,points; the exponents need base and
#   the doubled sizes in one run; WAVEVALID_BENCH_SAVE=<file.rds> saves the
#   results of every size
#   R_LIBS=<lib> [WAVEVALID_BENCH_PLAN=auto|sequential|multisession|slurm] Rscript bench/bench_scale.R large default
#   runs validate() itself with every default at that size (its phases from
#   fit$timing, the chains' rounds, ESS and R-hat), then where_fails() and
#   validation_report() on its fit
#
# Measured on a 2-core machine shared with other jobs (load average 5-7, so
# elapsed time ran at about 2.5 x CPU time; R 4.2, reference BLAS); CPU
# seconds (elapsed in brackets), peak RSS; the whole table is in
# bench/README.md, "bench_scale.R":
#   base 2 x 1024 x 50 x 1 (349 coefficients per site): preflight,
#     registration and basis 0.6 s (1.7), fit_emulators 1.1 s (2.7),
#     calibrate(100 x 20) 1.8 s (4.5), 0.080 s (0.21) per 1000 cycles, the
#     default sampler projected 41 s (104); bands 0.06 s, where_fails 0.4 s,
#     validation_report 10.8 s (27.3); peak RSS 278 MiB.
#   growth exponents, CPU time (sites, points, runs, experiments):
#     fit_emulators 0.81, 0.80, 1.55, 0.33; cost per cycle 1.54, 1.17, 1.14,
#     1.41 (the coefficients per site: 349, 418 at 4 sites, 630 at 2048
#     points, 325 at 100 runs); where_fails 1.26, 1.38, 0.04, 1.15;
#     validation_report 0.53, 0.26, 0.03, 0.29 (pandoc and knitr dominate).
#     Phases under a second vary by +-0.3 or more in the exponent.
#   large 4 x 4096 x 200 x 2 (1919 coefficients per site): preflight,
#     registration and basis 3.0 s (6.1), fit_emulators 94 s (220) with R's
#     peak 3.6 GiB, the second experiment's registration 23 s (58),
#     calibrate(100 x 20) 147 s (371) with peak RSS 7.7 GiB, 4.47 s (12.7)
#     per 1000 cycles, the default sampler projected 2318 s (6519); bands
#     5.9 s (15), where_fails 15 s (37), validation_report 103 s (260).
#     validate() with the default sampler projected 2438 s of CPU, 41 min
#     (8.1 x the issue's 5 minutes), peak RSS 7.7 GiB (1.9 x its 4 GB).
library(wavevalid)
options(wavevalid.quiet = TRUE)

sizes_all <- list(
  base = c(S = 2L, T = 1024L, K = 50L, E = 1L),
  sites = c(S = 4L, T = 1024L, K = 50L, E = 1L),
  points = c(S = 2L, T = 2048L, K = 50L, E = 1L),
  runs = c(S = 2L, T = 1024L, K = 100L, E = 1L),
  experiments = c(S = 2L, T = 1024L, K = 50L, E = 2L),
  large = c(S = 4L, T = 4096L, K = 200L, E = 2L)
)
# n_inner of the second, longer calibration that gives the cost of a cycle
# (at most 200, so that the burn-in stays 5000 cycles); shorter at the large
# size, whose cycles cost tens of times the base's
n_inner_long <- c(base = 200L, sites = 200L, points = 200L, runs = 200L, experiments = 200L, large = 60L)
# two chains of 1000 x 200 (the fixed length that was the default, and the
# stopping rule's ceiling)
default_cycles <- 2 * (1000 * 200 + max(5000, 1000 * 200 / 4))
# two chains of the default stopping rule's first round, ess / chains = 200
# draws of n_inner = 50 cycles after a burn-in of max(5000, 200 * 50 / 4):
# enough when every saved draw is about one effective draw (0.8-0.9 on the
# test beds, studies/stopping.R); a second round adds what the ESS lacks
stop_cycles <- 2 * (200 * 50 + max(5000, 200 * 50 / 4))

args <- commandArgs(trailingOnly = TRUE)
named_sizes <- names(sizes_all)
child <- length(args) >= 1L && args[1] == "--one"

# A size given as SxTxKxE (sites x points x runs x experiments, e.g.
# 16x8192x500x4) besides the named ones: its calibrations are shorter
# (n_draws 20, burn-in 100, n_inner 5 and 25: 800 cycles between them), as
# a cycle there costs up to hundreds of times the base's.
custom_size <- function(size) {
  if (size %in% names(sizes_all)) return(NULL)
  v <- suppressWarnings(as.integer(strsplit(size, "x", fixed = TRUE)[[1]]))
  if (length(v) != 4L || anyNA(v) || any(v < 1L) || v[2] < 64L || v[3] < 10L) {
    stop("size ", size, ": give one of ", paste(names(sizes_all), collapse = ", "),
         " or sites x points x runs x experiments as SxTxKxE, e.g. 16x8192x500x4")
  }
  stats::setNames(v, c("S", "T", "K", "E"))
}
for (a in unique(unlist(strsplit(args[!startsWith(args, "-") & !grepl("\\.rds$", args) &
                                      !args %in% c("default")], ",", fixed = TRUE)))) {
  d <- custom_size(a)
  if (!is.null(d)) {
    sizes_all[[a]] <- d
    n_inner_long[[a]] <- 25L
  }
}
short_of <- function(size) {
  if (size %in% named_sizes) {
    return(list(n_draws = 100L, n_inner = 20L, burnin = NULL))
  }
  list(n_draws = 20L, n_inner = 5L, burnin = 100L)
}
# the phases one by one in this process: the chains one after the other
options(wavevalid.workers = 1)

# --- the synthetic problem ------------------------------------------------------
inputs <- c("u1", "u2", "u3", "x1", "x2", "x3")
u_true <- c(u1 = 0.3, u2 = 0.6, u3 = 0.45)
x_nom <- c(x1 = 0.5, x2 = 0.5, x3 = 0.5)

# three sharp events, each a peak and a dip 0.006 of the record apart (a
# doublet), then a steep step; registration windows on the doublets
event_at <- c(0.15, 0.35, 0.6)
windows <- lapply(event_at, function(e) c(e - 0.03, e + 0.03))
doublet <- function(t, at, w) ((t - at) / w) * exp(-((t - at) / w)^2)

model <- function(t, z, s) {
  shift <- 0.004 * (z[["u3"]] - 0.5)
  (0.5 + 0.3 * z[["x2"]]) * sin(2 * pi * (1.5 + 0.2 * s) * t) -
    (1.5 + z[["u1"]] + 0.2 * s) * doublet(t, event_at[1] + shift, 0.004) -
    (1 + 0.8 * z[["x1"]]) * doublet(t, event_at[2], 0.005) -
    (1.2 + z[["u2"]] - 0.1 * s) * doublet(t, event_at[3] - shift, 0.003) +
    (0.4 + 0.4 * z[["x3"]] + 0.3 * z[["u1"]] * z[["u2"]]) * stats::plogis((t - 0.8) / 0.002)
}

lhs <- function(K, p) {
  m <- sapply(seq_len(p), function(j) (sample(K) - stats::runif(K)) / K)
  colnames(m) <- inputs
  as.data.frame(m)
}

# 3 replicates at every site; the time warp belongs to the replicate (the
# test run), the same at every site
field_of <- function(t, S, z) {
  warps <- lapply(1:3, function(r) t + stats::runif(1, -0.002, 0.002) * sin(2 * pi * t))  # ends fixed
  curves <- lapply(seq_len(S), function(s) {
    truth <- model(t, z, s) + 0.15 * exp(-((t - 0.48) / 0.01)^2)    # a bump the model lacks
    t(sapply(warps, function(tw) stats::approx(t, truth, tw, rule = 2)$y + stats::rnorm(length(t), sd = 0.02)))
  })
  names(curves) <- paste0("site", seq_len(S))
  curves
}

problem <- function(S, T, K, E, seed = 1) {
  set.seed(seed)
  t <- (0:(T - 1L)) / (T - 1L)
  design <- lhs(K, length(inputs))
  run_curves <- lapply(seq_len(S), function(s) t(apply(as.matrix(design), 1L, function(z) model(t, z, s))))
  names(run_curves) <- paste0("site", seq_len(S))
  runs <- model_runs(design, run_curves, t)
  field <- field_runs(field_of(t, S, c(u_true, x_nom)), t, x_nom = x_nom)
  experiments <- NULL
  # experiments 2, 3, 4, ...: x1, x2, x3, x1, ... changed by +0.1
  for (e in seq_len(max(0L, E - 1L))) {
    p <- names(x_nom)[(e - 1L) %% 3L + 1L]
    step <- 0.1 * ((e - 1L) %/% 3L + 1L)
    xe <- x_nom
    xe[[p]] <- xe[[p]] + step
    fe <- field_runs(field_of(t, S, c(u_true, xe)), t, x_nom = x_nom)
    experiments[[sprintf("changed_%s_%d", p, e)]] <- experiment(fe, change = stats::setNames(step, p))
  }
  iu <- iu_map(inputs, rep(c("calibration", "variation"), each = 3), lower = rep(0, 6), upper = rep(1, 6),
               nominal = rep(0.5, 6))
  list(runs = runs, field = field, iu = iu, experiments = experiments, windows = windows)
}

# --- measuring a phase ----------------------------------------------------------
status_mib <- function(key) {
  st <- readLines("/proc/self/status")
  as.numeric(sub(sprintf("^%s:\\s*(\\d+).*", key), "\\1", grep(sprintf("^%s", key), st, value = TRUE))) / 1024
}
reset_hwm <- function() {
  tryCatch({
    writeLines("5", "/proc/self/clear_refs")
    TRUE
  }, error = function(e) FALSE, warning = function(w) FALSE)
}
phases <- list()
# A phase is run up to three times while it has taken less than 10 s in all
# (the load of the machine's other jobs makes single timings of a second or
# two noisy); its time is the fastest run, its memory the first run's.
measure <- function(phase, expr, reps = 3L) {
  f <- function() NULL
  body(f) <- substitute(expr)
  environment(f) <- parent.frame()
  invisible(gc())
  g0 <- gc(reset = TRUE)
  base_r <- sum(g0[, 2])
  hwm_ok <- reset_hwm()
  cpu_of <- function(st) sum(st[c("user.self", "sys.self", "user.child", "sys.child")], na.rm = TRUE)
  st <- system.time(res <- f())
  g1 <- gc()
  r_mib <- sum(g1[, ncol(g1)]) - base_r
  rss_mib <- if (hwm_ok) status_mib("VmHWM") else NA_real_
  sec <- st[["elapsed"]]
  cpu <- cpu_of(st)
  n <- 1L
  spent <- sec
  while (n < reps && spent < 10) {
    rm(res)
    st <- system.time(res <- f())
    sec <- min(sec, st[["elapsed"]])
    cpu <- min(cpu, cpu_of(st))
    spent <- spent + st[["elapsed"]]
    n <- n + 1L
  }
  phases[[phase]] <<- data.frame(phase = phase, sec = sec, cpu = cpu, r_mib = r_mib, rss_mib = rss_mib, reps = n)
  # each phase as it ends, to stderr: a long size's phases can be read while it runs
  message(sprintf("[%s] %s: %.1f s elapsed, %.1f s CPU, R peak %.0f MiB, RSS peak %.0f MiB", format(Sys.time(), "%H:%M:%S"),
                  phase, sec, cpu, r_mib, rss_mib))
  res
}

# The experiments with a change (experiment(field, change = )), their field
# data registered as validate() registers them (the package's own
# register_experiments(): to the mean of the model runs with the change, each
# run moved by the emulators' change of its retained coefficients).
register_all_experiments <- function(experiments, emulators, runs, field, iu, windows, ...) {
  ns <- asNamespace("wavevalid")
  ex <- ns$check_experiments(experiments, emulators, field, iu = iu)
  ex <- ns$register_experiments(ex, emulators, runs, windows, ..., landmark_site = "all", quiet = TRUE)
  attr(ex, "references") <- NULL
  ex
}

# --- one size, in its own process ----------------------------------------------
run_one <- function(size, out_file) {
  d <- sizes_all[[size]]
  pr <- problem(d[["S"]], d[["T"]], d[["K"]], d[["E"]])
  runs <- pr$runs
  windows <- pr$windows
  knots_every <- diff(range(pr$field$t)) / 32
  sh <- short_of(size)
  short <- sampler_control(n_draws = sh$n_draws, n_inner = sh$n_inner, burnin = sh$burnin, quiet = TRUE)
  longer <- sampler_control(n_draws = sh$n_draws, n_inner = n_inner_long[[size]], burnin = sh$burnin, quiet = TRUE)
  pf <- measure("preflight", preflight(runs, pr$field, pr$iu, windows = windows))
  if (any(pf$status == "error")) stop("the pre-flight check failed: ", paste(pf$check[pf$status == "error"], collapse = ", "))
  field <- measure("register", register_curves(pr$field, runs, windows, features = c("min", "max"),
                                               knots_every = knots_every))
  basis <- measure("wavelet_basis", wavelet_basis(runs, field))
  emulators <- measure("fit_emulators", suppressWarnings(fit_emulators(runs, basis, "gasp_level")), reps = 1L)
  experiments <- NULL
  if (!is.null(pr$experiments)) {
    experiments <- measure("register_experiments",
                           register_all_experiments(pr$experiments, emulators, runs, field, pr$iu, windows,
                                                    features = c("min", "max"), knots_every = knots_every))
  }
  fit <- measure("calibrate", suppressWarnings(calibrate(emulators, field, pr$iu, experiments = experiments,
                                                         sampler = short, chains = 2, seed = 1)), reps = 1L)
  invisible(measure("calibrate_longer", suppressWarnings(calibrate(emulators, field, pr$iu,
                                                                       experiments = experiments,
                                                                       sampler = longer, chains = 2, seed = 1)), reps = 1L))
  invisible(measure("reality_band", predict(fit, type = "reality", seed = 1)))
  invisible(measure("where_fails", suppressWarnings(where_fails(fit))))
  if (requireNamespace("rmarkdown", quietly = TRUE) && rmarkdown::pandoc_available()) {
    f <- tempfile(fileext = ".html")
    invisible(measure("validation_report", suppressMessages(suppressWarnings(validation_report(fit, f))), reps = 1L))
    unlink(f)
  } else {
    message("validation_report() skipped: pandoc is not available")
  }
  tab <- do.call(rbind, phases)
  rownames(tab) <- NULL
  n_coef <- length(basis$index)
  saveRDS(list(size = size, dims = d, phases = tab, n_coef = n_coef, burnin = fit$settings$burnin,
               n_inner_long = n_inner_long[[size]], short = sh),
          out_file)
}

# --- validate() itself with every default, then where_fails() and the report ---
# One call of validate() as a user makes it (windows and the experiments
# given, seed = 1, every other argument its default: the stopping rule, two
# chains) under the plan named in the environment variable
# WAVEVALID_BENCH_PLAN:
#   auto          (the default) the package's own: with no plan set, a
#                 multisession plan over the free cores for the call
#   sequential    every phase in this process (options(wavevalid.workers = 1))
#   multisession  future::plan(multisession, workers = 2) set beforehand
#   slurm         future.batchtools' Slurm template through a stand-in for
#                 Slurm's commands on this machine (the one the tests use):
#                 sbatch keeps each job script and runs it at once, under
#                 /usr/bin/time where there is one, which gives each job's
#                 peak resident set; the number of jobs and their peaks
#                 are reported
# Its phases as fit$timing records them, the chains' rounds, ESS and R-hat
# (fit$stopping); the peak resident set of the process and of its
# descendants together (the multisession workers; sampled every half
# second by a shell loop); then where_fails() and validation_report() on
# the fit.
tree_rss_monitor <- function(out) {
  script <- sprintf(paste0(
    "max=0; while kill -0 %d 2>/dev/null; do ",
    "s=$(ps -e -o pid=,ppid=,rss= | awk -v root=%d '{p[$1]=$2; r[$1]=$3} END {",
    "t=0; for (q in p) { x=q; while (x != 0 && x != 1 && x != root && (x in p)) x=p[x]; if (x == root) t+=r[q] } print t}'); ",
    "if [ \"$s\" -gt \"$max\" ]; then max=$s; echo $max > %s; fi; sleep 0.5; done"),
    Sys.getpid(), Sys.getpid(), out)
  system2("bash", c("-c", shQuote(script)), wait = FALSE)
}
fake_slurm <- function(dir) {
  dir.create(dir, showWarnings = FALSE, recursive = TRUE)
  timer <- if (file.exists("/usr/bin/time")) sprintf("/usr/bin/time -a -o %s -f %%M ", file.path(dir, "rss_kib.txt")) else ""
  writeLines(c("#!/bin/sh", "cat \"$1\" >> \"$(dirname \"$0\")/submitted.txt\"",
               sprintf("%sbash \"$1\" >/dev/null 2>&1", timer), "echo \"Submitted batch job $$\""),
             file.path(dir, "sbatch"))
  writeLines(c("#!/bin/sh", "exit 0"), file.path(dir, "squeue"))
  writeLines(c("#!/bin/sh", "exit 0"), file.path(dir, "scancel"))
  Sys.chmod(file.path(dir, c("sbatch", "squeue", "scancel")), "0755")
  dir
}
run_default <- function(size, out_file) {
  d <- sizes_all[[size]]
  pr <- problem(d[["S"]], d[["T"]], d[["K"]], d[["E"]])
  plan <- Sys.getenv("WAVEVALID_BENCH_PLAN", "auto")
  options(wavevalid.workers = "auto")
  jobs <- NULL
  if (plan == "sequential") options(wavevalid.workers = 1)
  if (plan == "multisession") future::plan(future::multisession, workers = 2)
  if (plan == "slurm") {
    home <- tempfile("slurm")
    bin <- fake_slurm(file.path(home, "bin"))
    Sys.setenv(PATH = paste(bin, Sys.getenv("PATH"), sep = .Platform$path.sep))
    setwd(home)  # batchtools keeps its registries under the working directory
    future::plan(future.batchtools::batchtools_slurm, template = "slurm-simple",
                 resources = list(walltime = 3600, memory = 8000, ncpus = 1))
  }
  rss_file <- tempfile()
  tree_rss_monitor(rss_file)
  options(wavevalid.quiet = FALSE)
  fit <- measure("validate_default", validate(pr$runs, pr$field, pr$iu, windows = pr$windows,
                                              experiments = pr$experiments, seed = 1), reps = 1L)
  options(wavevalid.quiet = TRUE)
  invisible(measure("where_fails", suppressWarnings(where_fails(fit)), reps = 1L))
  if (requireNamespace("rmarkdown", quietly = TRUE) && rmarkdown::pandoc_available()) {
    f <- tempfile(fileext = ".html")
    invisible(measure("validation_report", suppressMessages(suppressWarnings(validation_report(fit, f))), reps = 1L))
    unlink(f)
  }
  tree_peak <- if (file.exists(rss_file)) as.numeric(readLines(rss_file, n = 1L)) / 1024 else NA_real_
  if (plan == "slurm") {
    submitted <- readLines(file.path(bin, "submitted.txt"))
    rss <- if (file.exists(file.path(bin, "rss_kib.txt"))) as.numeric(readLines(file.path(bin, "rss_kib.txt"))) / 1024
    jobs <- list(n = sum(grepl("batchtools::doJobCollection", submitted, fixed = TRUE)), rss_mib = rss)
  }
  tab <- do.call(rbind, phases)
  rownames(tab) <- NULL
  saveRDS(list(size = size, dims = d, phases = tab, timing = fit$timing, stopping = fit$stopping, plan = plan,
               tree_peak_mib = tree_peak, jobs = jobs,
               n_coef = length(fit$basis$index), findings = nrow(suppressWarnings(where_fails(fit)))),
          out_file)
}

if (child) {
  if (length(args) >= 4L && args[4] == "default") run_default(args[2], args[3]) else run_one(args[2], args[3])
  quit(save = "no")
}

# with "default" as the second argument: validate() with every default at
# each size, instead of the phases one by one
if (length(args) >= 2L && args[2] == "default") {
  sizes <- strsplit(args[1], ",", fixed = TRUE)[[1]]
  script <- sub("^--file=", "", grep("^--file=", commandArgs(FALSE), value = TRUE))
  for (size in sizes) {
    f <- tempfile(fileext = ".rds")
    status <- system2(file.path(R.home("bin"), "Rscript"), c(script, "--one", size, f, "default"))
    if (status != 0L || !file.exists(f)) {
      cat(sprintf("size %s: failed (exit status %d)\n", size, status))
      next
    }
    r <- readRDS(f)
    d <- r$dims
    cat(sprintf("\n== %s: %d sites x %d points x %d runs x %d experiment%s, validate() with every default (plan %s)\n",
                size, d[["S"]], d[["T"]], d[["K"]], d[["E"]], if (d[["E"]] > 1) "s" else "", r$plan))
    print(data.frame(call = r$phases$phase, elapsed_s = round(r$phases$sec, 1), cpu_s = round(r$phases$cpu, 1),
                     R_peak_MiB = round(r$phases$r_mib), RSS_peak_MiB = round(r$phases$rss_mib)), row.names = FALSE)
    cat(sprintf("peak resident set of this process and its workers together: %.0f MiB\n", r$tree_peak_mib))
    if (!is.null(r$jobs)) {
      cat(sprintf("jobs submitted through the Slurm template: %d; their peak resident sets (MiB): %s\n", r$jobs$n,
                  paste(round(r$jobs$rss_mib), collapse = ", ")))
    }
    cat("validate()'s phases (fit$timing):\n")
    print(r$timing, row.names = FALSE)
    st <- r$stopping
    if (!is.null(st)) {
      cat(sprintf("chains: %d draws each in %d round(s); smallest ESS %.0f (%s), largest R-hat %.3f; targets met: %s; findings %d\n",
                  st$draws, st$rounds, st$ess, st$slowest, st$rhat, st$met, r$findings))
    }
    if (nzchar(Sys.getenv("WAVEVALID_BENCH_SAVE"))) saveRDS(r, Sys.getenv("WAVEVALID_BENCH_SAVE"))
  }
  quit(save = "no")
}

# --- the driver: each size in turn, then the table and the exponents ----------
sizes <- if (length(args) >= 1L) strsplit(args[1], ",", fixed = TRUE)[[1]] else names(sizes_all)
bad <- setdiff(sizes, names(sizes_all))
if (length(bad)) stop("unknown size(s): ", paste(bad, collapse = ", "), "; known: ", paste(names(sizes_all), collapse = ", "))
script <- sub("^--file=", "", grep("^--file=", commandArgs(FALSE), value = TRUE))
rscript <- file.path(R.home("bin"), "Rscript")
results <- list()
for (size in sizes) {
  f <- tempfile(fileext = ".rds")
  t0 <- proc.time()[["elapsed"]]
  status <- system2(rscript, c(script, "--one", size, f))
  if (status != 0L || !file.exists(f)) {
    cat(sprintf("size %s: failed (exit status %d)\n", size, status))
    next
  }
  r <- readRDS(f)
  unlink(f)
  results[[size]] <- r
  tab <- r$phases
  d <- r$dims
  # cost of a cycle: 100 draws x (n_inner_long - 20) more cycles in each of 2 chains
  cyc <- function(col) {
    long <- tab[[col]][tab$phase == "calibrate_longer"]
    short <- tab[[col]][tab$phase == "calibrate"]
    sh <- r$short
    per_cycle <- (long - short) / (2 * sh$n_draws * (r$n_inner_long - sh$n_inner))
    short_cycles <- 2 * (sh$n_draws * sh$n_inner + r$burnin)
    before <- sum(tab[[col]][tab$phase %in% c("preflight", "register", "wavelet_basis", "fit_emulators",
                                               "register_experiments")])
    proj_cal <- short + (default_cycles - short_cycles) * per_cycle
    proj_stop <- short + (stop_cycles - short_cycles) * per_cycle
    c(per_1000 = 1000 * per_cycle, proj_cal = proj_cal, before = before, proj_validate = before + proj_cal,
      proj_stop = proj_stop, proj_validate_stop = before + proj_stop)
  }
  r$elapsed <- cyc("sec")
  r$cpu <- cyc("cpu")
  results[[size]] <- r
  cat(sprintf("\n== %s: %d sites x %d points x %d runs x %d experiment%s; %d coefficients per site (%.0f s in all)\n",
              size, d[["S"]], d[["T"]], d[["K"]], d[["E"]], if (d[["E"]] > 1) "s" else "", r$n_coef,
              proc.time()[["elapsed"]] - t0))
  print(data.frame(phase = tab$phase, elapsed_s = round(tab$sec, 2), cpu_s = round(tab$cpu, 2),
                   R_peak_MiB = round(tab$r_mib, 1), RSS_peak_MiB = round(tab$rss_mib, 1), reps = tab$reps), row.names = FALSE)
  for (w in c("elapsed", "cpu")) {
    v <- r[[w]]
    cat(sprintf("%-7s calibrate: %.3f s per 1000 Metropolis-Hastings cycles (both chains' cycles counted); 2 chains of 1000 x 200 (%d cycles) projected %.0f s; validate() with them %.0f s (%.1f s before calibrate())\n",
                w, v[["per_1000"]], default_cycles, v[["proj_cal"]], v[["proj_validate"]], v[["before"]]))
    cat(sprintf("%-7s the stopping rule's first round (%d cycles) projected %.0f s; validate() with it %.0f s\n",
                w, stop_cycles, v[["proj_stop"]], v[["proj_validate_stop"]]))
  }
  cat(sprintf("peak RSS over the phases %.0f MiB\n", max(tab$rss_mib)))
}

if (nzchar(Sys.getenv("WAVEVALID_BENCH_SAVE"))) saveRDS(results, Sys.getenv("WAVEVALID_BENCH_SAVE"))

if ("base" %in% names(results)) {
  b <- results$base
  factors <- intersect(c("sites", "points", "runs", "experiments"), names(results))
  if (length(factors)) {
    ph <- b$phases$phase
    growth <- function(col, w) {
      ex <- sapply(factors, function(f) {
        x <- results[[f]]$phases
        vapply(ph, function(p) {
          v <- log2(x[[col]][x$phase == p] / b$phases[[col]][b$phases$phase == p])
          if (length(v) == 1L) v else NA_real_
        }, numeric(1))
      })
      rbind(matrix(ex, nrow = length(ph), dimnames = list(ph, factors)),
            `s per 1000 cycles` = sapply(factors, function(f) log2(results[[f]][[w]][["per_1000"]] / b[[w]][["per_1000"]])),
            `default calibrate (proj.)` = sapply(factors, function(f) log2(results[[f]][[w]][["proj_cal"]] / b[[w]][["proj_cal"]])),
            `validate() default (proj.)` = sapply(factors, function(f) log2(results[[f]][[w]][["proj_validate"]] / b[[w]][["proj_validate"]])))
    }
    cat("\nGrowth exponents, log2(time at the doubled size / time at the base), elapsed time:\n")
    print(round(growth("sec", "elapsed"), 2))
    cat("\nThe same, CPU time (user + system, this process and its children):\n")
    print(round(growth("cpu", "cpu"), 2))
    cat("(register_experiments is absent at the base: the second experiment's registration has no exponent)\n")
  }
}
