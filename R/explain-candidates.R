# The candidates of explain_bias(): their effects placed on the fit's grid and
# wavelet coefficients, their signs, and the shifts of the inputs.

# The sign constraint of each of the m user candidates from `positive`.
candidate_signs <- function(positive, m, call = rlang::caller_env()) {
  if (!is.logical(positive) || anyNA(positive) || !(length(positive) %in% c(1L, m))) {
    wv_abort(c("{.arg positive} must be TRUE, FALSE or one logical per candidate.",
               "x" = "It has length {length(positive)}; the number of candidates is {m}."),
             call = call)
  }
  rep_len(positive, m)
}

# The effect each of the user's candidates is a version of, from `effect`
# (NULL: each candidate its own effect).
candidate_effects <- function(effect, nm, call = rlang::caller_env()) {
  if (is.null(effect)) return(nm)
  if (!is.character(effect) || length(effect) != length(nm) || anyNA(effect) ||
      any(!nzchar(effect))) {
    wv_abort(c("{.arg effect} must name, for each candidate, the effect it is a version of.",
               "x" = "It has length {length(effect)}; the number of candidates is {length(nm)}."),
             call = call)
  }
  if (any(startsWith(effect, "shift:"))) {
    wv_abort("Effect names starting with {.val shift:} are reserved for the parameter shifts.",
             call = call)
  }
  effect
}

# Coefficients (all sites stacked, in the order of fit$wb) of user candidates,
# each curve first put on the fit's grid (candidate_on_grid()); one message
# names the curves that were interpolated.
candidate_coefficients <- function(fit, candidates, t = NULL, call = rlang::caller_env()) {
  sites <- fit_sites(fit)
  tb <- fit_get(fit, "basis")$t
  if (!is.list(candidates)) {
    wv_abort("{.arg candidates} must be a named list of curves.", call = call)
  }
  if (!is.null(t)) t <- check_candidate_grid(t, tb, call = call)
  if (length(candidates) == 0L) return(matrix(0, sum(vapply(fit_get(fit, "wb"), ncol, 1L)), 0L))
  nm <- names(candidates)
  if (is.null(nm) || anyNA(nm) || any(!nzchar(nm)) || anyDuplicated(nm)) {
    wv_abort("{.arg candidates} must be a list with a unique name for every candidate.",
             call = call)
  }
  placed <- lapply(nm, function(k) {
    cur <- candidates[[k]]
    if (is.numeric(cur) && is.null(dim(cur))) cur <- stats::setNames(rep(list(cur), length(sites)),
                                                                     sites)
    if (!is.list(cur) || !all(sites %in% names(cur))) {
      wv_abort(c(
        "Candidate {.val {k}} must be a numeric vector on the fit's grid or a list with one curve per site.",
        "i" = "The fit's sites are {.val {sites}}.",
        "i" = if (any(grepl("/", sites, fixed = TRUE))) "A site {.val e/s} is site {.val s} of experiment {.val e}: give the candidate's curve in that experiment's condition."
      ), call = call)
    }
    lapply(sites, function(s) candidate_on_grid(cur[[s]], k, s, tb, t, call = call))
  })
  from <- lapply(placed, function(p) unlist(lapply(p, `[[`, "from")))
  if (length(unlist(from))) {
    moved <- nm[lengths(from) > 0L]
    wv_inform(c(
      "i" = "{cli::qty(length(moved))}Candidate{?s} {.val {moved}} {?was/were} not on the fit's grid of {length(tb)} points ({.code fit$basis$t}): linearly interpolated to it from {unique(unlist(from))}."
    ))
  }
  Psi <- fit_get(fit, "basis")$Psi
  out <- do.call(cbind,
                 lapply(placed, function(p) unlist(lapply(p, function(y) drop(y$y %*% Psi)))))
  colnames(out) <- nm
  zero <- colSums(out^2) == 0
  if (any(zero)) {
    wv_abort(c(
      "Candidate{?s} {.val {nm[zero]}} {?is/are} zero on the retained wavelet coefficients.",
      "i" = "A candidate must be a curve that changes where the bias could be."
    ), call = call)
  }
  out
}

# The curve `y` of candidate `k` at site `s` on the fit's grid `tb`: `y` as
# given when it has one value per point of `tb` (and `t` does not say
# otherwise); linearly interpolated from the grid `t` when it has one value per
# point of `t`; else, without `t`, from as many equally spaced points over the
# interval of `tb` when model_runs() and field_runs() would have interpolated
# such a grid to `tb` (more than half as many points as `tb`, fewer than it):
# the user's grid when it was equally spaced but not dyadic. A list with `y`
# and `from` (how the curve was placed, NULL when it was on `tb`).
candidate_on_grid <- function(y, k, s, tb, t = NULL, call = rlang::caller_env()) {
  n_t <- length(tb)
  if (!is.numeric(y) || !length(y)) {
    wv_abort("Candidate {.val {k}} at site {.val {s}} must be a numeric curve, not {.obj_type_friendly {y}}.",
             call = call)
  }
  y <- as.numeric(y)
  if (any(!is.finite(y))) {
    wv_abort(c("Candidate {.val {k}} has missing or infinite values at site {.val {s}}.",
               "i" = "Give a complete curve: fill the gaps (e.g. by interpolation) first."),
             call = call)
  }
  n <- length(y)
  if (!is.null(t) && n == length(t)) {
    if (n == n_t && max(abs(t - tb)) <= 1e-8 * max(1, abs(tb))) return(list(y = y, from = NULL))
    from <- t
    how <- sprintf("the %d points of `t`", n)
  } else if (n == n_t) {
    return(list(y = y, from = NULL))
  } else if (is.null(t) && n >= 8L && 2L^ceiling(log2(n)) == n_t) {
    from <- seq(tb[1], tb[n_t], length.out = n)
    how <- sprintf("%d equally spaced points on [%s, %s] (give `t` if they are not)", n,
                   format(signif(tb[1], 4)), format(signif(tb[n_t], 4)))
  } else {
    also <- if (is.null(t)) "" else sprintf(", `t` has %d", length(t))
    wv_abort(c(
      "Candidate {.val {k}} is not on the fit's grid at site {.val {s}}.",
      "x" = "It has {n} value{?s}; the grid has {n_t} points{also}.",
      "i" = "Interpolate it to {.code fit$basis$t} first, or give its times with {.arg t} (over the interval of the fit's grid)."
    ), class = c("grid", "input"), call = call)
  }
  list(y = stats::approx(from, y, xout = tb, rule = 2)$y, from = how)
}

