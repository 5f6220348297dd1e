# Running the chains of calibrate(): one future per chain, each the C++
# sampler, on as many threads as there are free cores.

# One future per chain, or the chains together in this process
# (sm$together). `sm`: the sampler's settings, a sampler_control()
# with `burnin` and `threads` resolved (calibrate()). debug_break (1: no
# proposal-density ratio of the global moves, 2: no tau2 ratio, ...) exists
# only to show that the simulation-based checks detect errors. With
# `sm$n_draws` NULL the chains run in rounds until the inputs' draws meet
# the targets (chain_rounds()).
run_chains <- function(spec, sm, chains, seed, tau, debug_break = 0L, p_global = 0.1) {
  team <- isTRUE(sm$together) && chains >= 2L
  worker <- chain_worker(spec, sm, seed, tau, debug_break, p_global, team = team)
  # the worker carries the sampler's spec in its closure, sent once per chain;
  # chains run together run in this process, on its threads: neither the
  # spec nor the draws (at 4 sites x 4096 points, hundreds of MB a round)
  # travel between processes
  run <- function(jobs) {
    if (team) return(worker(jobs))
    future.apply::future_lapply(jobs, worker, future.seed = NULL, future.packages = "wavevalid",
                                future.globals = stats::setNames(list(), character(0)))
  }
  if (!is.null(sm$n_draws)) {
    return(run(lapply(seq_len(chains),
                      function(ch) list(chain = ch, n_draws = sm$n_draws, resume = NULL))))
  }
  chain_rounds(run, spec, sm, chains)
}

# The chains run until every input's effective sample size (all chains
# together, coda::effectiveSize()) reaches `sm$ess` and, with two chains or
# more, its R-hat (coda::gelman.diag()) is at most `sm$rhat`, or until they
# hold `sm$max_draws` draws each. The first round gives each chain
# ess / chains draws; each further round continues every chain from where it
# stopped (its state), its walk re-learned from its own draws so far
# (relearn_walk()), by the draws the slowest input's ESS says are missing, a
# fifth more, but at most the draws held (their ESS, partly drawn with an
# earlier walk, understates what the re-learned walk gives), and by the
# draws held while R-hat is above its target. Inputs held to a point are not
# judged. The runs carry attribute `stopping`.
chain_rounds <- function(run, spec, sm, chains) {
  n <- first_round_draws(sm, chains)
  runs <- run(lapply(seq_len(chains), function(ch) list(chain = ch, n_draws = n, resume = NULL)))
  judged <- judged_inputs(spec)
  rounds <- 1L
  repeat {
    chk <- chain_convergence(runs, judged, spec$inputs)
    met <- chk$ess >= sm$ess && (is.na(chk$rhat) || chk$rhat <= sm$rhat)
    if (met || n >= sm$max_draws) break
    # the draws the slowest input's ESS says are missing, a fifth more
    need <- n + 1.2 * n * max(0, sm$ess / max(chk$ess, 1) - 1)
    # at most doubling: the projection rests on the draws held, taken in part
    # with a walk learned from fewer draws than the next round's
    need <- if (!is.na(chk$rhat) && chk$rhat > sm$rhat) 2 * n else min(need, 2 * n)
    more <- as.integer(min(sm$max_draws - n, max(20, ceiling(need) - n)))
    if (!isTRUE(sm$quiet)) {
      wv_inform(c("i" = sprintf("Chains continued by %d draws each: the slowest input's ESS is %s of %s%s.", more,
                                round(chk$ess), sm$ess,
                                if (is.na(chk$rhat)) "" else sprintf(", the largest R-hat %.3f (target %s)",
                                                                     chk$rhat, sm$rhat))))
    }
    if (sm$proposal == "adaptive") runs <- lapply(runs, relearn_walk, priors = spec$priors)
    more_runs <- run(lapply(seq_len(chains),
                            function(ch) list(chain = ch, n_draws = more,
                                              resume = runs[[ch]]$state)))
    runs <- Map(join_chain_runs, runs, more_runs)
    n <- n + more
    rounds <- rounds + 1L
  }
  attr(runs, "stopping") <- list(ess_target = sm$ess, rhat_target = sm$rhat,
                                 max_draws = sm$max_draws, met = met,
                                 draws = n, rounds = rounds, ess = chk$ess, rhat = chk$rhat,
                                 slowest = chk$slowest)
  runs
}

