#' What a fit assumed, as text
#'
#' The lines that `print()` of a fit gives for one part of what the
#' calibration assumed, for reports and logs:
#' * `"priors"`: the prior of every input, one line each, then the joint
#'   priors' correlations;
#' * `"joint_prior"`: the correlations of the joint Gaussian priors
#'   ([iu_prior_joint()]) alone;
#' * `"noise"`: how the field noise was set at each site, with its size;
#' * `"likelihood"`: how the inputs' likelihood counted the coefficients
#'   (`input_likelihood` of [calibrate()]);
#' * `"experiments"`: the experiments calibrated jointly ([experiment()]).
#'
#' Each part but `"joint_prior"` and `"likelihood"` starts with a heading
#' line ("Priors:", "Field noise:", "Experiments, ...") followed by indented
#' lines.
#'
#' @param fit A `wv_fit` object ([calibrate()], [validate()]).
#' @param part One of `"priors"`, `"joint_prior"`, `"noise"`,
#'   `"likelihood"`, `"experiments"`.
#' @return A character vector of lines; empty when the fit has nothing of
#'   that part (no joint prior, no experiments).
#' @export
#' @examples
#' fit <- example_fit()
#' fit_assumptions(fit, "noise")
#' writeLines(fit_assumptions(fit, "priors"))
fit_assumptions <- function(fit,
                            part = c("priors", "joint_prior", "noise", "likelihood",
                                     "experiments")) {
  check_class(fit, "wv_fit")
  part <- check_choice(part)
  out <- switch(part,
                priors = prior_lines(fit_get(fit, "prior_iu"), fit_get(fit, "conditions")),
                joint_prior = if (!is.null(fit_get(fit, "prior_iu")))
                  joint_prior_text(fit_get(fit, "prior_iu")),
                noise = noise_lines(fit),
                likelihood = shared_error_lines(fit),
                experiments = experiment_lines(fit))
  as.character(out)
}

# The experiments of a fit, one line each, for print() and the report
# (nothing with one experiment).
experiment_lines <- function(fit) {
  ex <- fit_get(fit, "experiments")
  conditions <- fit_get(fit, "conditions")
  if (is.null(ex) && !is.null(conditions)) {
    return(sprintf("Condition%s (known, not sampled): %s",
                   if (length(conditions$inputs) == 1L) "" else "s",
                   condition_labels(conditions)[["base"]]))
  }
  if (is.null(ex)) return(character(0))
  lines <- vapply(unique(ex$experiment), function(e) {
    sites <- ex$site[ex$experiment == e]
    reps <- vapply(sites, function(s) fit_get(fit, "n_rep")[[s]], numeric(1))
    sh <- site_shift(fit, sites[1])
    cond_lab <- if (!is.null(conditions)) condition_labels(conditions)[[e]]
    sh[names(sh) %in% conditions$inputs] <- 0
    how <- if (!is.null(cond_lab)) {
      paste0(if (e == "base") "the base experiment, " else "", cond_lab,
             if (any(sh != 0)) paste0("; inputs changed by ",
                                      paste(sprintf("%s %+g", names(sh)[sh != 0], sh[sh != 0]),
                                            collapse = ", ")))
    } else if (e == "base") "the base experiment" else if (any(sh != 0)) {
      paste0("inputs changed by ",
             paste(sprintf("%s %+g", names(sh)[sh != 0], sh[sh != 0]), collapse = ", "))
    } else "its own emulators"
    sprintf("  %s: %s; %s", e, how, paste(sprintf("%s %d replicate%s", sites, reps,
                                                  ifelse(reps == 1, "", "s")),
                                          collapse = ", "))
  }, character(1))
  settings <- fit_get(fit, "settings")
  c(sprintf("Experiments, calibrated jointly (%s):",
            if (identical(settings$experiment_bias, "shared"))
              "one bias shared by the experiments" else
              sprintf("one bias per experiment; level variances %s",
                      if (identical(settings$level_variances, "per_experiment")) "per experiment" else "shared")),
    lines)
}

