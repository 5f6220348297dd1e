#' Which missing effect explains the bias?
#'
#' Regresses the bias (the field data's residuals from the emulated model at
#' the posterior draws of the inputs), draw by draw, on the wavelet coefficients of
#' candidate effect curves and compares subsets of candidates by their
#' marginal likelihood. A candidate is the signature of a mechanism the user
#' suspects the model lacks: typically the difference between a run with the
#' mechanism and a run without it, near the calibrated inputs, or a physical
#' feature curve of the calibrated model (a contact force, a velocity). The
#' directions in which the emulated model output moves when one input moves
#' (emulator gradients at the posterior mean inputs) join as automatic
#' candidates named `shift:<input>`, so that a bias a parameter change would
#' absorb is told apart from a missing mechanism.
#'
#' For draw h, with inputs `z_h`, field variances `sigma^2_h` and bias level
#' variances `tau^2_h`, the residuals of the field data from the emulated
#' model, `wbar - m(z_h)` (all sites stacked; `r` below), are regressed on the
#' candidates' coefficients `C`: under the model, `r` is `w^b + e`, `e` the
#' field and emulator error of variance `S = sigma^2_h / R + V(z_h)`; a
#' candidate explains the mean of the bias, `w^b ~ N(C_S a_S, tau^2)`, so
#' the residuals are `C_S a_S + e'`, `e' ~ N(0, phi diag(S + tau^2))` (weighted least
#' squares with weights `1 / (S + tau^2)`). Regressing the residuals rather
#' than the posterior draws of `w^b` keeps the signal that the bias prior
#' shrinks towards zero at the levels where `tau^2` is small against `S`.
#' Zellner's g-prior
#' `a_S ~ N(0, g phi (C_S' W C_S)^-1)`, `g = n` and `pi(phi) ∝ 1/phi`. The Bayes
#' factor of a subset S against no candidate is then
#' `(1 + g)^(-|S|/2) (1 - g / (1 + g) R^2_S)^(-n/2)`, with `R^2_S` the
#' weighted share of the bias explained. Subsets of up to `max_size`
#' candidates are enumerated with equal prior probability for each size and
#' within a size; posterior subset probabilities are averaged over draws, and
#' the inclusion probability of a candidate is the total probability of the
#' subsets that contain it. Subsets whose candidates are linearly dependent
#' are skipped, so identical candidates share their inclusion.
#'
#' The regression counts every coefficient as an independent piece of
#' evidence. A real bias is not that tidy: a mistimed or misshapen event moves
#' many neighbouring coefficients together, and the residual left after the
#' best candidates is concentrated where the candidates themselves act. Taken
#' at face value, such a residual makes every candidate that resembles it
#' look decisive. The likelihood is therefore tempered, raised to a power
#' `eta` in (0, 1] for each draw: the record is cut into `segments` time
#' segments, the coefficients whose support is centred in one segment of one
#' site form a cluster, and `eta = m / tr(J^-1 I)`, with `J` the information
#' the regression on all `m` (linearly independent) candidates claims for
#' their amplitudes and `I` the cluster-robust (sandwich) estimate of it from
#' the residuals. When the residuals behave as the model says, `I` is close
#' to `J` and `eta` is 1 (it is capped there); when they are more dispersed or
#' more alike within a segment, the evidence is discounted accordingly. The
#' tempered Bayes factor is the one above with `n` and `g` replaced by
#' `eta n` (an effective number of coefficients), and the amplitude intervals
#' widen by `1 / sqrt(eta)`. Duplicating every coefficient, for example,
#' leaves the result unchanged instead of doubling the evidence.
#' `segments = NULL` turns the tempering off.
#'
#' A mechanism either acts or it does not: its signature (the run with it
#' minus the run without it) enters the bias with a non-negative strength, and
#' a bias that looks like the opposite of the signature is no evidence for it.
#' With `positive = TRUE` (default) the prior above, over subsets and
#' amplitudes jointly, is conditioned on the amplitudes of the user's
#' candidates being non-negative. The marginal likelihood of a subset is then
#' the one above times `P(a_S >= 0 | data)`, the posterior probability of
#' that orthant (a multivariate t, integrated by the GHK simulator on a fixed
#' lattice of quasi-random points, so that the result does not depend on the
#' seed and keeps its order of magnitude when the probability is tiny), and
#' the amplitude draws are truncated to it. A subset's evidence never exceeds
#' its unconstrained evidence, and a candidate whose amplitude would be
#' credibly negative gets almost none. (Truncating each subset's g-prior and
#' renormalising it instead would double the density of the amplitudes that
#' remain and so up to double the evidence of a candidate of the right sign.)
#' On the package's suspension test bed the constraint removed a false claim
#' of a decoy whose amplitude was negative and made none of its own
#' (`studies/README.md` in the package's source repository). The shifts
#' `shift:<input>` stay free in sign: an input may move either way. Set
#' `positive = FALSE` for candidates whose sign is arbitrary, such as a
#' physical feature curve, or give one logical per candidate.
#'
#' When the posterior of an input piles up at a bound of its range, the
#' calibration is likely using that input to make up for the missing effect,
#' and the calibrated inputs can be far from the true ones. A mechanism's
#' effect often depends on the inputs, so a candidate simulated at the
#' posterior mean inputs can then differ from the effect the data carry.
#' `print` says so; compare with candidates simulated at other inputs (the
#' nominal ones, say) before concluding. Neither choice wins everywhere: on
#' the package's suspension test bed the signature of a hidden digressive
#' damper held less of its true effect at the calibrated inputs than at the
#' nominal ones, yet each choice found some hidden mechanisms more often than
#' the other.
#'
#' Rather than choose, give both: `effect` names, for each candidate, the
#' effect it is a version of, so that a mechanism's signature simulated at the
#' posterior mean inputs and at the nominal inputs are two versions of one
#' effect. The versions of an effect share its prior mass equally and never
#' enter one subset together, so the effect is weighed once, as a mixture of
#' its versions: its inclusion probability is the sum of theirs, its amplitude
#' draws those of the version each draw includes. The result has one row per
#' effect; the attribute `versions` gives each version's inclusion
#' probability. A version identical to another adds nothing: the effect keeps
#' the inclusion probability it had with one. On the package's suspension
#' test bed, two versions of each mechanism (at the posterior mean and at the
#' nominal inputs) ranked the hidden one first more often than either version
#' alone, without a claim when nothing was hidden (`studies/README.md` in the
#' package's source repository). Keep the versions few and chosen for a
#' reason: a mixture of many versions can fit what none of them explains
#' alone, and then names a mechanism that is not there.
#'
#' Some effects the model's own inputs can mimic, and the calibration then
#' takes up most of them before the bias is ever looked at. The attribute
#' `absorbed` says, for each candidate, how much of its signature the
#' parameter shifts span; `print` warns at 75\% and above. On the package's
#' suspension test bed the shifts spanned from a small part of one
#' mechanism's signature to most of another's, and the best setting of the
#' model's own inputs took up most of a hidden damper's effect, leaving the
#' bias little of it to carry (`studies/README.md` in the package's source
#' repository, "absorption.R"). A low inclusion probability for a candidate
#' that is mostly a parameter shift is weak evidence against it: re-validate
#' the model with it instead (section "Re-validated models as candidates").
#'
#' @section One finding:
#' With `finding`, the regression is restricted to what that finding of
#' [where_fails()] carries. An `"interval"`: the coefficients of its site
#' whose basis function's support overlaps the interval (of the localised
#' levels when the table read the bias by scale, as it does by default), so
#' that the field data elsewhere, at other sites and in the record-wide
#' levels leave the result unchanged. A `"record-wide"` bias: the record-wide
#' levels ([where_fails()]) of its site. A `"covered"` misfit: the fit read
#' again with the inputs in conflict held to their prior
#' (`attr(where_fails(fit), "held")$fit`), restricted to the interval as
#' above. An `"input"` in conflict: that held fit, whole. Give the `fit`
#' whose table the row comes from. The tempering and the prior over subsets
#' are as without `finding`, on fewer coefficients, so the evidence is
#' weaker than the whole bias would give. The result's attribute `finding`
#' says which was explained.
#'
#' @inheritParams bands
#' @inheritParams calibrate
#' @param candidates A named list of candidate curves: each a numeric vector
#'   (used at every site) or a named list by site of vectors, on the fit's
#'   grid `fit$basis$t` or on the grid the runs were given on (see `t`).
#'   May be empty when `shifts = TRUE`. Or a named list of `wv_fit` objects,
#'   the model re-validated with each candidate mechanism (see the section
#'   "Re-validated models as candidates").
#' @param shifts Add the automatic parameter-shift candidates `shift:<input>`.
#' @param positive Constrain the amplitudes of the user's candidates to be
#'   non-negative (see Details): `TRUE`, `FALSE`, or one logical per candidate.
#' @param max_size Largest number of candidates in one subset.
#' @param n_draws Number of posterior draws used (evenly thinned).
#' @param level Probability of the amplitude intervals.
#' @param segments Number of equal time segments of the record whose
#'   coefficients count as one cluster when the evidence is tempered (see
#'   Details); `NULL` for no tempering.
#' @param effect `NULL` (each candidate is its own effect) or one name per
#'   candidate: candidates with the same name are versions of one effect, such
#'   as its signature simulated at different inputs (see Details). The table
#'   then has one row per effect, named by `effect`.
#' @param t The times of candidate curves that are not on the fit's grid: when
#'   the runs were given on a grid that is not dyadic, [model_runs()] and
#'   [field_runs()] interpolated them to one (`fit$basis$t`), and candidates
#'   simulated on the original grid can be given there. A curve with one
#'   value per point of `t` (increasing times over the interval of
#'   `fit$basis$t`) is linearly interpolated to `fit$basis$t`, with a message.
#'   With `t = NULL`, a curve of `n` values, fewer than the `N` of
#'   `fit$basis$t` but more than `N / 2` (a grid that [model_runs()] would
#'   have interpolated to `fit$basis$t`), is taken as equally spaced over its
#'   interval and interpolated likewise. Not used with re-validated models.
#' @param finding `NULL` (default: the whole bias) or one finding of
#'   [where_fails()] to explain: a row of its table, `where_fails(fit)[k, ]`
#'   (a `wv_fails` table is explained by its first row, the largest
#'   finding). See the section "One finding". Not used with re-validated
#'   models.
#' @param ... Must be empty: an unknown argument is an error.
#' @return A `wv_explain` data frame ranked by `inclusion_prob`, with columns
#'   `candidate`, `inclusion_prob`, `amplitude` (posterior mean coefficient of
#'   the candidate curve in the bias, model-averaged; 0 in draws that leave it
#'   out), `amplitude_lower`, `amplitude_upper` (from draws of subsets that
#'   `seed` fixes), `share_explained` (the share of what the most
#'   probable subset of candidates explains that the candidate alone
#'   explains, averaged over draws: measured against the part of the bias the
#'   candidates could explain, not an offset or a noise no candidate
#'   resembles; at most 1) and
#'   `share_of_bias` (the share of the whole residual energy that the
#'   candidate alone explains). Both are in the regression's metric, each
#'   coefficient weighted by the inverse of its variance, so that a
#'   coarse-level offset whose size the data barely fix does not swamp them. Attributes
#'   `subsets` (top subsets with their probabilities), `eta` (the tempering
#'   power of each draw used), `curves` (bias and scaled candidates by
#'   site, for plotting; an effect is drawn with its most probable version),
#'   `boundary` (the inputs whose posterior piles up at a bound of their range,
#'   see [calibrate()]) and, with `effect`, `versions` (each candidate's
#'   inclusion probability, amplitude and share explained, with the effect it
#'   is a version of), and with curve candidates and `shifts = TRUE`,
#'   `absorbed`: for each of the user's candidates, the share of its signature
#'   (in the regression's metric) that the parameter shifts span, and the
#'   inputs that carry it. `print` warns of a candidate 75\% or more of which
#'   is a parameter shift: the bias can hardly tell such an effect from a
#'   change of those inputs, since the calibration has already moved them to
#'   absorb what they can, and a low inclusion probability is then weak
#'   evidence against it.
#' @export
#' @examples
#' # a small problem whose field has a bump near t = 0.25 that the model lacks
#' fit <- example_fit()
#' t <- fit$field$t
#' candidates <- list(bump_early = exp(-((t - 0.25) / 0.05)^2),
#'                    bump_late = exp(-((t - 0.75) / 0.05)^2))
#' ex_b <- explain_bias(fit, candidates, seed = 1)
#' ex_b
#' autoplot(ex_b)
#' # the first finding of where_fails() alone
#' explain_bias(fit, candidates, seed = 1, finding = where_fails(fit)[1, ])
#' # the early bump in two versions (the second a little late), weighed as one
#' # effect
#' versions <- c(candidates, list(bump_early_2 = exp(-((t - 0.3) / 0.05)^2)))
#' ex_v <- explain_bias(fit, versions, effect = c("bump_early", "bump_late", "bump_early"), seed = 1)
#' ex_v
#' attr(ex_v, "versions")
#' # or add the bump to the model, its strength a new calibration input, and
#' # validate again on the same basis and field data; the runs include the
#' # model without the bump (strength 0)
#' on <- data.frame(u1 = (sample(30) - 0.5) / 30, x1 = (sample(30) - 0.5) / 30,
#'                  s_bump = (sample(30) - 0.5) / 30)
#' design <- rbind(transform(on, s_bump = 0), on)
#' model <- function(u, x, s) (1 + 0.5 * x) * sin(2 * pi * t) + u * exp(-((t - 0.6) / 0.08)^2) +
#'   s * exp(-((t - 0.25) / 0.05)^2)
#' runs <- model_runs(design, t(apply(design, 1, function(z) model(z[1], z[2], z[3]))), t, site = "site1")
#' iu_bump <- iu_add(fit$iu, "s_bump", lower = 0, upper = 1)
#' with_bump <- calibrate(fit_emulators(runs, fit$basis), fit$field, iu_bump, chains = 1, seed = 2,
#'                        sampler = sampler_control(n_draws = 100, n_inner = 20, quiet = TRUE))
#' explain_bias(fit, list(bump = with_bump))
explain_bias <- function(fit, candidates = list(), shifts = TRUE, positive = TRUE, max_size = 3L,
                         n_draws = 200L, level = 0.9, seed = NULL, segments = 64L, effect = NULL, t = NULL,
                         finding = NULL, ...) {
  check_dots_none(...)
  check_class(fit, "wv_fit")
  check_number(max_size, min = 1, max = 8, integer = TRUE)
  if (!is.null(segments)) check_number(segments, min = 1, integer = TRUE)
  check_number(n_draws, min = 2, integer = TRUE)
  check_level(level)
  scope <- if (!is.null(finding)) finding_scope(fit, finding)
  if (candidates_are_fits(candidates)) {
    if (!is.null(scope)) {
      wv_abort(c("{.arg finding} restricts the regression on candidate curves.",
                 "i" = "Re-validated models are weighed on the whole bias: drop {.arg finding}."))
    }
    return(explain_refits(fit, candidates, n_draws, level))
  }
  if (!is.null(scope)) fit <- scope$fit
  cand <- candidate_coefficients(fit, candidates, t)
  pos <- candidate_signs(positive, ncol(cand))
  group <- candidate_effects(effect, colnames(cand))
  draws <- fit_draws_matrix(fit)
  user <- cand
  if (isTRUE(shifts)) {
    sh <- shift_candidates(fit, colMeans(draws[, fit_get(fit, "inputs"), drop = FALSE]))
    cand <- cbind(cand, sh)
    pos <- c(pos, rep(FALSE, ncol(sh)))
    group <- c(group, colnames(sh))
  }
  if (ncol(cand) == 0L) {
    wv_abort("No candidates: give {.arg candidates} or set {.code shifts = TRUE}.")
  }
  H <- nrow(fit_get(fit, "wb")[[1]])
  keep <- unique(round(seq(1, H, length.out = min(n_draws, H))))
  draws <- draws[keep, , drop = FALSE]
  rs <- residual_regression_data(fit, draws, keep)
  Y <- rs$residuals
  Wt <- 1 / (rs$variance + bias_level_variances(fit, draws))
  seed <- resolve_seed(seed)
  cluster <- if (!is.null(segments)) coefficient_segments(fit, segments)
  use <- scope$use %||% rep(TRUE, ncol(Y))
  if (!any(use)) wv_abort("The finding {scope$label} holds no coefficient to regress.")
  res <- with_rng_seed(seed, bias_regression(Y[, use, drop = FALSE], cand[use, , drop = FALSE],
                                             Wt[, use, drop = FALSE], max_size = max_size, level = level, cluster = cluster[use],
                                             positive = pos, group = group))
  out <- res$table
  attr(out, "subsets") <- res$subsets
  attr(out, "versions") <- res$versions
  attr(out, "eta") <- res$eta
  lead <- cand[, res$lead, drop = FALSE]
  colnames(lead) <- names(res$lead)
  attr(out, "curves") <- explain_curves(fit, lead, out)
  attr(out, "boundary") <- unique(fit_get(fit, "flags")$boundary$input)
  if (isTRUE(shifts)) {
    attr(out, "absorbed") <- shift_absorption(user[use, , drop = FALSE], sh[use, , drop = FALSE],
                                              colMeans(Wt[, use, drop = FALSE]))
  }
  attr(out, "finding") <- scope$label
  attr(out, "positive") <- colnames(cand)[pos]
  class(out) <- c("wv_explain", "data.frame")
  out
}

