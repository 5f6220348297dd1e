#' Calibrate the model against field data: the modular posterior
#'
#' Draws from the posterior of the method (eq. 15-19 of Bayarri et al.):
#' calibration parameters `u`, manufacturing variations `delta` (reported as
#' `x_nom + delta`, in each input's own units), bias variances `tau2` by
#' (site, resolution level), field variances `sigma2`, bias coefficients `w^b`
#' and model coefficients `w^M`.
#'
#' Per site the field replicates are projected on the basis
#' (`W = curves \%*\% Psi`); their mean `wbar`, sum of squares `s2` and the number
#' of replicates `R` are the data. For each saved draw the sampler
#' 1. draws `sigma2_i ~ InvGamma((R - 1) / 2, rate = s2_i / 2)` (the replicates
#'    alone fix sigma: the modularization of the method), or uses `sigma2`;
#' 2. runs `n_inner` cycles of Metropolis-Hastings on `(delta, u, tau2)`
#'    targeting `prod_i N(wbar_i; m_i(z), V_i(z) + sigma2_i / R + tau2_j(i))`
#'    times the priors, with `pi(tau2_j) ~ 1 / (tau2_j + mean(sigma2_j) / R)`;
#' 3. draws `w^b` (eq. 17) and `w^M` (eq. 16, with the variance
#'    `V (sigma2 / R) / (V + sigma2 / R)`).
#'
#' The proposals, the burn-in and when the chains stop are set by
#' [sampler_control()] (its sections Proposals and Stopping). `iu` holds the
#' emulators' inputs and no others (else an error of class
#' `wavevalid_error_inputs`). Variation inputs have prior `N(x_nom, prior_sd^2)`
#' truncated to the I/U range shifted by `x_nom - nominal` (`x_nom` from
#' `field$x_nom`, else the nominals of `iu`); calibration inputs have the prior
#' of the I/U map (uniform on their range unless [iu_map()] or
#' [iu_prior_joint()] say otherwise), a prior on `log(x)` entering with its
#' Jacobian `1 / x`. Several sites share the inputs; each has its own
#' emulators, data, `sigma2` and `tau2` groups. Each chain is a future (see
#' "Where the work runs" in [wavevalid-package]). The figures behind the
#' sections below are in `studies/README.md` in the package's source
#' repository, under the study named.
#'
#' @section Bias variances:
#' The coarsest levels hold one coefficient or few, so under the method's
#' prior by level (`bias_control(pool_levels = NULL)`) their bias takes
#' whatever offset of the whole record the calibrated inputs create. By
#' default (`pool_levels = "coarse"`) the record-wide levels and the finer
#' ones after them share one variance per site until the group holds more
#' than four coefficients (levels 0 to 3 for the default basis). On both test
#' beds this removed the credible record-wide offsets with nothing hidden and
#' kept mechanisms acting on the whole record reported as record-wide
#' (`false_findings.R`).
#'
#' @section Levels cut off the inputs:
#' `bias_control(inform_levels = )` names the levels that inform the inputs (a
#' modular analysis, Bayarri, Berger and Liu 2009); the other levels' `tau2`
#' and bias are drawn given the inputs, so fine levels with errors the model
#' cannot have no longer pull them. On the suspension test bed this covered
#' the true inputs more often, but the levels cut off carried more bias, which
#' [explain_bias()] read as a mechanism more often (`coverage.R`): a
#' sensitivity check, not a default.
#'
#' @section Tempered posterior:
#' `bias_control(temper = )` below 1 raises the likelihood to that power in the
#' whole target (a power posterior: Ribatet, Cooley and Davison 2012; Bissiri,
#' Holmes and Walker 2016). It widens the inputs' posteriors, but the bias band
#' then flags less, wrongly and rightly (a hidden mechanism far less often on
#' the suspension test bed: section Retired): a sensitivity option.
#'
#' @section Errors the coefficients share:
#' An emulator's error at one input point, or the registration's error of one
#' replicate, is shared by many coefficients, and a likelihood that counts
#' them as independent gives too narrow inputs' intervals. By default
#' (`bias_control(input_likelihood = "adjusted")`) the likelihood enters the
#' inputs' steps raised to `w = p / tr(H^-1 J)`, the magnitude adjustment of
#' a composite likelihood (Ribatet, Cooley and Davison 2012): `H = G' D^-1 G`
#' its curvature in the inputs (`G` the emulators' gradient, `D` the variances
#' the product takes), `J = G' D^-1 Sigma D^-1 G` the variance of its score
#' under the errors' covariance `Sigma`, estimated from the emulators'
#' leave-one-out errors, the replicates' scatter and the bias variances, at
#' the mean of a short pilot chain. Independent errors give `w = 1`; the bias
#' variances and the noise keep the full likelihood. The print states `w`
#' (`fit$shared_errors`): a small one widens the inputs' intervals several
#' times, the bias barely moves (`shared_errors.R`). `"independent"` is the
#' method's posterior.
#'
#' @section Field noise:
#' With two replicates or more, each coefficient's field variance is drawn
#' from the replicates alone, as in the method. With one measured curve, the
#' noise is one variance per site (white noise has the same variance at every
#' coefficient of an orthonormal basis), learned under the prior of
#' [noise_prior()] (by default a half-Cauchy on its sd, scaled by the
#' finest-level estimate). When [field_runs()] built the field from
#' measurements off the grid, the learned variance is that of one
#' measurement, carried through the averaging and interpolation, and the
#' repeated measurements' scatter enters the likelihood (`noise_evidence`).
#' `noise_setting` records, by site, `"replicates"`, `"given"`, `"finest"` or
#' `"learned"`; print, summary and the report state it.
#'
#' @section Several experiments:
#' Experiments of one unit (a test course, the same course with an added
#' mass) share the calibration inputs and manufacturing variations; the
#' likelihood is the product of theirs. Site `s` of experiment `e` becomes
#' site `"e/s"` of the fit, with its own noise and bias, its emulators
#' evaluated at the inputs plus the experiment's change; bands,
#' [where_fails()] and [predict()] report every site. With
#' `bias_control(experiment_bias = "shared")` the experiments' field means at
#' a site share one bias. One experiment gives the same draws as none.
#'
#' @section Registration:
#' Every field replicate is warped onto one reference, so the registered
#' field mean carries an error the replicates' scatter does not show, which
#' the likelihood would read as signal. By default
#' (`bias_control(registration_variance = "auto")`) that error is measured on
#' the model when the field carries the measure, as [validate()] registers
#' it: the five runs nearest the field are registered like a replicate
#' (`check_runs` of [register_curves()]). What that changes is regressed on
#' the events' time shifts (landmark `k` off by `delta_k` moves the mean by
#' about `delta_k h_k(t) ybar'(t)`, `h_k` the warp's hat function, `ybar'` the
#' mean's slope); the shifts get normal priors and are drawn with the inputs,
#' so a misfit along a time shift is no finding while a change of height at
#' an event still is. The inputs' steps take the shifts integrated out (they
#' are normal and linear), and the shifts are drawn given the inputs, so an
#' input that moves an event in time mixes as freely as without them. What they leave is added, one mean square per site, to
#' every coefficient's variance; the print says how many shifts and their sd.
#' `"check"` requires the measure, `FALSE` is the method's field mean, `TRUE`
#' a first-order variance from each landmark's spread over the runs. On both
#' test beds with nothing hidden the measure removed almost every false
#' finding and kept hidden mechanisms found, for wider bands; an effect no
#' larger than what the registration changes at the events may go unflagged
#' (`registration_check.R`, `false_findings.R`).
#'
#' @param emulators A `wv_emulators` object ([fit_emulators()]).
#' @param field A `wv_field` object ([field_runs()]): the field replicates, on
#'   the grid of the model runs and of the wavelet basis.
#' @param iu A `wv_iu` object ([iu_map()]): the uncertain inputs with their
#'   types, ranges, nominal values and priors.
#' @param seed `NULL` (a seed drawn from R's random number generator, so
#'   that [set.seed()] applies) or a whole number: the random draws depend on
#'   it alone, not on the state of R's generator.
#' @param experiments `NULL` (one experiment: `field`) or a named list of
#'   further experiments of the same unit, each made with [experiment()]; see
#'   the section Several experiments. The whole data set of several
#'   conditions, [experiments_at()] with `base`, may be given as `field`
#'   instead: its base field is `field`, its experiments come first.
#' @param bias A [bias_control()] object: the field noise, the bias variances'
#'   grouping, the levels that inform the inputs and the inputs' likelihood.
#' @param sampler A [sampler_control()] object: chains, draws, thinning,
#'   proposal, burn-in, the start's search, threads and progress bar.
#' @param ... Settings of [bias_control()] and [sampler_control()] given
#'   directly (`chains = 1`, `n_draws = 200`), each replacing that setting of
#'   `bias` or `sampler`; any other name is an error (`wavevalid_error_input`).
#' @return A `wv_fit` object: a list with `draws` (a [coda::mcmc.list] of the
#'   inputs in their own units and `tau2[site:level]`), `wM`, `wb`, `sigma2`
#'   (lists by site of H x n matrices, H = `n_draws * chains`, chains
#'   stacked), `chain`, `emulators`, `basis`, `field`, `iu`, `prior_iu` (the
#'   I/U map shifted to `x_nom`), `x_nom`, `wbar`, `s2`, `n_rep`, `groups`,
#'   `bias_group`, `acceptance` (by chain), `start`, `proposal_cov`, `rhat`,
#'   `ess`, `flags`, `seed`, `control` (the control objects, by kind),
#'   `settings` (what the sampler ran with), `registration_var`,
#'   `registration_shifts` (the shifts' `variance`, `draws` and `U`),
#'   `noise_setting`, `noise_prior` and `sampling_seconds`.
#' @seealso [bias()], [reality()], [model_prediction()], [validate()].
#' @export
#' @examples
#' ex <- example_problem()
#' fit <- calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 1,
#'                  sampler = sampler_control(n_draws = 100, n_inner = 20, quiet = TRUE))
#' fit
calibrate <- function(emulators, field, iu, experiments = NULL, bias = bias_control(),
                      sampler = sampler_control(), seed = NULL, ...) {
  ctl <- resolve_controls(list(bias = bias, sampler = sampler), list(...), "calibrate")
  bias <- ctl$bias
  sampler <- ctl$sampler
  chains <- sampler$chains
  check_class(emulators, "wv_emulators")
  given <- split_field_set(field, experiments)
  field <- given$field
  experiments <- given$experiments
  check_class(field, "wv_field")
  check_class(iu, "wv_iu")
  seed <- resolve_seed(seed)
  check_sigma2(bias$sigma2, names(field$curves))
  sm <- sampler
  if (is.null(sm$burnin)) {
    n <- sm$n_draws %||% first_round_draws(sm, chains)
    sm$burnin <- if (sm$proposal == "adaptive") max(5000, floor(n * sm$n_inner / 4)) else 0
  }
  # the free cores, measured (a quarter of a second) only where a choice needs them
  free <- local({
    n <- NULL
    function() {
      if (is.null(n)) n <<- free_cores()
      n
    }
  })
  if (sm$threads > 1L && sm$threads > free()) {
    if (!sm$quiet) wv_inform("Using {free()} thread{?s}, the free cores, instead of {sm$threads}.")
    sm$threads <- free()
  }
  sm$together <- chains_together(sm$together, chains, free)
  fit <- calibrate_fit(emulators, field, iu, experiments, bias, sm, chains, seed)
  fit <- fit_set(fit, control = list(bias = bias, sampler = sampler))
  if (!sm$together) hint_parallel_chains(fit_get(fit, "sampling_seconds"), chains, free, sm$quiet)
  warn_fit_flags(fit)
  warn_experiment_extrapolation(fit)
  validate_wv_fit(fit)
}

