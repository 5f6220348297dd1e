# Running the chains of calibrate(): one future per chain, each the C++
# sampler, on as many threads as there are free cores.

# Cores free for this process: the option wavevalid.free_cores when set, else
# the cores R sees less the other processes the 1-minute load average counts
# (this one counted once; Linux, elsewhere every core), at least 1.
free_cores <- function() {
  set <- getOption("wavevalid.free_cores")
  if (is.numeric(set) && length(set) == 1L && is.finite(set) && set >= 1) return(as.integer(set))
  n <- suppressWarnings(parallel::detectCores())
  if (is.na(n) || n < 1L) return(1L)
  load <- tryCatch(as.numeric(strsplit(readLines("/proc/loadavg", n = 1L, warn = FALSE), " ")[[1L]][1L]),
                   error = function(e) NA_real_, warning = function(w) NA_real_)
  busy <- if (length(load) == 1L && is.finite(load)) max(0, round(load - 1)) else 0
  as.integer(max(1, n - busy))
}

# One future per chain. `sm`: the sampler's settings, a sampler_control()
# with `burnin` and `threads` resolved (calibrate()). debug_break (1: no
# proposal-density ratio of the global moves, 2: no tau2 ratio, ...) exists
# only to show that the simulation-based checks detect errors.
run_chains <- function(spec, sm, chains, seed, tau, debug_break = 0L, p_global = 0.1) {
  worker <- chain_worker(spec, sm, seed, tau, debug_break, p_global)
  # the worker carries the sampler's spec in its closure, sent once per chain
  future.apply::future_lapply(seq_len(chains), worker, future.seed = NULL, future.packages = "wavevalid",
                              future.globals = stats::setNames(list(), character(0)))
}

# The function a chain's future evaluates: its environment holds only what
# the chain needs (the sampler's spec, settings and seed). On the suspension
# test bed (2 sites, 431 coefficients each, 66 runs) that is 30 MiB per chain.
chain_worker <- function(spec, sm, seed, tau, debug_break, p_global) {
  # forced, so that no promise carries the caller's frame to the worker
  force(sm)
  force(seed)
  force(debug_break)
  force(p_global)
  fix <- any(tau$fixed)
  tau_init <- if (fix) unname(tau$values) else numeric(0)
  # what the C++ sampler reads: by site the emulators' banks and the field's
  # coefficients, and the priors (not the basis nor the I/U map)
  spec <- list(sites = spec$sites, priors = spec$priors, groups = spec$groups["name"], z_init = spec$z_init,
               informs = spec$informs, temper = spec$temper, input_weight = spec$input_weight,
               reg_shift_var = spec$reg_shift_var)
  rm(tau)
  function(ch) {
    n_draws <- sm$n_draws
    progress <- NULL
    if (!isTRUE(sm$quiet)) {
      id <- cli::cli_progress_bar(sprintf("Chain %d", ch), total = n_draws, .envir = environment())
      progress <- function(h) cli::cli_progress_update(id = id, set = h)
    }
    settings <- list(n_groups = nrow(spec$groups), z_init = as.numeric(spec$z_init),
                     tau2_init = as.numeric(tau_init), fix_tau2 = fix, n_draws = as.integer(n_draws),
                     n_inner = as.integer(sm$n_inner), step = as.numeric(sm$step), seed = as.numeric(seed),
                     chain = as.integer(ch), debug_break = as.integer(debug_break), progress = progress,
                     adaptive = identical(sm$proposal, "adaptive"), burnin = as.integer(sm$burnin),
                     p_global = as.numeric(p_global), p_indep = as.numeric(sm$global_moves),
                     n_search = as.integer(sm$n_search), threads = as.integer(sm$threads),
                     informs = as.integer(spec$informs %||% integer(0)),
                     temper = as.numeric(spec$temper %||% 1), input_weight = as.numeric(spec$input_weight %||% 1),
                     reg_shift_var = if (is.null(spec$reg_shift_var)) NULL else as.numeric(spec$reg_shift_var))
    calibrate_chain_cpp(spec$sites, spec$priors, settings)
  }
}
