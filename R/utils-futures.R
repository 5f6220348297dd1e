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
