# Work sent to futures, where future::plan() decides it runs.

# Runs tasks through future.apply in batches of twice the workers so that a
# progress bar labelled `label` can follow, task i moving it by steps[i].
# `worker` carries its data in its closure (no search for globals); the
# results do not depend on the plan (`future_seed` as future.apply's
# future.seed: NULL when each task sets its own seed).
run_futures <- function(tasks, worker, label, quiet = FALSE, steps = rep(1L, length(tasks)),
                        future_seed = NULL) {
  if (!length(tasks)) return(list())
  batch <- max(1L, 2L * future::nbrOfWorkers())
  groups <- split(seq_along(tasks), ceiling(seq_along(tasks) / batch))
  if (!quiet) cli::cli_progress_bar(label, total = sum(steps), .envir = environment())
  out <- vector("list", length(tasks))
  no_globals <- stats::setNames(list(), character(0))
  for (g in groups) {
    out[g] <- future.apply::future_lapply(tasks[g], worker, future.seed = future_seed,
                                          future.packages = "wavevalid",
                                          future.globals = no_globals)
    if (!quiet) cli::cli_progress_update(inc = sum(steps[g]), .envir = environment())
  }
  if (!quiet) cli::cli_progress_done(.envir = environment())
  out
}

# Cores free for this process: the option wavevalid.free_cores when set, else
# the cores R sees less those that other processes keep busy, measured over a
# quarter of a second from /proc/stat (Linux; elsewhere every core is free),
# at least 1. This process sleeps meanwhile, so its own work is not counted.
# (The load average lags: for a minute after a computation on every core it
# still counts them busy.)
free_cores <- function() {
  set <- getOption("wavevalid.free_cores")
  if (is.numeric(set) && length(set) == 1L && is.finite(set) && set >= 1) return(as.integer(set))
  n <- suppressWarnings(parallel::detectCores())
  if (is.na(n) || n < 1L) return(1L)
  as.integer(max(1, n - busy_cores(n)))
}

# The cores (of n) busy over `wait` seconds, from the first line of
# /proc/stat (the time every core spent in each state); 0 where it cannot be
# read.
busy_cores <- function(n, wait = 0.25) {
  read <- function() {
    line <- tryCatch(readLines("/proc/stat", n = 1L, warn = FALSE), error = function(e) "",
                     warning = function(w) "")
    v <- suppressWarnings(as.numeric(strsplit(trimws(line[1L]), " +")[[1L]][-1L]))
    if (length(v) < 5L || anyNA(v[1:5])) return(NULL)
    c(idle = v[4L] + v[5L], total = sum(v[seq_len(min(8L, length(v)))]))
  }
  a <- read()
  if (is.null(a)) return(0)
  Sys.sleep(wait)
  b <- read()
  if (is.null(b)) return(0)
  d <- b - a
  if (!(d[["total"]] > 0)) return(0)
  round(n * max(0, 1 - d[["idle"]] / d[["total"]]))
}

# The plan a call runs under when the user set none. With future's default
# (sequential) plan and the option wavevalid.workers "auto" (the default),
# or a number of workers, a multisession plan over the free cores
# (free_cores(): the cores R sees less those other processes keep busy, within
# future::availableCores()) is set for
# the caller's duration and the old plan restored on its exit; says so once
# per call. A plan the user set (other than sequential, or through the
# option future.plan or R_FUTURE_PLAN) is left alone, and so is
# wavevalid.workers = 1. The results are the same under every plan.
use_cores <- function(tasks, quiet, envir = parent.frame()) {
  want <- getOption("wavevalid.workers", "auto")
  ok <- identical(want, "auto") ||
    (is.numeric(want) && length(want) == 1L && is.finite(want) && want >= 1)
  if (!ok) {
    cli::cli_abort(c("The option {.code wavevalid.workers} must be {.val auto} or a number of workers (1 or more).",
                     "x" = "It is {.obj_type_friendly {want}}.",
                     "i" = "{.code options(wavevalid.workers = 1)} keeps the work in this R process."),
                   class = "wavevalid_error_workers")
  }
  if (!requireNamespace("future", quietly = TRUE) || !inherits(future::plan(), "sequential") ||
      !is.null(getOption("future.plan")) || nzchar(Sys.getenv("R_FUTURE_PLAN"))) {
    return(invisible(0L))
  }
  # inside a future's worker availableCores() is 1: no plan within a plan
  n <- if (identical(want, "auto")) min(free_cores(), future::availableCores()) else as.integer(want)
  n <- min(n, tasks)
  if (n < 2L) return(invisible(0L))
  old <- future::plan(future::multisession, workers = n)
  do.call(on.exit, list(substitute(future::plan(old), list(old = old)), add = TRUE), envir = envir)
  if (!quiet) {
    wv_inform(c("i" = paste0("Running on {n} cores (future's multisession plan, for this call); ",
                             "{.code options(wavevalid.workers = 1)} keeps the work in this R process, ",
                             "and a {.fn future::plan} of your own is used as it is.")),
              class = "cores")
  }
  invisible(n)
}