# Cluster of each coefficient (all sites stacked, in the order of fit$wb) for
# the tempering: the time segment, out of `segments` equal ones, where the
# support of its basis function is centred (by squared weight), per site.
coefficient_segments <- function(fit, segments) {
  t <- fit_get(fit, "basis")$t
  P2 <- fit_get(fit, "basis")$Psi^2
  centre <- colSums(P2 * t) / colSums(P2)
  seg <- pmin(segments - 1L, floor((centre - t[1]) / (t[length(t)] - t[1]) * segments))
  n <- vapply(fit_get(fit, "wb"), ncol, 1L)
  unlist(lapply(seq_along(n), function(i) (i - 1L) * segments + seg[seq_len(n[i])]))
}

# Residuals wbar - m(z_h) of the field data from the emulated model at the
# inputs of the kept draws `draws` (rows `keep` of the fit's draws), and their
# field and emulator variance sigma^2_h / R + V(z_h): H x n matrices, sites
# stacked in the order of fit$wb.
residual_regression_data <- function(fit, draws, keep) {
  Z <- draws[, fit_get(fit, "inputs"), drop = FALSE]
  parts <- lapply(fit_sites(fit), function(s) {
    pr <- bank_predict(site_bank(fit_get(fit, "emulators"), s), shift_inputs(fit, s, Z))
    list(r = field_mean_draws(fit, s, keep) - pr$mean,
         v = pr$var + field_mean_variance(fit, s, keep))
  })
  list(residuals = do.call(cbind, lapply(parts, `[[`, "r")),
       variance = do.call(cbind, lapply(parts, `[[`, "v")))
}

