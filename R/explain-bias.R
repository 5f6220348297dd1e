#' Which missing effect explains the bias?
#'
#' Regresses the bias (the field data's residuals from the emulated model at
#' the posterior draws of the inputs), draw by draw, on the wavelet
#' coefficients of candidate effect curves and compares subsets of
#' candidates by their marginal likelihood. A candidate is the signature of a
#' mechanism the user suspects the model lacks: typically the difference
#' between a run with the mechanism and a run without it, near the calibrated
#' inputs, or a physical feature curve of the calibrated model (a contact
#' force, a velocity). The directions in which the emulated output moves when
#' one input moves (emulator gradients at the posterior mean inputs) join as
#' automatic candidates `shift:<input>`, so that a bias a parameter change
#' would absorb is told apart from a missing mechanism. The figures quoted
#' below are in `studies/README.md` in the package's source repository,
#' "diagnosis.R" and "absorption.R".
#'
#' For each draw, the residuals `wbar - m(z_h)` (all sites stacked) are
#' regressed on the candidates' coefficients by weighted least squares (weights
#' `1 / (sigma^2_h / R + V(z_h) + tau^2)`), which keeps the signal the bias
#' prior would shrink, under Zellner's g-prior (`g = n`, `pi(phi) ~ 1/phi`).
#' Subsets of up to `max_size` candidates have equal prior probability for
#' each size and within a size; their probabilities are averaged over draws,
#' and a candidate's inclusion probability is the total probability of the
#' subsets that contain it (linearly dependent subsets are skipped, so
#' identical candidates share their inclusion).
#'
#' A misshapen event moves many neighbouring coefficients together, which
#' would make every candidate resembling it look decisive, so the evidence of
#' each draw is tempered by `eta = m / tr(J^-1 I)` in (0, 1]: `J` the
#' information the regression on all `m` candidates claims for their
#' amplitudes, `I` its sandwich estimate with the coefficients centred in one
#' of `segments` time segments of a site as a cluster. The Bayes factor then
#' counts `eta n` coefficients and the intervals widen by `1 / sqrt(eta)`;
#' `segments = NULL` turns it off.
#'
#' A mechanism either acts or it does not: with `positive = TRUE` (default)
#' the user's candidates' amplitudes are constrained non-negative (each
#' subset's evidence times the posterior probability of that orthant, by the
#' GHK simulator on a fixed lattice, so independent of the seed). A candidate
#' whose amplitude would be credibly negative gets almost no evidence; on the
#' suspension test bed this removed a false claim of such a decoy. The shifts
#' stay free in sign; set `positive = FALSE`, or one logical per candidate,
#' for candidates of arbitrary sign (a physical feature curve).
#'
#' When an input's posterior piles up at a bound (`print` says so), the
#' calibration is likely making up for the missing effect with it, and a
#' signature simulated at the calibrated inputs can differ from the effect the
#' data carry; at the nominal inputs it can too. Give both as versions of one
#' effect (`effect`): versions share the effect's prior mass, never enter one
#' subset together, and the effect's inclusion probability is the sum of
#' theirs. On the suspension test bed, two such versions ranked the hidden
#' mechanism first more often than either alone, with no claim when nothing
#' was hidden; many versions can fit what none explains, so keep them few.
#'
#' The attribute `absorbed` says how much of each candidate's signature the
#' parameter shifts span (`print` warns at 75\%): the calibration takes up
#' such an effect before the bias is looked at, so a low inclusion
#' probability is weak evidence against it; re-validate the model with it
#' instead (section "Re-validated models as candidates").
#'
#' @section One finding:
#' With `finding`, the regression is restricted to what that finding of
#' [where_fails()] carries: for an `"interval"`, the coefficients of its site
#' whose support overlaps it (of the localised levels when the table read the
#' bias by scale, its default); for a `"record-wide"` bias, the record-wide
#' levels of its site; for a `"covered"` misfit, the fit read again with the
#' inputs in conflict held to their prior (`attr(where_fails(fit),
#' "held")$fit`), restricted to the interval; for an `"input"` in conflict,
#' that held fit, whole. Give the `fit` whose table the row comes from. With
#' fewer coefficients the evidence is weaker than the whole bias would give.
#' The attribute `finding` says which was explained.
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
#' @param t The times of candidate curves not on the fit's grid (runs given on
#'   a grid that is not dyadic were interpolated to `fit$basis$t` by
#'   [model_runs()] and [field_runs()]): a curve with one value per point of
#'   `t` (increasing, over the interval of `fit$basis$t`) is linearly
#'   interpolated to `fit$basis$t`, with a message. With `t = NULL`, a curve
#'   of `n` values, `N / 2 < n < N` (`N` the length of `fit$basis$t`), is
#'   taken as equally spaced over its interval and interpolated likewise. Not
#'   used with re-validated models.
#' @param finding `NULL` (default: the whole bias) or one finding of
#'   [where_fails()] to explain: a row of its table, `where_fails(fit)[k, ]`
#'   (a whole table is explained by its first row, the largest finding). See
#'   the section "One finding". Not used with re-validated models.
#' @param ... Must be empty: an unknown argument is an error.
#' @return A `wv_explain` data frame ranked by `inclusion_prob`, with columns
#'   `candidate`, `inclusion_prob`, `amplitude` (posterior mean coefficient of
#'   the candidate curve in the bias, model-averaged; 0 in draws that leave it
#'   out), `amplitude_lower`, `amplitude_upper`, `share_explained` (the share
#'   of what the most probable subset explains that the candidate alone
#'   explains, averaged over draws; at most 1) and `share_of_bias` (the share
#'   of the whole residual energy the candidate alone explains), both in the
#'   regression's metric (each coefficient weighted by its inverse variance).
#'   Attributes `subsets` (top subsets with their probabilities), `eta` (the
#'   tempering power of each draw), `curves` (bias and scaled candidates by
#'   site, for plotting), `boundary` (the inputs piled at a bound of their
#'   range), with `effect` `versions` (each version's inclusion probability,
#'   amplitude and share explained), and with curve candidates and
#'   `shifts = TRUE` `absorbed` (each candidate's share spanned by the
#'   parameter shifts, and the inputs that carry it).
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
#' ex_v <- explain_bias(fit, versions, effect = c("bump_early", "bump_late", "bump_early"),
#'                      seed = 1)
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
#' runs <- model_runs(design, t(apply(design, 1, function(z) model(z[1], z[2], z[3]))), t,
#'                    site = "site1")
#' iu_bump <- iu_add(fit$iu, "s_bump", lower = 0, upper = 1)
#' with_bump <- calibrate(fit_emulators(runs, fit$basis), fit$field, iu_bump, chains = 1, seed = 2,
#'                        sampler = sampler_control(n_draws = 100, n_inner = 20, quiet = TRUE))
#' explain_bias(fit, list(bump = with_bump))
explain_bias <- function(fit, candidates = list(), shifts = TRUE, positive = TRUE, max_size = 3L,
                         n_draws = 200L, level = 0.9, seed = NULL, segments = 64L, effect = NULL,
                         t = NULL,
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
  absorbed <- NULL
  if (isTRUE(shifts)) {
    absorbed <- shift_absorption(user[use, , drop = FALSE], sh[use, , drop = FALSE],
                                 colMeans(Wt[, use, drop = FALSE]))
    # a candidate the shifts span (to rounding) is a change of inputs: it
    # cannot be weighed beside them
    spanned <- absorbed$candidate[absorbed$absorbed > 1 - 1e-8]
    if (length(spanned)) {
      wv_inform(c("!" = "Skipped {.val {spanned}}: the shifts of the inputs span {?its/their} signature{?s} (a change of {absorbed$inputs[match(spanned, absorbed$candidate)]}), so the bias cannot tell {?it/them} from that change.",
                  "i" = "{.fn explain_bias} weighs the shifts themselves (the rows {.val shift:...})."),
                class = "spanned")
      gone <- colnames(cand) %in% spanned
      cand <- cand[, !gone, drop = FALSE]
      pos <- pos[!gone]
      group <- group[!gone]
    }
  }
  res <- with_rng_seed(seed, bias_regression(Y[, use, drop = FALSE], cand[use, , drop = FALSE],
                                             Wt[, use, drop = FALSE], max_size = max_size,
                                             level = level, cluster = cluster[use],
                                             positive = pos, group = group))
  out <- res$table
  attr(out, "subsets") <- res$subsets
  attr(out, "versions") <- res$versions
  attr(out, "eta") <- res$eta
  lead <- cand[, res$lead, drop = FALSE]
  colnames(lead) <- names(res$lead)
  attr(out, "curves") <- explain_curves(fit, lead, out)
  attr(out, "boundary") <- unique(fit_get(fit, "flags")$boundary$input)
  if (isTRUE(shifts)) attr(out, "absorbed") <- absorbed
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
    out <- data.frame(site = s, t = fit_get(fit, "basis")$t, curve = "posterior mean bias",
                      value = b)
    for (k in seq_len(nrow(lead))) {
      v <- drop(fit_get(fit, "basis")$Psi %*% cand[rows, lead$candidate[k]]) * lead$amplitude[k]
      out <- rbind(out, data.frame(site = s, t = fit_get(fit, "basis")$t,
                                   curve = sprintf("%s x %.3g", lead$candidate[k],
                                                   lead$amplitude[k]),
                                   value = v))
    }
    out
  }))
}
