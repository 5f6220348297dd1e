# explain_bias() with re-validated models as candidates: each candidate is the
# model with one mechanism added, its strength an extra calibration input,
# calibrated on the same field data and wavelet basis as `fit`. Each is weighed
# by the Bayes factor of the strength free against the strength at the lower
# bound of its range (the mechanism switched off), estimated from its own
# posterior draws by the Savage-Dickey density ratio.

#' @name explain_bias
#' @rdname explain_bias
#' @section Re-validated models as candidates:
#' A signature is a curve taken at fixed inputs. When the calibration has made
#' up for the missing mechanism by moving the inputs (often to a bound of their
#' range), the mechanism's effect at the calibrated inputs differs from the
#' effect in the data, and a decoy can look more alike. The remedy is to add
#' each suspected mechanism to the model and validate again: the model with
#' the mechanism, its strength an extra calibration input whose lower bound
#' switches it off, run at a design over all inputs together with the
#' model's own runs with the strength at that bound (the model without the
#' mechanism), its emulators fitted on
#' the basis of `fit` (`fit_emulators(runs, fit$basis)`) and calibrated on the
#' field data of `fit` (`fit$field`). Give these fits, one per mechanism, as
#' `candidates`.
#'
#' Each is then weighed against itself with the mechanism switched off, on the
#' same emulators: a comparison of two models fitted to different designs would
#' carry the difference between their emulators (on the package's suspension
#' test bed, a model with a mechanism whose strength the data put at zero
#' scored well above the one without it). The Bayes factor of the strength free
#' against the strength at its lower bound `s_0` is the Savage-Dickey ratio
#' `p(s_0) / p(s_0 | data)`, the strength's prior density (uniform over its
#' range) over its posterior density at `s_0`. The posterior density is
#' Rao-Blackwellised: the mean over the draws (up to `n_draws`, evenly
#' thinned) of the strength's density given the draw's other inputs, field
#' and bias variances, which is the likelihood of the coefficients over the
#' strength's range, computed on a grid refined around its peak. "No
#' mechanism" and each mechanism alone are equally likely a priori, so a
#' candidate's `inclusion_prob` is its Bayes factor over one plus the sum of
#' all of them; the attribute `subsets` gives each model's probability,
#' "(none)" included, and `log_bf` the log Bayes factors. `amplitude` and its
#' interval are the strength's posterior mean and equal-tailed interval,
#' `share_explained` is one minus the energy of the candidate model's posterior
#' mean bias over that of `fit`, both without the record-wide levels (those
#' [where_fails()] reports apart: an offset or a slow trend), and
#' `share_of_bias` the same on the whole bias; `autoplot` overlays the bias of `fit` and
#' each leading mechanism's effect in its model (the emulated output at the
#' posterior mean inputs minus the same with the strength at `s_0`). The other
#' arguments but `n_draws` and `level` are not used: the calibration moves the
#' inputs itself.
#'
#' On an example with three inputs and fixed variances, the estimate agreed
#' with the Bayes factor computed by quadrature to within 0.15 on the log scale
#' (the package's tests). The estimate averages a density that is tiny
#' wherever the data put the strength far from `s_0`, so a very large log
#' Bayes factor is decisive but its size is not to be read (a hidden
#' mechanism can give one in the thousands).
#'
#' Each candidate costs a calibration of its own. Where the model's own inputs
#' absorb a mechanism's effect, "(none)" can win against it. On the package's
#' test beds the re-validated models named hidden mechanisms even where a
#' signature lost to a decoy's, but they too claimed a mechanism at times
#' when nothing was hidden; the figures are in `studies/README.md` in the
#' package's source repository.
NULL

# TRUE when `candidates` is a non-empty list of wv_fit objects; an error when
# it mixes fits with curves.
candidates_are_fits <- function(candidates, call = rlang::caller_env()) {
  if (!is.list(candidates) || inherits(candidates, "wv_fit") || !length(candidates)) return(FALSE)
  is_fit <- vapply(candidates, inherits, logical(1), what = "wv_fit")
  if (any(is_fit) && !all(is_fit)) {
    wv_abort(c("{.arg candidates} mixes fitted models and curves.",
               "x" = "{.val {names(candidates)[!is_fit]}} {?is/are} not {.cls wv_fit} object{?s}.",
               "i" = "Give either curves (signatures) or re-validated models, in separate calls."),
             call = call)
  }
  all(is_fit)
}

