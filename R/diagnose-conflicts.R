# Inputs in conflict with their prior, and the bias re-read with them held to
# their prior (the cut).

#' Hold calibrated inputs to their prior and read the bias again
#'
#' An input that can mimic a missing effect is pulled towards the values
#' that mimic it, often to a bound of its range or far into its prior's tail;
#' the bias then shrinks where the effect acts, and [where_fails()] finds
#' little. `hold_inputs()` takes those inputs out of the calibration: each is
#' held to its prior, so that the data inform the other inputs, the bias and
#' the noise but not the held inputs (the "cut" of modular Bayesian
#' analysis, Liu, Bayarri and Berger 2009). What the held inputs covered then
#' shows in the bias.
#'
#' The cut posterior is the prior of the held inputs times the posterior of
#' everything else given them. It is computed by stratification: the held
#' inputs are fixed at `strata` points of their prior (stratum `k` at the
#' prior's quantile `(k - 0.5) / strata` of each held input, the strata
#' permuted across several held inputs as in a Latin square), the fit is
#' calibrated again at each point (one chain, with the fit's settings and the
#' same field data, emulators and noise), and the draws of the strata are
#' pooled. Its bias bands therefore include how much the held inputs could
#' move the model within their prior. The strata's calibrations are futures
#' ([future::plan()] decides where they run; each worker is sent the fit's
#' emulators and field data, and its draws do not depend on the plan).
#'
#' @param fit A `wv_fit` from [calibrate()] or [validate()] (one experiment).
#' @param inputs Names of the inputs to hold; `NULL` (default) holds those
#'   in conflict with their prior (see [where_fails()]).
#' @param strata Number of points of the held inputs' prior (each one
#'   calibration).
#' @param quiet If `TRUE`, no progress bar.
#' @return A `wv_fit` whose draws pool the strata (one chain each; their
#'   R-hat, which would measure the spread between strata, is not computed),
#'   with `held`: the `inputs` held, their `values` by stratum, and the
#'   `original` fit's conflicts. Every method of a fit applies; its bias is
#'   the bias with the inputs held to their prior, and [explain_bias()] can
#'   be given it. Predictions of new runs from it keep the held inputs'
#'   prior.
#' @seealso [where_fails()], which calls it for inputs in conflict.
#' @export
#' @examples
#' \donttest{
#' fit <- example_fit()
#' held <- hold_inputs(fit, inputs = "u1", strata = 2, quiet = TRUE)
#' held$held$values
#' where_fails(held)
#' }
hold_inputs <- function(fit, inputs = NULL, strata = 3L,
                        quiet = getOption("wavevalid.quiet", FALSE)) {
  check_class(fit, "wv_fit")
  check_number(strata, min = 1, max = 50, integer = TRUE)
  check_flag(quiet)
  if (!is.null(fit_get(fit, "experiments"))) {
    wv_abort(c("Inputs can be held only in a fit of one experiment.",
               "i" = "Hold them in the fit of each experiment on its own."), class = "experiment")
  }
  P <- prior_sample(fit_get(fit, "prior_iu"))
  colnames(P) <- fit_get(fit, "inputs")
  cf <- input_conflicts(fit, prior = P)
  if (is.null(inputs)) inputs <- cf$input[cf$conflict]
  if (!is.character(inputs) || !length(inputs) || anyNA(inputs) || anyDuplicated(inputs)) {
    wv_abort(c("{.arg inputs} must name one or more inputs of the fit.",
               "i" = if (!any(cf$conflict)) "No input of the fit is in conflict with its prior."),
             class = "input")
  }
  bad <- setdiff(inputs, fit_get(fit, "inputs"))
  if (length(bad)) {
    wv_abort(c("{.val {bad}} {?is/are} not {?an input/inputs} of the fit.",
               "i" = "Its inputs are {.val {fit_get(fit, 'inputs')}}."), class = "input")
  }
  joint <- attr(fit_get(fit, "iu"), "joint")
  in_joint <- intersect(inputs, unlist(lapply(joint, `[[`, "names")))
  if (length(in_joint)) {
    wv_abort("{.val {in_joint}} {?has/have} a joint prior with other inputs and cannot be held alone.",
             class = "input")
  }
  strata <- as.integer(strata)
  values <- vapply(seq_along(inputs), function(j) {
    ord <- (seq_len(strata) + j - 2L) %% strata + 1L
    stats::quantile(P[, inputs[j]], (ord - 0.5) / strata, names = FALSE)
  }, numeric(strata))
  values <- matrix(values, strata, length(inputs), dimnames = list(NULL, inputs))
  ctl <- fit_controls(fit)
  sampler <- ctl$sampler
  sampler$quiet <- TRUE
  # each stratum as long as the fit's chains: equal shares of the prior
  if (is.null(sampler$n_draws)) sampler$n_draws <- fit_get(fit, "settings")$n_draws
  seed <- fit_get(fit, "seed") %||% 1L
  label <- sprintf("Holding %s to %s prior", paste(inputs, collapse = ", "),
                   if (length(inputs) == 1L) "its" else "their")
  tasks <- lapply(seq_len(strata),
                  function(k) list(iu = held_iu(fit, values[k, ]), seed = seed + k))
  job <- list(emulators = fit_get(fit, "emulators"), field = fit_get(fit, "field"), bias = ctl$bias,
              sampler = sampler)
  fits <- run_futures(tasks, stratum_worker(job), label, quiet)
  pool_fits(fit, fits, values, cf)
}

# The calibration of one stratum of hold_inputs(): a closure that carries
# only what a worker needs (the emulators, the field data, the settings).
stratum_worker <- function(job) {
  force(job)
  function(task) {
    suppressMessages(suppressWarnings(calibrate(
      job$emulators, job$field, task$iu, bias = job$bias, sampler = job$sampler, chains = 1L,
      seed = task$seed
    ), classes = c("wavevalid_warning_mixing", "wavevalid_warning_boundary")))
  }
}