# Whether the chains run together in one process, a thread each
# (sampler_control(together = )): as asked, or with two chains or more when
# each has a core of its own, the plan's workers under a local plan with
# workers (multisession, multicore, callr) or the free cores under the
# sequential plan (not with options(wavevalid.workers = 1)); never under a
# plan that may send work to other machines. `free`: the free cores, or a
# function giving them.
chains_together <- function(together, chains, free) {
  if (chains < 2L) return(FALSE)
  if (!is.null(together)) return(isTRUE(together))
  if (!requireNamespace("future", quietly = TRUE)) return(FALSE)
  pl <- future::plan()
  if (inherits(pl, "sequential")) {
    want <- getOption("wavevalid.workers", "auto")
    if (is.numeric(want) && isTRUE(all(want <= 1))) return(FALSE)
    return((if (is.function(free)) free() else free) >= chains)
  }
  if (inherits(pl, c("multisession", "multicore", "callr"))) return(future::nbrOfWorkers() >= chains)
  FALSE
}

# When the chains ran one after the other (future's sequential plan) for a
# minute or more while other cores were free: how to run them at once. Not
# when the user chose one process (options(wavevalid.workers = 1)).
hint_parallel_chains <- function(seconds, chains, free, quiet) {
  if (isTRUE(quiet) || chains < 2L || !isTRUE(seconds >= 60)) return(invisible(FALSE))
  if (is.function(free)) free <- free()
  if (free < 2L) return(invisible(FALSE))
  want <- getOption("wavevalid.workers", "auto")
  if (is.numeric(want) && isTRUE(all(want <= 1))) return(invisible(FALSE))
  if (!requireNamespace("future", quietly = TRUE) || !inherits(future::plan(), "sequential"))
    return(invisible(FALSE))
  workers <- min(chains, free)
  wv_inform(c("i" = paste0("The {chains} chains ran one after the other ({round(seconds)} s) while {free} cores were free: ",
                           "{.code future::plan(future::multisession, workers = {workers})} runs them at once, with the same draws.")),
            class = "parallel")
  invisible(TRUE)
}