# The strength input of each re-validated model: the one input it has beyond
# `fit`'s, a calibration input. Checks that each was calibrated on the same
# field data and basis.
refit_strengths <- function(fit, refits, call = rlang::caller_env()) {
  nm <- names(refits)
  if (is.null(nm) || anyNA(nm) || any(!nzchar(nm)) || anyDuplicated(nm)) {
    wv_abort("{.arg candidates} must be a list with a unique name for every candidate.",
             call = call)
  }
  sites <- fit_sites(fit)
  fit_basis <- fit_get(fit, "basis")
  vapply(nm, function(k) {
    rf <- refits[[k]]
    if (!setequal(fit_sites(rf), sites)) {
      wv_abort(c("Candidate {.val {k}} has sites {.val {fit_sites(rf)}}; {.arg fit} has {.val {sites}}.",
                 "i" = "Calibrate each candidate model on the field data of {.arg fit}."),
               call = call)
    }
    basis <- fit_get(rf, "basis")
    same_basis <- identical(basis$index, fit_basis$index) &&
      identical(dim(basis$Psi), dim(fit_basis$Psi)) &&
      isTRUE(all.equal(basis$Psi, fit_basis$Psi, tolerance = 1e-10))
    if (!same_basis) {
      wv_abort(c("Candidate {.val {k}} was not fitted on the wavelet basis of {.arg fit}.",
                 "i" = "Fit its emulators with {.code fit_emulators(runs, fit$basis)}."),
               call = call)
    }
    same_field <- all(vapply(sites, function(s) {
      isTRUE(all.equal(fit_get(rf, "wbar")[[s]], fit_get(fit, "wbar")[[s]], tolerance = 1e-8)) &&
        identical(fit_get(rf, "n_rep")[[s]], fit_get(fit, "n_rep")[[s]])
    }, logical(1)))
    if (!same_field) {
      wv_abort(c("Candidate {.val {k}} was not calibrated on the field data of {.arg fit}.",
                 "i" = "Use the same registered field data ({.code fit$field}) for every candidate."), call = call)
    }
    extra <- setdiff(fit_get(rf, "inputs"), fit_get(fit, "inputs"))
    lacks <- setdiff(fit_get(fit, "inputs"), fit_get(rf, "inputs"))
    if (length(extra) != 1L || length(lacks)) {
      wv_abort(c("Candidate {.val {k}} must have the inputs of {.arg fit} and one more, the mechanism's strength.",
                 "x" = "Its inputs beyond those of {.arg fit}: {.val {if (length(extra)) extra else 'none'}}.",
                 "x" = if (length(lacks)) "It lacks {.val {lacks}}."), call = call)
    }
    prior_iu <- fit_get(rf, "prior_iu")
    p <- prior_iu[match(extra, prior_iu$name), ]
    if (!identical(p$type, "calibration")) {
      wv_abort(c("The strength {.val {extra}} of candidate {.val {k}} must be a calibration input.",
                 "i" = "Give it a range whose lower bound switches the mechanism off, with {.fn iu_map}."),
               call = call)
    }
    extra
  }, character(1))
}

# Log likelihood of the coefficients that inform the inputs at each row of Z,
# given one draw's field variances and bias variances (row h of the fit and
# of its draws as a matrix, D).
refit_loglik <- function(rf, D, Z, h, informing) {
  ll <- numeric(nrow(Z))
  for (s in fit_sites(rf)) {
    g <- fit_get(rf, "bias_group")[[s]]
    use <- g %in% informing
    pr <- bank_predict(site_bank(fit_get(rf, "emulators"), s), shift_inputs(rf, s, Z))
    e <- drop(field_mean_variance(rf, s, h)) + D[h, tau2_columns(rf, s)]
    tot <- sweep(pr$var, 2L, e, `+`)[, use, drop = FALSE]
    r2 <- sweep(pr$mean, 2L, drop(field_mean_draws(rf, s, h)))[, use, drop = FALSE]^2
    ll <- ll - 0.5 * rowSums(log(tot) + r2 / tot)
  }
  ll
}