# Per-draw bias variance tau^2 of each coefficient's (site, level) group, for
# the rows of the draws matrix `d`: H x n matrix, sites stacked in the order of
# fit$wb.
bias_level_variances <- function(fit, d) {
  do.call(cbind, lapply(fit_sites(fit), function(s) {
    col <- tau2_columns(fit, s)
    miss <- setdiff(unique(col), colnames(d))
    if (length(miss)) wv_abort("The fit has no draws of {.val {miss}}.", class = "state")
    d[, col, drop = FALSE]
  }))
}

# Posterior mean bias and the leading candidates scaled by their amplitude, by
# site, on the grid (for autoplot).
explain_curves <- function(fit, cand, table, n_lead = 3L) {
  sites <- fit_sites(fit)
  n <- vapply(fit_get(fit, "wb"), ncol, 1L)
  offs <- c(0L, cumsum(n))
  lead <- utils::head(table[table$inclusion_prob > 0, , drop = FALSE], n_lead)
  do.call(rbind, lapply(seq_along(sites), function(i) {
    s <- sites[i]
    rows <- (offs[i] + 1L):offs[i + 1L]
    b <- drop(fit_get(fit, "basis")$Psi %*% colMeans(fit_get(fit, "wb")[[s]]))
    out <- data.frame(site = s, t = fit_get(fit, "basis")$t, curve = "posterior mean bias", value = b)
    for (k in seq_len(nrow(lead))) {
      v <- drop(fit_get(fit, "basis")$Psi %*% cand[rows, lead$candidate[k]]) * lead$amplitude[k]
      out <- rbind(out, data.frame(site = s, t = fit_get(fit, "basis")$t,
                                   curve = sprintf("%s x %.3g", lead$candidate[k], lead$amplitude[k]),
                                   value = v))
    }
    out
  }))
}
