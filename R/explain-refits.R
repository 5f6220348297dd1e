# explain_bias() with re-validated models as candidates: each candidate is the
# model with one mechanism added, its inputs (a strength, perhaps rates) extra
# calibration inputs, calibrated on the same field data and wavelet basis as
# `fit`. Each is weighed by the Bayes factor of the strengths free against the
# strengths at their no-effect values (the mechanism switched off), estimated
# from its own posterior draws by the Savage-Dickey density ratio.

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
#' A mechanism may add several inputs (an exchange rate and a return rate):
#' give each its no-effect value with `iu_add(off = )`, `NA` for a rate that
#' acts only while the others are on; a single added input without one is
#' off at its lower bound. The mechanism is off when its one or two inputs
#' with a no-effect value are at it, and the Bayes factor below is of those
#' inputs (jointly) against that point, the rates free in both models.
#'
#' Each is then weighed against itself with the mechanism switched off, on the
#' same emulators: a comparison of two models fitted to different designs would
#' carry the difference between their emulators (on the package's suspension
#' test bed, a model with a mechanism whose strength the data put at zero
#' scored well above the one without it). The Bayes factor of the strength free
#' against the strength at its no-effect value `s_0` is the Savage-Dickey ratio
#' `p(s_0) / p(s_0 | data)`, the strength's prior density over its posterior
#' density at `s_0`. The posterior density is
#' Rao-Blackwellised: the mean over the draws (up to `n_draws`, evenly
#' thinned) of the strength's density given the draw's other inputs (rates
#' included), field and bias variances: the likelihood of the coefficients
#' times the prior over the strength's range, on a grid refined around its peak. "No
#' mechanism" and each mechanism alone are equally likely a priori, so a
#' candidate's `inclusion_prob` is its Bayes factor over one plus the sum of
#' all of them; the attribute `subsets` gives each model's probability,
#' "(none)" included, `log_bf` the log Bayes factors and `inputs` each added
#' input's role (strength or rate), no-effect value, posterior mean and
#' interval. `amplitude` and its
#' interval are the (first) strength's posterior mean and equal-tailed interval,
#' `share_explained` is one minus the energy of the candidate model's posterior
#' mean bias over that of `fit`, both without the record-wide levels (those
#' [where_fails()] reports apart: an offset or a slow trend), and
#' `share_of_bias` the same on the whole bias; `autoplot` overlays the bias of `fit` and
#' each leading mechanism's effect in its model (the emulated output at the
#' posterior mean inputs minus the same with the strengths at `s_0`). The other
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

# Log of the posterior density of the strengths at their no-effect values
# `off`, by Rao-Blackwellised Savage-Dickey: the mean over the kept draws of
# the conditional density of the strengths given the other inputs (the
# mechanism's rates included), field and bias variances. Each conditional is
# the likelihood times the strengths' prior over their box, on a grid of
# n_grid points per strength (17 with two) refined around its largest value,
# integrated by the trapezoidal rule, strength by strength.
log_density_at_off <- function(rf, D, strength, off, keep, n_grid = 33L, tick = NULL) {
  prior_iu <- fit_get(rf, "prior_iu")
  idx <- match(strength, prior_iu$name)
  lo <- prior_iu$lower[idx]
  hi <- prior_iu$upper[idx]
  n_dim <- length(strength)
  if (n_dim > 1L) n_grid <- 17L
  n_fine <- if (n_dim > 1L) 9L else 17L
  settings <- fit_get(rf, "settings")
  groups <- fit_get(rf, "groups")
  informs <- informing_groups(settings$inform_levels, fit_get(rf, "basis")$level,
                              fit_get(rf, "bias_group"), groups)
  informing <- if (is.null(informs)) groups$name else groups$name[informs == 1L]
  inputs <- fit_get(rf, "inputs")
  coarse <- lapply(seq_len(n_dim), function(i) sort(unique(c(seq(lo[i], hi[i], length.out = n_grid), off[i]))))
  step <- (hi - lo) / (n_grid - 1L)
  log_prior <- function(S) {
    Reduce(`+`, lapply(seq_len(n_dim), function(i) log(iu_prior_density(prior_iu, idx[i], S[, i]))))
  }
  out <- vapply(keep, function(h) {
    z <- D[h, inputs]
    at <- function(S) {
      Z <- matrix(z, nrow(S), length(z), byrow = TRUE, dimnames = list(NULL, inputs))
      Z[, strength] <- S
      (settings$temper %||% 1) * refit_loglik(rf, D, Z, h, informing) + log_prior(S)
    }
    S0 <- as.matrix(expand.grid(coarse))
    l0 <- at(S0)
    j <- S0[which.max(l0), ]
    axes <- lapply(seq_len(n_dim), function(i) {
      fine <- seq(max(lo[i], j[i] - step[i]), min(hi[i], j[i] + step[i]), length.out = n_fine)
      sort(unique(c(coarse[[i]], fine)))
    })
    S <- as.matrix(expand.grid(axes))
    key <- function(M) apply(M, 1L, paste, collapse = " ")
    l <- l0[match(key(S), key(S0))]
    new <- is.na(l)
    if (any(new)) l[new] <- at(S[new, , drop = FALSE])
    if (!is.null(tick)) tick()
    at_off <- l[which(Reduce(`&`, lapply(seq_len(n_dim), function(i) S[, i] == off[i])))[1]]
    at_off - log_trapezoid_grid(axes, l)
  }, numeric(1))
  m <- max(out)
  m + log(mean(exp(out - m)))
}