# Log of the posterior density of the strength at `off`, by Rao-Blackwellised
# Savage-Dickey: the mean over the kept draws of the conditional density of
# the strength given the other inputs, field and bias variances. Each
# conditional is the likelihood over [lower, upper] (the strength's prior is
# uniform there) on a grid of n_grid points refined around its largest value,
# integrated by the trapezoidal rule.
log_density_at_off <- function(rf, D, strength, keep, n_grid = 33L, tick = NULL) {
  prior_iu <- fit_get(rf, "prior_iu")
  p <- prior_iu[match(strength, prior_iu$name), ]
  lo <- p$lower
  hi <- p$upper
  settings <- fit_get(rf, "settings")
  groups <- fit_get(rf, "groups")
  informs <- informing_groups(settings$inform_levels, fit_get(rf, "basis")$level,
                              fit_get(rf, "bias_group"), groups)
  informing <- if (is.null(informs)) groups$name else groups$name[informs == 1L]
  inputs <- fit_get(rf, "inputs")
  grid <- seq(lo, hi, length.out = n_grid)
  step <- grid[2] - grid[1]
  out <- vapply(keep, function(h) {
    z <- D[h, inputs]
    at <- function(v) {
      Z <- matrix(z, length(v), length(z), byrow = TRUE, dimnames = list(NULL, inputs))
      Z[, strength] <- v
      (settings$temper %||% 1) * refit_loglik(rf, D, Z, h, informing)
    }
    ll <- at(grid)
    j <- which.max(ll)
    fine <- seq(max(lo, grid[j] - step), min(hi, grid[j] + step), length.out = 17L)
    v <- c(grid, fine)
    l <- c(ll, at(fine))
    o <- order(v)
    if (!is.null(tick)) tick()
    l[o][1] - log_trapezoid(v[o], l[o])
  }, numeric(1))
  m <- max(out)
  m + log(mean(exp(out - m)))
}

# Log of the integral of exp(l) over increasing points v by the trapezoidal
# rule, scaled by the largest l so that exp() cannot overflow.
log_trapezoid <- function(v, l) {
  m <- max(l)
  m + log(sum(diff(v) * (exp(l[-1] - m) + exp(l[-length(l)] - m)) / 2))
}

