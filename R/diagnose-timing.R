# --- the timing of the field's events against the model's ---------------------
#
# Registration moves every replicate's landmarks onto the reference's, so a
# difference of timing between reality and the model (a lag, a rate that
# moves an event) leaves no trace in the registered field mean: the bias
# cannot show it. The landmarks themselves keep it. For each landmark of the
# registration, the field's time is the mean of the replicates' times (before
# registration), with the sampling error their scatter gives it (Student t on
# R - 1 degrees of freedom); the model's time at the calibrated inputs comes
# from the same landmark found on every model run, regressed on the runs'
# inputs (a quadratic in each input, or linear when the runs are few), taken
# at each posterior draw, with the regression's residual error. The
# difference is a finding when its central interval at the level
# 1 - (1 - level) / K, K the landmarks read, excludes zero (the K readings
# together hold the family's error at 1 - level).

# The landmarks' timing of a fit registered to model runs: a data frame with
# one row per landmark (site, window, feature, field and model times, the
# shift field - model with its interval, the size the shift makes in the
# curve and the size credible, flagged), or NULL when the fit's field was
# not registered by validate() or has fewer than two replicates.
timing_table <- function(fit, level = 0.9) {
  w <- fit_get(fit, "field")$warps
  runs <- fit_pipeline(fit)$runs
  if (is.null(w) || !inherits(runs, "wv_runs") || !identical(runs$t, fit_get(fit, "field")$t))
    return(NULL)
  lw <- w[w$feature != "fitted", , drop = FALSE]
  if (!nrow(lw)) return(NULL)
  st <- attr(w, "landmark_settings") %||%
    list(features = check_features(fit_controls(fit)$registration$features %||% c("min", "max")),
         refine = FALSE)
  windows <- attr(w, "windows")
  t <- fit_get(fit, "field")$t
  keys <- unique(lw[, c("site", "window", "feature")])
  X <- timing_inputs(fit, runs)
  if (is.null(X)) return(NULL)
  rows <- list()
  for (m in unique(keys$site)) {
    if (!m %in% names(runs$curves)) next
    i_m <- which(keys$site == m)
    times <- landmark_times(runs$curves[[m]], t, windows, st$features, st$refine,
                            keys$window[i_m], keys$feature[i_m])
    for (j in seq_along(i_m)) {
      i <- i_m[j]
      L <- lw$t_before[lw$site == m & lw$window == keys$window[i] & lw$feature == keys$feature[i]]
      L <- L[is.finite(L)]
      tr <- times[j, ]
      if (length(L) < 2L || sum(is.finite(tr)) < 5L) next
      rows[[length(rows) + 1L]] <- c(list(site = m, window = keys$window[i],
                                          feature = keys$feature[i]),
                                     timing_shift(L, tr, X$design, X$draws))
    }
  }
  if (!length(rows)) return(NULL)
  out <- do.call(rbind, lapply(rows, function(r)
    as.data.frame(r[c("site", "window", "feature", "field", "model", "shift")],
                  stringsAsFactors = FALSE)))
  K <- length(rows)
  a <- (1 - level) / K / 2
  lim <- t(vapply(rows, function(r) stats::quantile(r$draws, c(a, 1 - a), names = FALSE),
                  numeric(2)))
  out$lower <- lim[, 1]
  out$upper <- lim[, 2]
  out$flagged <- out$lower > 0 | out$upper < 0
  # what the shift makes in the curve near the event: the largest change of
  # the site's registered field mean moved by it
  ybar <- lapply(fit_get(fit, "field")$curves, colMeans)
  near <- mapply(function(m, w, f) lw$t_after[lw$site == m & lw$window == w & lw$feature == f][1],
                 out$site, out$window, out$feature)
  out$size <- mapply(function(m, t0, d) shift_size(ybar[[m]], t, t0, d), out$site, near, out$shift)
  closest <- ifelse(out$flagged, ifelse(out$shift > 0, out$lower, out$upper), 0)
  out$credible <- mapply(function(m, t0, d) shift_size(ybar[[m]], t, t0, d), out$site, near,
                         closest)
  attr(out, "level") <- level
  rownames(out) <- NULL
  out
}

# The inputs of the runs' regression and of the posterior draws: the runs'
# design columns that vary, the draws of those the fit samples and the
# fit's value of the others. NULL when the runs' design lacks an input.
timing_inputs <- function(fit, runs) {
  D <- runs$design
  if (is.null(D)) return(NULL)
  vary <- names(D)[vapply(D, function(v) is.numeric(v) && stats::sd(v) > 0, logical(1))]
  draws <- fit_draws_matrix(fit)
  P <- matrix(NA_real_, nrow(draws), length(vary), dimnames = list(NULL, vary))
  x_nom <- fit_get(fit, "x_nom")
  for (p in vary) {
    P[, p] <-
      if (p %in% colnames(draws)) draws[, p] else if (p %in% names(x_nom)) x_nom[[p]] else NA_real_
  }
  if (anyNA(P)) return(NULL)
  list(design = as.data.frame(D[vary]), draws = as.data.frame(P))
}

# One landmark: the field's times L (one per replicate), the runs' times tr
# (NA where a run lacks it), the runs' inputs D and the posterior draws P.
# The draws of field - model: the model's time at each draw plus the
# regression's residual error, the field's mean plus its sampling error.
timing_shift <- function(L, tr, D, P) {
  ok <- is.finite(tr)
  D <- D[ok, , drop = FALSE]
  y <- tr[ok]
  terms <- names(D)
  if (nrow(D) > 2L * length(terms) + 6L) terms <- c(terms, sprintf("I(%s^2)", names(D)))
  fit <- stats::lm(stats::reformulate(terms, "y"), data = cbind(D, y = y))
  res_sd <- max(stats::sigma(fit), 0)
  pred <- stats::predict(fit, P)
  R <- length(L)
  n <- length(pred)
  draws <- withr::with_seed(1L, {
    mean(L) - pred - res_sd * stats::rnorm(n) + stats::sd(L) / sqrt(R) * stats::rt(n, R - 1L)
  })
  list(field = mean(L), model = mean(pred), shift = mean(draws), draws = draws)
}

# The largest change a shift d makes in the curve y near t0: max over t
# within 3 |d| (and a grid step) of t0 of |y(t) - y(t - d)|.
shift_size <- function(y, t, t0, d) {
  if (!is.finite(d) || d == 0) return(0)
  reach <- 3 * abs(d) + diff(t[1:2])
  tt <- t[abs(t - t0) <= reach]
  max(abs(stats::approx(t, y, tt, rule = 2)$y - stats::approx(t, y, tt - d, rule = 2)$y))
}