# calibrate() past its checks: `sm` the sampler's settings with the burn-in
# and threads resolved.
calibrate_fit <- function(emulators, field, iu, experiments, bias, sm, chains, seed) {
  sigma2 <- bias$sigma2
  pool_levels <- bias$pool_levels
  registration_variance <- bias$registration_variance
  inform_levels <- bias$inform_levels
  # the conditions are known: held at the base experiment's values
  iu_run <- conditions_held_iu(iu)
  spec <- calibration_spec(emulators, field, iu_run, sigma2, pool_levels = pool_levels,
                           registration_variance = registration_variance)
  cond <- iu_conditions(iu)
  spec$x_nom[cond] <- condition_base(iu)
  experiments <- check_experiments(experiments, emulators, field, spec$x_nom, iu = iu)
  if (!is.null(experiments)) check_not_base_data(experiments, field)
  if (!is.null(experiments)) {
    spec <- add_experiments(spec, experiments, emulators, iu_run, pool_levels,
                            registration_variance, bias$level_variances,
                            bias$experiment_bias)
    parts <- experiment_fit_parts(spec, emulators, field, experiments)
    emulators <- parts$emulators
    field <- parts$field
  }
  tau <- resolve_fix_tau2(bias$fix_tau2, spec$groups)
  spec$informs <- informing_groups(inform_levels, spec$basis$level, spec$bias_group, spec$groups)
  spec$inform_levels <-
    if (is.null(inform_levels)) NULL else sort(unique(as.integer(inform_levels)))
  spec$temper <- bias$temper
  shared <- NULL
  if (bias$input_likelihood == "adjusted") {
    shared <- shared_error_weight(spec, field, tau, seed, sm)
    spec$input_weight <- shared$weight
  }
  # the workers start once the inputs and the data have passed their checks,
  # and stop as calibrate() returns (after its hint on the plan)
  # chains run together take one process (the main one unless a plan is set)
  together <- isTRUE(sm$together)
  use_cores(if (together) 1L else chains, sm$quiet, envir = parent.frame())
  if (together && !sm$quiet && requireNamespace("future", quietly = TRUE) && inherits(future::plan(), "sequential")) {
    wv_inform(c("i" = paste0("The {chains} chains run together in this R process, a thread each ",
                             "(the same draws as apart; {.code sampler_control(together = FALSE)} runs them apart).")),
              class = "cores")
  }
  t_sampling <- proc.time()[["elapsed"]]
  runs <- run_chains(spec, sm, chains, seed, tau)
  t_sampling <- proc.time()[["elapsed"]] - t_sampling
  fit <- assemble_fit(spec, runs, emulators, field, iu,
                      settings = list(n_draws = sm$n_draws %||% nrow(runs[[1L]]$inputs),
                                      n_inner = sm$n_inner, chains = chains,
                                      step = sm$step, proposal = sm$proposal,
                                      global_moves = sm$global_moves,
                                      burnin = sm$burnin,
                                      fix_tau2 = tau$values[tau$fixed],
                                      pool_levels = spec$pool_levels,
                                      registration_variance = registration_variance,
                                      inform_levels = spec$inform_levels, temper = bias$temper,
                                      n_search = sm$n_search,
                                      input_likelihood = bias$input_likelihood),
                      seed = seed)
  fit <- fit_set(fit, shared_errors = shared, sampling_seconds = t_sampling,
                 stopping = attr(runs, "stopping"),
                 conditions = fit_condition_table(iu, experiments))
  if (!is.null(experiments)) {
    settings <- fit_get(fit, "settings")
    settings$level_variances <- bias$level_variances
    settings$experiment_bias <- bias$experiment_bias
    fit <- fit_set(fit, settings = settings, experiments = spec$experiments, shift = spec$shift)
  }
  fit
}