# The candidate table for re-validated models.
explain_refits <- function(fit, refits, n_draws, level) {
  strength <- refit_strengths(fit, refits)
  nm <- names(refits)
  a <- (1 - level) / 2
  # the energy of the posterior mean bias, whole and without the levels that
  # span the whole record (an offset or a slow trend, which a mechanism
  # acting at events does not explain)
  basis <- fit_get(fit, "basis")
  local <- !basis$level %in% record_wide_levels(basis)
  bias_energy <- function(f, keep = TRUE) {
    sum(vapply(fit_get(f, "wb"), function(w) sum(colMeans(w)[keep]^2), numeric(1)))
  }
  e0 <- bias_energy(fit)
  e0_local <- bias_energy(fit, local)
  tick <- NULL
  if (!isTRUE(getOption("wavevalid.quiet", FALSE))) {
    total <- sum(vapply(refits, function(rf) min(n_draws, length(fit_get(rf, "chain"))),
                        numeric(1)))
    id <- cli::cli_progress_bar("Savage-Dickey density ratios", total = total)
    tick <- function() cli::cli_progress_update(id = id)
  }
  off <- vapply(nm, function(k) {
    rf <- refits[[k]]
    prior_iu <- fit_get(rf, "prior_iu")
    lower <- prior_iu$lower[match(strength[[k]], prior_iu$name)]
    s <- fit_get(rf, "emulators")$design[, strength[[k]]]
    sum(abs(s - lower) <= 1e-8 * max(1, abs(lower)))
  }, numeric(1))
  if (any(off < 2)) {
    wv_warn(c("The runs of {.val {nm[off < 2]}} hold no model with the mechanism switched off.",
              "i" = paste("Its weight rests on the emulators' extrapolation to the strength's lower bound, and a",
                          "mechanism can then win with nothing missing."),
              "i" = paste("Fit its emulators on the model's own runs with the strength at its lower bound as",
                          "well: {.code fit_emulators(c(runs_off, runs_on), fit$basis)}.")),
            class = "refit_off")
  }
  rows <- lapply(nm, function(k) {
    rf <- refits[[k]]
    D <- fit_draws_matrix(rf)
    H <- nrow(D)
    keep <- unique(round(seq(1, H, length.out = min(n_draws, H))))
    prior_iu <- fit_get(rf, "prior_iu")
    p <- prior_iu[match(strength[[k]], prior_iu$name), ]
    log_bf <- -log(p$upper - p$lower) - log_density_at_off(rf, D, strength[[k]], keep, tick = tick)
    s <- D[, strength[[k]]]
    data.frame(candidate = k, log_bf = log_bf, amplitude = mean(s),
               amplitude_lower = unname(stats::quantile(s, a)),
               amplitude_upper = unname(stats::quantile(s, 1 - a)),
               share_explained = 1 - bias_energy(rf, local) / e0_local,
               share_of_bias = 1 - bias_energy(rf) / e0,
               strength = strength[[k]], stringsAsFactors = FALSE)
  })
  tab <- do.call(rbind, rows)
  # no mechanism and each mechanism alone, equally likely a priori
  lb <- c(0, tab$log_bf)
  post <- exp(lb - max(lb))
  post <- post / sum(post)
  tab$inclusion_prob <- post[-1]
  tab <- tab[order(-tab$inclusion_prob, -tab$log_bf), , drop = FALSE]
  out <- tab[c("candidate", "inclusion_prob", "amplitude", "amplitude_lower", "amplitude_upper",
               "share_explained", "share_of_bias")]
  rownames(out) <- NULL
  models <- data.frame(subset = c(tab$candidate, "(none)"),
                       probability = c(tab$inclusion_prob, post[1]),
                       stringsAsFactors = FALSE)
  attr(out, "subsets") <- models[order(-models$probability), , drop = FALSE]
  attr(out, "log_bf") <- stats::setNames(tab$log_bf, tab$candidate)
  attr(out, "strength") <- stats::setNames(tab$strength, tab$candidate)
  attr(out, "curves") <- refit_curves(fit, refits[tab$candidate], tab$strength, tab$inclusion_prob)
  attr(out, "boundary") <- unique(fit_get(fit, "flags")$boundary$input)
  attr(out, "method") <- "revalidated"
  class(out) <- c("wv_explain", "data.frame")
  out
}

# Posterior mean bias of `fit` and, for up to three leading candidates, the
# effect of the mechanism in the re-validated model: its emulated output at the
# posterior mean inputs minus the same with the strength at its lower bound.
refit_curves <- function(fit, refits, strength, prob, n_lead = 3L) {
  sites <- fit_sites(fit)
  lead <- utils::head(which(prob > 0), n_lead)
  # each leading refit at its posterior mean inputs and with the strength at
  # its lower bound, once for all sites
  at <- lapply(lead, function(k) {
    rf <- refits[[k]]
    z <- posterior_mean_inputs(rf)
    z0 <- z
    z0[strength[k]] <- fit_get(rf,
                               "prior_iu")$lower[match(strength[k], fit_get(rf, "prior_iu")$name)]
    rbind(z, z0)
  })
  do.call(rbind, lapply(sites, function(s) {
    b <- drop(fit_get(fit, "basis")$Psi %*% colMeans(fit_get(fit, "wb")[[s]]))
    out <- data.frame(site = s, t = fit_get(fit, "basis")$t, curve = "posterior mean bias",
                      value = b)
    for (i in seq_along(lead)) {
      k <- lead[i]
      rf <- refits[[k]]
      z <- at[[i]][1, ]
      m <- bank_predict(site_bank(fit_get(rf, "emulators"), s), shift_inputs(rf, s, at[[i]]))$mean
      v <- drop(fit_get(fit, "basis")$Psi %*% (m[1, ] - m[2, ]))
      out <- rbind(out, data.frame(site = s, t = fit_get(fit, "basis")$t,
                                   curve = sprintf("%s at %s = %.3g", names(refits)[k], strength[k],
                                                   z[strength[k]]),
                                   value = v))
    }
    out
  }))
}