# The walk a continued chain takes: the covariance of its own draws so far
# times 2.38^2 / p (Haario, Saksman and Tamminen 2001), and the independence
# proposal the moments of those draws, set by the sampler's own rule
# (relearn_walk_cpp()). The burn-in's covariance rests on a few thousand
# cycles, a noisy estimate where a chain moves slowly; the draws of a round
# are many more cycles. Each round is a time-homogeneous Metropolis-Hastings
# chain, its proposal learned from the draws before it (a finite number of
# adaptations). Unchanged with fewer than 20 p distinct draws (a chain that
# hardly moved) or a covariance that is not positive definite.
relearn_walk <- function(r, priors) {
  z <- r$inputs
  p <- ncol(z)
  # a chain that hardly moved keeps its walk
  if (!p || nrow(unique(z)) < 20L * p || is.null(r$state$walk_chol)) return(r)
  st <- relearn_walk_cpp(priors, r$state, z)
  if (!is.null(st)) r$state <- st
  r
}

# Draws per chain of the stopping rule's first round: ess / chains, at least
# 20, at most the ceiling (calibrate() sizes the burn-in to it).
first_round_draws <- function(sm, chains) {
  min(sm$max_draws, max(20L, as.integer(ceiling(sm$ess / chains))))
}

# The inputs whose draws the stopping rule judges: those with a range wider
# than a point (held inputs are not).
judged_inputs <- function(spec) {
  lo <- spec$priors$lower
  hi <- spec$priors$upper
  if (is.null(lo) || is.null(hi)) return(seq_along(spec$inputs))
  which(hi - lo > 1e-5 * pmax(abs(hi), abs(lo), 1))
}

# The slowest judged input's ESS (all chains) and the largest R-hat (NA with
# one chain or none judged).
chain_convergence <- function(runs, judged, inputs) {
  if (!length(judged)) return(list(ess = Inf, rhat = NA_real_, slowest = NA_character_))
  ml <- coda::mcmc.list(lapply(runs, function(r) coda::mcmc(r$inputs[, judged, drop = FALSE])))
  ess <- coda::effectiveSize(ml)
  rhat <- NA_real_
  if (length(runs) >= 2L) {
    rhat <- tryCatch(max(coda::gelman.diag(ml, autoburnin = FALSE, multivariate = FALSE)$psrf[, 1]),
                     error = function(e) NA_real_)
  }
  list(ess = min(ess), rhat = rhat, slowest = inputs[judged][which.min(ess)])
}

# One chain's draws of two rounds, the second continuing the first: the draws
# stacked, the acceptance rates weighted by the draws, the state and the
# walk's covariance the second's.
join_chain_runs <- function(a, b) {
  ha <- nrow(a$inputs)
  hb <- nrow(b$inputs)
  w <- function(x, y) if (is.na(x)) y else if (is.na(y)) x else (ha * x + hb * y) / (ha + hb)
  out <- a
  for (nm in c("inputs", "tau2", "reg_shift")) out[[nm]] <- rbind(a[[nm]], b[[nm]])
  for (nm in c("sigma2", "wb", "wM")) out[[nm]] <- Map(rbind, a[[nm]], b[[nm]])
  for (nm in c("acc_tau", "acc_input", "acc_global", "acc_noise")) out[[nm]] <- w(a[[nm]], b[[nm]])
  out$state <- b$state
  # the walk of the last round (each round re-learns it: relearn_walk())
  if (!is.null(b$proposal_cov)) out$proposal_cov <- b$proposal_cov
  out
}