# Log of the integral of exp(l) over the tensor grid of `axes` (l in the order
# of expand.grid(axes)), by the trapezoidal rule one axis at a time.
log_trapezoid_grid <- function(axes, l) {
  A <- array(l, lengths(axes))
  for (i in seq_along(axes)) {
    A <- if (length(dim(A)) > 1L) {
      apply(A, seq_along(dim(A))[-1L], function(v) log_trapezoid(axes[[i]], v))
    } else {
      log_trapezoid(axes[[i]], A)
    }
  }
  A
}

# Log of the integral of exp(l) over increasing points v by the trapezoidal
# rule, scaled by the largest l so that exp() cannot overflow.
log_trapezoid <- function(v, l) {
  m <- max(l)
  m + log(sum(diff(v) * (exp(l[-1] - m) + exp(l[-length(l)] - m)) / 2))
}

# The candidate table for re-validated models.
explain_refits <- function(fit, refits, n_draws, level) {
  eff <- refit_strengths(fit, refits)
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
  # runs with every strength at its no-effect value: the model without the
  # mechanism
  n_off <- vapply(nm, function(k) {
    e <- eff[[k]]
    d <- fit_get(refits[[k]], "emulators")$design
    is_off <- lapply(e$strength, function(v) abs(d[, v] - e$off[[v]]) <= 1e-8 * max(1, abs(e$off[[v]])))
    sum(Reduce(`&`, is_off))
  }, numeric(1))
  if (any(n_off < 2)) {
    wv_warn(c("The runs of {.val {nm[n_off < 2]}} hold no model with the mechanism switched off.",
              "i" = paste("Its weight rests on the emulators' extrapolation to the strength's no-effect value,",
                          "and a mechanism can then win with nothing missing."),
              "i" = paste("Fit its emulators on the model's own runs with the strength at its no-effect value",
                          "as well: {.code fit_emulators(c(runs_off, runs_on), fit$basis)}.")),
            class = "refit_off")
  }
  inputs_tab <- list()
  rows <- lapply(nm, function(k) {
    rf <- refits[[k]]
    e <- eff[[k]]
    D <- fit_draws_matrix(rf)
    H <- nrow(D)
    keep <- unique(round(seq(1, H, length.out = min(n_draws, H))))
    prior_iu <- fit_get(rf, "prior_iu")
    idx <- match(e$strength, prior_iu$name)
    off <- unname(e$off[e$strength])
    log_prior_off <- sum(log(vapply(seq_along(idx), function(i) iu_prior_density(prior_iu, idx[i], off[i]),
                                    numeric(1))))
    log_bf <- log_prior_off - log_density_at_off(rf, D, e$strength, off, keep, tick = tick)
    q <- vapply(e$added, function(v) {
      c(mean(D[, v]), stats::quantile(D[, v], c(a, 1 - a), names = FALSE))
    }, numeric(3))
    inputs_tab[[k]] <<- data.frame(candidate = k, input = e$added,
                                   role = ifelse(is.na(e$off), "rate", "strength"),
                                   off = unname(e$off), mean = q[1, ], lower = q[2, ], upper = q[3, ],
                                   stringsAsFactors = FALSE)
    s <- e$strength[1]
    data.frame(candidate = k, log_bf = log_bf, amplitude = q[1, s],
               amplitude_lower = q[2, s], amplitude_upper = q[3, s],
               share_explained = 1 - bias_energy(rf, local) / e0_local,
               share_of_bias = 1 - bias_energy(rf) / e0,
               strength = s, stringsAsFactors = FALSE)
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
  added <- do.call(rbind, inputs_tab[tab$candidate])
  rownames(added) <- NULL
  attr(out, "inputs") <- added
  attr(out, "curves") <- refit_curves(fit, refits[tab$candidate], eff[tab$candidate], tab$inclusion_prob)
  attr(out, "boundary") <- unique(fit_get(fit, "flags")$boundary$input)
  attr(out, "method") <- "revalidated"
  class(out) <- c("wv_explain", "data.frame")
  out
}

# Posterior mean bias of `fit` and, for up to three leading candidates, the
# effect of the mechanism in the re-validated model: its emulated output at the
# posterior mean inputs minus the same with its strengths at their no-effect
# values (`eff`: each candidate's added inputs, as refit_strengths() gives).
refit_curves <- function(fit, refits, eff, prob, n_lead = 3L) {
  sites <- fit_sites(fit)
  lead <- utils::head(which(prob > 0), n_lead)
  # each leading refit at its posterior mean inputs and with its strengths
  # off, once for all sites
  at <- lapply(lead, function(k) {
    z <- posterior_mean_inputs(refits[[k]])
    z0 <- z
    z0[eff[[k]]$strength] <- eff[[k]]$off[eff[[k]]$strength]
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
      added <- eff[[k]]$added
      out <- rbind(out, data.frame(site = s, t = fit_get(fit, "basis")$t,
                                   curve = sprintf("%s at %s", names(refits)[k],
                                                   paste(sprintf("%s = %.3g", added, z[added]),
                                                         collapse = ", ")),
                                   value = v))
    }
    out
  }))
}