# How the chains' length was set: stopped on the targets (or at the
# ceiling), or fixed.
stopping_lines <- function(x) {
  st <- fit_get(x, "stopping")
  if (is.null(st)) return(character(0))
  rh <- if (is.na(st$rhat)) "" else sprintf(" and R-hat at most %s (largest %.3f)", st$rhat_target,
                                            st$rhat)
  if (isTRUE(st$met)) {
    sprintf("Chains stopped at %d draws each (%d round%s), when every input had an ESS of %s%s (slowest %s, %s)",
            st$draws, st$rounds, if (st$rounds == 1L) "" else "s", st$ess_target, rh, st$slowest,
            round(st$ess))
  } else {
    sprintf("! Chains stopped at their ceiling of %d draws each without the targets: ESS %s wanted, the slowest input %s has %s%s",
            st$draws, st$ess_target, st$slowest, round(st$ess),
            if (is.na(st$rhat)) "" else sprintf("; R-hat %.3f (target %s)", st$rhat,
                                                st$rhat_target))
  }
}

# The chains' wall time and the slowest input's effective draws per second
# (all chains together), for the print of a fit.
sampling_speed_lines <- function(x) {
  sec <- fit_get(x, "sampling_seconds")
  ess <- fit_get(x, "ess")[fit_get(x, "inputs")]
  ess <- ess[is.finite(ess)]
  if (is.null(sec) || !is.finite(sec) || sec <= 0 || !length(ess)) return(character(0))
  k <- which.min(ess)
  sprintf("Sampling took %s s: %s effective draws per second for the slowest input (%s, ESS %s)",
          format(signif(sec, 3)), format(signif(ess[[k]] / sec, 3)), names(ess)[k], round(ess[[k]]))
}

# The prior of every input, one line each, and the correlations of joint priors.
prior_lines <- function(prior_iu, conditions = NULL) {
  if (is.null(prior_iu)) return(character(0))
  lab <- prior_labels(prior_iu)
  cond <- prior_iu$name %in% conditions$inputs
  if (any(cond)) {
    lab[cond] <- sprintf("none: a condition, known (%s in the base experiment; each experiment at its own)",
                         format(signif(conditions$base[prior_iu$name[cond]], 4), trim = TRUE))
  }
  c("Priors:", paste0("  ", formatC(prior_iu$name, width = -max(nchar(prior_iu$name))), "  ", lab),
    joint_prior_text(prior_iu))
}

# How the field noise was set at each site, one line each, with its size.
noise_lines <- function(fit) {
  sites <- fit_sites(fit)
  setting <- fit_get(fit, "noise_setting") %||%
    stats::setNames(ifelse(unlist(fit_get(fit, "n_rep")[sites]) >= 2, "replicates", "given"), sites)
  f <- function(v) format(signif(v, 3), trim = TRUE)
  noise_prior <- fit_get(fit, "noise_prior")
  lines <- vapply(sites, function(s) {
    ev <- fit_get(fit, "noise_evidence")[[s]]
    sigma2 <- fit_get(fit, "sigma2")[[s]]
    sd_draws <- sqrt(sigma2[, 1] / (ev$mult %||% 1)[1])
    switch(setting[[s]],
      replicates = if (is.null(fit_get(fit, "field")$units[[s]])) {
        sprintf("%s: from %d replicates, one variance per coefficient (the method's estimate); median sd %s",
                s, fit_get(fit, "n_rep")[[s]], f(stats::median(sqrt(sigma2))))
      } else {
        sprintf("%s: %d replicates of %d units: the posterior takes their spread (between units and within) as the noise, one variance per coefficient; median sd %s; misfit_check() (and where_fails()) judge the population net of each unit's own inputs",
                s, fit_get(fit, "n_rep")[[s]], length(unique(fit_get(fit, "field")$units[[s]])),
                f(stats::median(sqrt(sigma2))))
      },
      given = sprintf("%s: given by the user; median sd %s", s,
                      f(stats::median(sqrt(sigma2[1, ])))),
      finest = sprintf("%s: estimated from the finest wavelet level, sd %s (too small if the curve was smoothed or interpolated)",
                       s, f(sqrt(sigma2[1, 1]))),
      learned = sprintf("%s: learned, %s; %s prior on its sd, scale %s; posterior sd %s [%s, %s]%s",
                        s, if (is.null(ev)) "one variance for all coefficients" else "the variance of one measurement",
                        noise_prior$family, f(noise_prior$scale[[s]]), f(stats::median(sd_draws)),
                        f(stats::quantile(sd_draws, 0.05, names = FALSE)),
                        f(stats::quantile(sd_draws, 0.95, names = FALSE)), measured_noise_text(ev)))
  }, character(1))
  sp <- spread_text(spread_along_record(fit_get(fit, "field")), "registered replicates")
  if (!is.null(sp)) {
    sp <- paste0("  ", sp, ": one variance per wavelet coefficient mixes it along the record; ",
                 "misfit_check() (and where_fails()) read each point with its own")
  }
  c("Field noise:", paste0("  ", lines), sp, registration_lines(fit))
}