# The function a chain's future evaluates, on a job list(chain, n_draws,
# resume): its environment holds only what the chain needs (the sampler's
# spec, settings and seed). On the suspension test bed (2 sites, 431
# coefficients each, 66 runs) that is 30 MiB per chain. A job with `resume`
# (a chain's state) continues that chain, without burn-in. With `team`, the
# function takes a list of jobs, one per chain, and runs them together in one
# process, a thread each (calibrate_team_cpp()): the same draws.
chain_worker <- function(spec, sm, seed, tau, debug_break, p_global, team = FALSE) {
  # forced, so that no promise carries the caller's frame to the worker
  force(sm)
  force(seed)
  force(debug_break)
  force(p_global)
  force(team)
  fix <- any(tau$fixed)
  tau_init <- if (fix) unname(tau$values) else numeric(0)
  # what the C++ sampler reads: by site the emulators' banks and the field's
  # coefficients, and the priors (not the basis nor the I/U map)
  spec <- list(sites = shared_banks(spec$sites), priors = spec$priors, groups = spec$groups["name"],
               z_init = spec$z_init,
               informs = spec$informs, temper = spec$temper, input_weight = spec$input_weight,
               reg_shift_var = spec$reg_shift_var)
  rm(tau)
  settings <- function(job, progress) {
    list(n_groups = nrow(spec$groups), z_init = as.numeric(spec$z_init),
         tau2_init = as.numeric(tau_init), fix_tau2 = fix,
         n_draws = as.integer(job$n_draws),
         n_inner = as.integer(sm$n_inner), step = as.numeric(sm$step),
         seed = as.numeric(seed),
         chain = as.integer(job$chain), debug_break = as.integer(debug_break),
         progress = progress,
         adaptive = identical(sm$proposal, "adaptive"), burnin = as.integer(sm$burnin),
         p_global = as.numeric(p_global), p_indep = as.numeric(sm$global_moves),
         n_search = as.integer(sm$n_search), threads = as.integer(sm$threads),
         informs = as.integer(spec$informs %||% integer(0)),
         temper = as.numeric(spec$temper %||% 1),
         input_weight = as.numeric(spec$input_weight %||% 1),
         reg_shift_var = if (is.null(spec$reg_shift_var)) NULL else
           as.numeric(spec$reg_shift_var),
         resume = job$resume)
  }
  progress_of <- function(label, n_draws) {
    if (isTRUE(sm$quiet)) return(NULL)
    id <- cli::cli_progress_bar(label, total = n_draws, .envir = parent.frame())
    function(h) cli::cli_progress_update(id = id, set = h)
  }
  if (team) {
    return(function(jobs) {
      chains <- vapply(jobs, function(j) j$chain, integer(1))
      label <- sprintf("Chains %s, together", paste(chains, collapse = " and "))
      progress <- progress_of(label, jobs[[1]]$n_draws)
      calibrate_team_cpp(spec$sites, spec$priors,
                         lapply(seq_along(jobs), function(k) {
                           settings(jobs[[k]], if (k == 1L) progress else NULL)
                         }))
    })
  }
  function(job) {
    progress <- progress_of(sprintf("Chain %d", job$chain), job$n_draws)
    calibrate_chain_cpp(spec$sites, spec$priors, settings(job, progress))
  }
}

# Sites that evaluate the same emulators (the sites of an experiment and of
# the base at the same gauge) carry one copy: a later site's bank is dropped
# for `bank_of`, the earlier site's position (from 0), which the sampler
# reads as that site's bank. What a chain's future carries shrinks by as
# much.
shared_banks <- function(sites) {
  for (s in seq_along(sites)[-1L]) {
    for (t in seq_len(s - 1L)) {
      if (is.null(sites[[t]][["bank_of"]]) &&
          identical(sites[[s]][["bank"]], sites[[t]][["bank"]])) {
        sites[[s]][["bank"]] <- NULL
        sites[[s]][["bank_of"]] <- t - 1L
        break
      }
    }
  }
  sites
}
