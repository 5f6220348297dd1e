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