# The grid `t` of candidate curves, checked against the fit's grid `tb`:
# finite, strictly increasing, at least 8 points, over the same interval.
check_candidate_grid <- function(t, tb, call = rlang::caller_env()) {
  ok <- is.numeric(t) && length(t) >= 8L && all(is.finite(t))
  if (!ok || any(diff(t) <= 0)) {
    wv_abort(c("{.arg t} must hold the times of the candidate curves: at least 8 finite, increasing values.",
               "x" = if (ok) "Its values do not increase." else
                 "It is {.obj_type_friendly {t}} of length {length(t)}, or holds missing or infinite values."),
             class = c("grid", "input"), call = call)
  }
  n_t <- length(tb)
  tol <- 1e-6 * (tb[n_t] - tb[1])
  if (abs(t[1] - tb[1]) > tol || abs(t[length(t)] - tb[n_t]) > tol) {
    wv_abort(c(
      "{.arg t} must span the interval of the fit's grid.",
      "x" = "It spans [{signif(t[1], 6)}, {signif(t[length(t)], 6)}]; the fit's grid {.code fit$basis$t} spans [{signif(tb[1], 6)}, {signif(tb[n_t], 6)}].",
      "i" = "Give the candidates on the grid the runs and the field were given on, or cut and interpolate them to that interval first."
    ), class = c("grid", "input"), call = call)
  }
  as.numeric(t)
}

# Emulator gradient of every coefficient in each input at the posterior mean
# inputs z_mean, by central differences, scaled by the input's range: the change
# of the model output when the input moves by its whole range.
shift_candidates <- function(fit, z_mean = posterior_mean_inputs(fit)) {
  em <- fit_get(fit, "emulators")
  zhat <- z_mean[em$inputs]
  sites <- fit_sites(fit)
  width <- vapply(em$inputs, function(p) {
    k <- match(p, fit_get(fit, "iu")$name)
    if (is.na(k))
      diff(range(em$design[, p])) else fit_get(fit, "iu")$upper[k] - fit_get(fit, "iu")$lower[k]
  }, numeric(1))
  out <- vapply(seq_along(em$inputs), function(p) {
    h <- 1e-3 * width[p]
    zp <- zm <- zhat
    zp[p] <- zp[p] + h
    zm[p] <- zm[p] - h
    Z <- rbind(zp, zm)
    unlist(lapply(sites, function(s) {
      pr <- bank_predict(site_bank(em, s), shift_inputs(fit, s, Z))$mean
      (pr[1, ] - pr[2, ]) / (2 * h) * width[p]
    }))
  }, numeric(sum(vapply(fit_get(fit, "wb"), ncol, 1L))))
  if (is.null(dim(out))) out <- matrix(out, ncol = length(em$inputs))
  colnames(out) <- paste0("shift:", em$inputs)
  out[, colSums(out^2) > 0, drop = FALSE]
}

# How much of each user candidate (columns of `cand`) the parameter-shift
# directions `sh` span, in the metric of the regression (weights `w`, one per
# coefficient): the share of the candidate's weighted energy that its weighted
# least-squares projection on the shifts takes up, and the inputs whose shifts
# carry at least a quarter as much of the projection as the largest, largest
# first. A data frame, one row per candidate; NULL without candidates or
# shifts.
shift_absorption <- function(cand, sh, w) {
  if (!ncol(cand) || !ncol(sh)) return(NULL)
  sw <- sqrt(w)
  A <- sh * sw
  qa <- qr(A)
  size <- sqrt(colSums(A^2))
  rows <- lapply(colnames(cand), function(k) {
    y <- cand[, k] * sw
    share <- sum(qr.fitted(qa, y)^2) / sum(y^2)
    beta <- qr.coef(qa, y)
    beta[is.na(beta)] <- 0
    contrib <- abs(beta) * size
    by <- order(contrib, decreasing = TRUE)
    by <- by[contrib[by] >= 0.25 * max(contrib)]
    data.frame(candidate = k, absorbed = min(1, share),
               inputs = paste(sub("^shift:", "", colnames(sh)[by]), collapse = ", "))
  })
  do.call(rbind, rows)
}