# The fit's I/U map with the inputs `values` (named, in the fit's own units)
# held: each a calibration input on a point-like range at its value.
held_iu <- function(fit, values) {
  hold_at(fit_get(fit, "iu"), values)
}

# The strata's fits pooled into one fit, with the original's I/U map, prior
# and settings.
pool_fits <- function(fit, fits, values, conflicts) {
  out <- fits[[1L]]
  stack <- function(what) {
    sites <- names(fit_get(out, what))
    stats::setNames(lapply(sites,
                           function(s) do.call(rbind,
                                               lapply(fits, function(f) fit_get(f, what)[[s]]))),
                    sites)
  }
  draws <- coda::mcmc.list(lapply(fits, function(f) fit_get(f, "draws")[[1L]]))
  n_each <- vapply(fits, function(f) length(fit_get(f, "chain")), integer(1))
  acceptance <- lapply(seq_along(fits),
                       function(k) transform(fit_get(fits[[k]], "acceptance"), chain = k))
  inputs <- fit_get(out, "inputs")
  settings <- fit_get(out, "settings")
  settings$chains <- length(fits)
  out <- fit_set(out, draws = draws, wM = stack("wM"), wb = stack("wb"), sigma2 = stack("sigma2"),
                 chain = rep(seq_along(fits), n_each), acceptance = do.call(rbind, acceptance),
                 start = do.call(rbind, lapply(fits, fit_get, "start")),
                 proposal_cov = do.call(c, lapply(fits, fit_get, "proposal_cov")),
                 iu = fit_get(fit, "iu"), prior_iu = fit_get(fit, "prior_iu"),
                 prior_sd = fit_get(fit, "prior_sd") %||% prior_sds(fit_get(fit, "prior_iu")),
                 seed = fit_get(fit, "seed"), ess = coda::effectiveSize(draws),
                 rhat = stats::setNames(rep(NA_real_, length(inputs)), inputs),
                 x_nom = fit_get(fit, "x_nom"), settings = settings)
  flags <- boundary_flags(out, fit_get(out, "rhat"))
  flags$boundary <- flags$boundary[!flags$boundary$input %in% colnames(values), , drop = FALSE]
  fit_set(out, flags = flags,
          held = list(inputs = colnames(values), values = values, original = conflicts))
}

# The fit read again with the inputs `inputs` held to their prior: reality's
# coefficients (w^M + w^b) kept draw by draw, the model's drawn from the
# emulators, conditioned on the fit's model coefficients at the posterior
# inputs, at those inputs with `inputs` replaced by prior draws. A wv_fit
# whose bias is reality less that model.
reread_held <- function(fit, inputs) {
  inputs_all <- fit_get(fit, "emulators")$inputs
  post <- fit_draws_matrix(fit)[, inputs_all, drop = FALSE]
  H <- nrow(post)
  wb <- fit_get(fit, "wb")
  wM_all <- fit_get(fit, "wM")
  with_rng_seed(fit_get(fit, "seed") %||% 1L, {
    prior <- iu_prior_draws(fit_get(fit, "prior_iu"), H)
    colnames(prior) <- fit_get(fit, "inputs")
    Znew <- post
    Znew[, inputs] <- prior[, inputs]
    for (s in fit_sites(fit)) {
      pr <- bank_predict_augmented(site_bank(fit_get(fit, "emulators"), s), post,
                                   fit_get(fit, "wM")[[s]], Znew)
      wM <- pr$mean + sqrt(pmax(pr$var, 0)) * matrix(stats::rnorm(length(pr$mean)), nrow(pr$mean))
      dimnames(wM) <- dimnames(fit_get(fit, "wM")[[s]])
      wb[[s]] <- fit_get(fit, "wM")[[s]] + fit_get(fit, "wb")[[s]] - wM
      wM_all[[s]] <- wM
    }
  })
  X <- fit_draws_matrix(fit)
  X[, inputs] <- Znew[, inputs]
  draws <- coda::mcmc.list(lapply(unique(fit_get(fit, "chain")), function(k) {
    coda::mcmc(X[fit_get(fit, "chain") == k, , drop = FALSE],
               thin = coda::thin(fit_get(fit, "draws")[[k]]))
  }))
  flags <- fit_get(fit, "flags")
  flags$boundary <- flags$boundary[!flags$boundary$input %in% inputs, , drop = FALSE]
  fit_set(fit, wb = wb, wM = wM_all, draws = draws, held = list(inputs = inputs, how = "reread"),
          flags = flags)
}

# Where the inputs' pull moves the localised part of the model most, by
# site: the stretch around the largest move where the move is at least half
# of it.
pull_support <- function(fit, held, keep) {
  basis <- fit_get(fit, "basis")
  do.call(rbind, lapply(fit_sites(fit), function(s) {
    Psi <- basis$Psi[, keep, drop = FALSE]
    shift <- drop(Psi %*% (colMeans(fit_get(fit, "wM")[[s]][, keep, drop = FALSE]) -
                             colMeans(fit_get(held, "wM")[[s]][, keep, drop = FALSE])))
    k <- which.max(abs(shift))
    big <- abs(shift) >= abs(shift[k]) / 2
    r <- rle(big)
    ends <- cumsum(r$lengths)
    starts <- ends - r$lengths + 1L
    j <- which(starts <= k & ends >= k)
    dt <- diff(basis$t[1:2])
    data.frame(site = s, start = basis$t[starts[j]], end = basis$t[ends[j]] + dt, t = basis$t[k],
               shift = shift[k], stringsAsFactors = FALSE)
  }))
}