# How the inputs' likelihood counted the coefficients, for print() and the
# report.
shared_error_lines <- function(x) {
  se <- fit_get(x, "shared_errors")
  if (is.null(se)) {
    return(c("Inputs' likelihood: the coefficients taken as independent (the method's). Errors they share (the emulators' at one input, a replicate's registration) then count many times: the inputs' intervals are too narrow (input_likelihood = \"adjusted\" weighs them)."))
  }
  sprintf("Inputs' likelihood: the coefficients' shared errors counted once, the likelihood raised to %s in the inputs' steps (%d inputs / %s, the magnitude adjustment of a composite likelihood; errors across %d coefficients from the emulators' leave-one-out errors and the replicates' scatter)",
          format(signif(se$weight, 3)), se$p, format(signif(se$trace, 3)), se$n_coef)
}

# The variance the registration adds to the field mean, and where it comes
# from (bias_control(registration_variance =)).
registration_lines <- function(fit) {
  reg_var <- fit_get(fit, "registration_var")
  settings <- fit_get(fit, "settings")
  if (is.null(reg_var)) {
    if (is.null(fit_get(fit, "field")$warps)) return(character())
    return(paste("Registration: nothing added to the variance of the field mean for the registration's own error",
                 if (isFALSE(settings$registration_variance)) "(registration_variance = FALSE)" else
                   "(the field carries no check of it: register it to model runs with register_curves(check_runs = 5))"))
  }
  share <- vapply(names(reg_var), function(s) {
    e <- colMeans(fit_get(fit, "sigma2")[[s]]) / fit_get(fit, "n_rep")[[s]]
    r <- reg_var[[s]]
    sum(r) / sum(r + e)
  }, numeric(1))
  src <- if (!isTRUE(settings$registration_variance)) {
    n <- nrow(fit_get(fit, "field")$registration_check[[1L]] %||% matrix(0, 0, 0))
    sprintf("the registration's own error (what it changed in the %d model run%s nearest the field)", n,
            if (n == 1L) "" else "s")
  } else {
    "the spread of the reference's landmarks over the model runs"
  }
  shares <- paste(sprintf("%s %.0f%%", names(share), 100 * share), collapse = ", ")
  rs <- fit_get(fit, "registration_shifts")
  if (is.null(rs)) return(
    sprintf("Registration: %s added to the variance of the field mean, %s of it", src, shares))
  K <- length(rs$variance)
  sprintf(paste("Registration: %s taken as %d shift%s of the landmarks along the curves' time-shift directions",
                "(prior sd %s, sampled with the inputs), the rest added to the variance of the field mean, %s of it"),
          src, K, if (K == 1L) "" else "s",
          paste(format(signif(sqrt(rs$variance), 2), trim = TRUE), collapse = ", "),
          shares)
}

# What the learned noise took from the measurements on their own time stamps
# (field_runs()), as the end of its print line.
measured_noise_text <- function(ev) {
  if (is.null(ev)) return("")
  f <- function(v) format(signif(v, 3), trim = TRUE)
  ddf <- ev$detail_df %||% 0
  paste0("\n    from the measured curve on its ", ev$n_stamps,
         " time stamps: the prior's scale from its detail (sd ",
         f(ev$detail_sd), ")",
         if (ddf > 0) sprintf("; its points' differences in the likelihood as data on the noise (%s df, their sd %s)",
                              f(ddf), f(sqrt(ev$detail_ss / ddf))) else "",
         if (ev$df > 0) sprintf("; %d repeated measurements in the likelihood (%g df, their sd %s)",
                                ev$n_repeated,
                                ev$df, f(sqrt(ev$ss / ev$df))) else "",
         "; each coefficient's variance from the resampling onto the grid (", f(min(ev$mult)),
         " to ",
         f(max(ev$mult)), " times one measurement's)")
}