assemble_fit <- function(spec, runs, emulators, field, iu, settings, seed) {
  sites <- names(spec$sites)
  tau_names <- paste0("tau2[", spec$groups$name, "]")
  chain_mcmc <- lapply(runs, function(r) {
    m <- cbind(r$inputs, r$tau2)
    colnames(m) <- c(spec$inputs, tau_names)
    coda::mcmc(m, thin = settings$n_inner)
  })
  draws <- coda::mcmc.list(chain_mcmc)
  stack <- function(what) {
    stats::setNames(lapply(seq_along(sites), function(s) {
      m <- do.call(rbind, lapply(runs, function(r) r[[what]][[s]]))
      colnames(m) <- paste0("w", spec$basis$index)
      m
    }), sites)
  }
  acceptance <- data.frame(chain = seq_along(runs),
                           tau2 = vapply(runs, function(r) r$acc_tau, numeric(1)),
                           inputs = vapply(runs, function(r) r$acc_input, numeric(1)),
                           global = vapply(runs, function(r) r$acc_global, numeric(1)),
                           burnin = vapply(runs, function(r) r$acc_burnin, numeric(1)))
  if (any(spec$noise_setting == "learned")) acceptance$noise <- vapply(runs,
                                                                       function(r) r$acc_noise,
                                                                       numeric(1))
  start <- do.call(rbind, lapply(runs, function(r) r$z_start))
  colnames(start) <- spec$inputs
  prop_cov <- lapply(runs, function(r) {
    m <- r$proposal_cov
    if (length(m)) dimnames(m) <- list(spec$inputs, spec$inputs)
    m
  })
  fit <- new_wv_fit(list(
    draws = draws, wM = stack("wM"), wb = stack("wb"), sigma2 = stack("sigma2"),
    chain = rep(seq_along(runs), each = settings$n_draws),
    emulators = emulators, basis = spec$basis, field = field, iu = iu, prior_iu = spec$prior_iu,
    inputs = spec$inputs, x_nom = spec$x_nom, wbar = spec$wbar, s2 = spec$s2, n_rep = spec$n_rep,
    groups = spec$groups, bias_group = spec$bias_group, acceptance = acceptance, start = start,
    proposal_cov = prop_cov,
    seed = seed, settings = settings, registration_var = spec$extra, missing_var = spec$fill,
    noise_setting = spec$noise_setting, noise_prior = spec$noise_prior,
    noise_evidence = if (length(spec$noise_evidence)) spec$noise_evidence,
    prior_sd = prior_sds(spec$prior_iu),
    registration_shifts = if (length(spec$reg_shift_var)) {
      list(variance = spec$reg_shift_var, draws = do.call(rbind, lapply(runs, `[[`, "reg_shift")),
           U = Filter(Negate(is.null), lapply(spec$sites, `[[`, "reg_U")))
    }
  ))
  diag <- fit_diagnostics(fit)
  fit_set(fit, rhat = diag$rhat, ess = diag$ess, flags = diag$flags)
}
