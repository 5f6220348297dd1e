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
fit_assumptions <- function(fit, part = c("priors", "joint_prior", "noise", "likelihood", "experiments")) {
  check_class(fit, "wv_fit")
  part <- check_choice(part)
  out <- switch(part,
                priors = prior_lines(fit$prior_iu, fit$conditions),
                joint_prior = if (!is.null(fit$prior_iu)) joint_prior_text(fit$prior_iu),
                noise = noise_lines(fit),
                likelihood = shared_error_lines(fit),
                experiments = experiment_lines(fit))
  as.character(out)
}

# The experiments of a fit, one line each, for print() and the report
# (nothing with one experiment).
experiment_lines <- function(fit) {
  ex <- fit$experiments
  if (is.null(ex) && !is.null(fit$conditions)) {
    return(sprintf("Condition%s (known, not sampled): %s", if (length(fit$conditions$inputs) == 1L) "" else "s",
                   condition_labels(fit$conditions)[["base"]]))
  }
  if (is.null(ex)) return(character(0))
  lines <- vapply(unique(ex$experiment), function(e) {
    sites <- ex$site[ex$experiment == e]
    reps <- vapply(sites, function(s) fit$n_rep[[s]], numeric(1))
    sh <- site_shift(fit, sites[1])
    cond_lab <- if (!is.null(fit$conditions)) condition_labels(fit$conditions)[[e]]
    sh[names(sh) %in% fit$conditions$inputs] <- 0
    how <- if (!is.null(cond_lab)) {
      paste0(if (e == "base") "the base experiment, " else "", cond_lab,
             if (any(sh != 0)) paste0("; inputs changed by ",
                                      paste(sprintf("%s %+g", names(sh)[sh != 0], sh[sh != 0]), collapse = ", ")))
    } else if (e == "base") "the base experiment" else if (any(sh != 0)) {
      paste0("inputs changed by ", paste(sprintf("%s %+g", names(sh)[sh != 0], sh[sh != 0]), collapse = ", "))
    } else "its own emulators"
    sprintf("  %s: %s; %s", e, how, paste(sprintf("%s %d replicate%s", sites, reps, ifelse(reps == 1, "", "s")),
                                          collapse = ", "))
  }, character(1))
  c(sprintf("Experiments, calibrated jointly (%s):",
            if (identical(fit$settings$experiment_bias, "shared")) "one bias shared by the experiments" else
              sprintf("one bias per experiment; level variances %s",
                      if (identical(fit$settings$level_variances, "per_experiment")) "per experiment" else "shared")),
    lines)
}

# How the chains' length was set: stopped on the targets (or at the
# ceiling), or fixed.
stopping_lines <- function(x) {
  st <- x$stopping
  if (is.null(st)) return(character(0))
  rh <- if (is.na(st$rhat)) "" else sprintf(" and R-hat at most %s (largest %.3f)", st$rhat_target, st$rhat)
  if (isTRUE(st$met)) {
    sprintf("Chains stopped at %d draws each (%d round%s), when every input had an ESS of %s%s (slowest %s, %s)",
            st$draws, st$rounds, if (st$rounds == 1L) "" else "s", st$ess_target, rh, st$slowest, round(st$ess))
  } else {
    sprintf("! Chains stopped at their ceiling of %d draws each without the targets: ESS %s wanted, the slowest input %s has %s%s",
            st$draws, st$ess_target, st$slowest, round(st$ess),
            if (is.na(st$rhat)) "" else sprintf("; R-hat %.3f (target %s)", st$rhat, st$rhat_target))
  }
}

# The chains' wall time and the slowest input's effective draws per second
# (all chains together), for the print of a fit.
sampling_speed_lines <- function(x) {
  sec <- x$sampling_seconds
  ess <- x$ess[x$inputs]
  ess <- ess[is.finite(ess)]
  if (is.null(sec) || !is.finite(sec) || sec <= 0 || !length(ess)) return(character(0))
  k <- which.min(ess)
  sprintf("Sampling took %s s: %s effective draws per second for the slowest input (%s, ESS %s)",
          format(signif(sec, 3)), format(signif(ess[[k]] / sec, 3)), names(ess)[k], round(ess[[k]]))
}
