# --- variance of the registered field mean from the reference's landmarks ------
#
# Landmark registration moves each replicate's landmarks onto those of the
# reference, the mean of the model runs. The model at the true inputs has its
# landmarks somewhere else: the landmark times of the runs vary with their
# inputs. An error delta_k in the time of the reference's landmark k moves the
# registered field mean by about -delta_k h_k(t) ybar'(t), h_k the hat function
# that is 1 at the landmark and 0 at its neighbouring knots (the warp is linear
# in between). With delta_k of standard deviation sd_k, the spread of that
# landmark over the runs, coefficient i of the registered mean gets the
# variance sum_k sd_k^2 (Psi' h_k ybar')_i^2 (the landmarks' errors taken
# independent, and each coefficient on its own as the sampler takes them).

# Named list by site of the variances (one per coefficient of `basis`), or
# NULL when the field was not registered to model runs.
registration_extra_variance <- function(field, basis) {
  cols <- registration_landmark_columns(field, names(field$curves))
  if (is.null(cols)) return(NULL)
  lapply(cols$H, function(H) {
    v <- numeric(ncol(basis$Psi))
    for (k in seq_along(cols$sd)) {
      if (!any(H[, k] != 0)) next
      v <- v + cols$sd[k]^2 * drop(basis_coef(basis, H[, k]))^2
    }
    v
  })
}

# The first-order effect of each of the reference's landmarks on the
# registered field mean: for landmark k, its hat function h_k times the field
# mean's slope, a column of a T x K matrix for each site in `sites` (zero at
# the sites the landmark does not act on; a landmark shared by the sites acts
# on all of them), and sd_k, its spread over the runs. Landmarks with no
# spread or on the edge of the knots are left out. NULL when the field was not
# registered to model runs.
registration_landmark_columns <- function(field, sites) {
  w <- field$warps
  spread <- if (is.null(w)) NULL else attr(w, "landmark_sd")
  if (is.null(spread)) return(NULL)
  t <- field$t
  slope <- lapply(field$curves[sites], function(Y) grid_slope(colMeans(Y), t))
  shared <- !is.na(attr(w, "landmark_site"))
  H <- stats::setNames(lapply(sites, function(s) matrix(0, length(t), 0L)), sites)
  sd <- numeric(0)
  for (m in unique(spread$site)) {
    lm <- spread[spread$site == m, , drop = FALSE]
    targets <- if (shared) intersect(attr(w, "sites"), sites) else m
    first <- min(w$replicate[w$site == m])
    after <- sort(unique(warp_knots(w, first, site = m)$after))
    for (k in seq_len(nrow(lm))) {
      if (!(lm$sd[k] > 0)) next
      j <- which.min(abs(after - lm$t_after[k]))
      if (j == 1L || j == length(after)) next
      h <- stats::approx(after[(j - 1L):(j + 1L)], c(0, 1, 0), xout = t, rule = 2)$y
      h[t < after[j - 1L] | t > after[j + 1L]] <- 0
      sd <- c(sd, lm$sd[k])
      for (s in sites) H[[s]] <- cbind(H[[s]], if (s %in% targets) h * slope[[s]] else 0 * t)
    }
  }
  list(H = H, sd = sd)
}

# Slope of a curve on its grid: central differences, one-sided at the ends.
grid_slope <- function(y, t) {
  n <- length(y)
  d <- numeric(n)
  d[2:(n - 1L)] <- (y[3:n] - y[1:(n - 2L)]) / (t[3:n] - t[1:(n - 2L)])
  d[1] <- (y[2] - y[1]) / (t[2] - t[1])
  d[n] <- (y[n] - y[n - 1L]) / (t[n] - t[n - 1L])
  d
}

# The variance of the registered field mean from the registration's own error
# (register_curves()'s `registration_check`: what registering changed in the
# model runs nearest the field): by site, the mean square of the change's
# coefficients, over the checked runs and the coefficients of `basis`, for
# every coefficient. NULL when the field carries no check.
registration_check_variance <- function(field, basis) {
  chk <- field$registration_check
  if (is.null(chk)) return(NULL)
  sites <- names(field$curves)
  if (!all(sites %in% names(chk))) return(NULL)
  stats::setNames(lapply(sites, function(s) {
    E <- basis_coef(basis, chk[[s]])
    rep(mean(E^2), ncol(E))
  }), sites)
}

# The registration's own error as shifts of the reference's landmarks: the
# first-order change a shift delta_k of landmark k makes in the registered
# field mean, h_k ybar' (registration_landmark_columns()), in coefficients,
# a column of U by site; the shifts' variances from the check (what
# registering did to the model runs nearest the field): each checked run's
# change regressed on the columns, the mean square of its shifts; what the
# shifts leave of the change, its mean square by site, as the per-coefficient
# variance beyond them. A list (U by site, var, extra by site), or NULL when
# the field carries no check or no landmark with a spread.
registration_shift_structure <- function(field, basis) {
  chk <- field$registration_check
  sites <- names(field$curves)
  if (is.null(chk) || !all(sites %in% names(chk))) return(NULL)
  cols <- registration_landmark_columns(field, sites)
  if (is.null(cols) || !length(cols$sd)) return(NULL)
  U <- lapply(cols$H[sites], function(H) t(basis_coef(basis, t(H))))
  E <- lapply(sites, function(s) basis_coef(basis, chk[[s]]))
  # every checked run's change, all sites together, on the stacked columns
  delta <- t(qr.coef(qr(do.call(rbind, U)), t(do.call(cbind, E))))
  delta[is.na(delta)] <- 0
  v <- colMeans(delta^2)
  extra <- stats::setNames(lapply(seq_along(sites), function(j) {
    rep(mean((E[[j]] - tcrossprod(delta, U[[j]]))^2), ncol(E[[j]]))
  }), sites)
  keep <- v > 0
  if (!any(keep)) return(NULL)
  list(U = lapply(stats::setNames(U, sites), function(u) u[, keep, drop = FALSE]), var = v[keep],
       extra = extra)
}
