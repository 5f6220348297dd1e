# Landmarks of the curves and the warps through them, for register_curves()
# (R/register.R).

# Landmarks of one curve: one row per (window, feature), ordered by time within
# each window. `features` is check_features()'s: the names, with the level
# crossed by "cross" as its attribute "cross".
curve_landmarks <- function(y, t, windows, features, refine = FALSE) {
  cross <- attr(features, "cross")
  out <- lapply(seq_along(windows), function(w) {
    idx <- which(t >= windows[[w]][1] & t <= windows[[w]][2])
    tt <- t[idx]
    yy <- y[idx]
    at <- vapply(features, function(f) {
      switch(f,
             min = extremum_at(tt, -yy, refine),
             max = extremum_at(tt, yy, refine),
             rise = steepest_at(tt, yy, refine),
             fall = steepest_at(tt, -yy, refine),
             cross = crossing_at(tt, yy, cross, refine, w))
    }, numeric(1))
    data.frame(window = w, feature = as.character(features), t = unname(at),
               stringsAsFactors = FALSE)
  })
  out <- do.call(rbind, out)
  out[order(out$window, out$t), , drop = FALSE]
}

# Location of the steepest rise of y on the grid tt: the largest central
# difference (y[i + 1] - y[i - 1]) / (tt[i + 1] - tt[i - 1]) at the interior
# grid points, refined as extremum_at() refines a maximum, on the slopes.
steepest_at <- function(tt, y, refine = FALSE) {
  n <- length(y)
  if (n < 3L) return(tt[which.max(diff(c(y, y[n])))])
  i <- seq(2L, n - 1L)
  slope <- (y[i + 1L] - y[i - 1L]) / (tt[i + 1L] - tt[i - 1L])
  extremum_at(tt[i], slope, refine)
}

# Time of the first crossing of a level by y on the grid tt, either way: the
# first grid point at which y - level has changed sign from its value at the
# start of the window (or is zero); with refine, the time between that point
# and the one before at which the straight line between them crosses the
# level. The level is `cross$value`, or the fraction `cross$fraction` of the
# way from the smallest to the largest value of y in the window.
crossing_at <- function(tt, y, cross, refine = FALSE, window = NA, call = rlang::caller_env()) {
  level <- cross$value %||% (min(y) + cross$fraction * (max(y) - min(y)))
  d <- y - level
  side <- sign(d[1])
  k <- if (side == 0) 1L else which(sign(d) != side)[1]
  if (is.na(k)) {
    wv_abort(c(
      "A curve does not cross the level {signif(level, 4)} in window {window}.",
      "x" = "It stays between {signif(min(y), 4)} and {signif(max(y), 4)} there.",
      "i" = "Widen the window around the event, or give a value it crosses with {.arg cross_value} or {.arg cross_fraction}."
    ), call = call)
  }
  if (!refine || k == 1L || d[k] == 0) return(tt[k])
  tt[k - 1L] + (tt[k] - tt[k - 1L]) * d[k - 1L] / (d[k - 1L] - d[k])
}

# Location of the maximum of y on the grid tt; with refine, refined between
# grid points by the vertex of the parabola through the grid maximum and its
# two neighbours (at most half a grid step away; the grid point itself at the
# ends of tt).
extremum_at <- function(tt, y, refine = FALSE) {
  i <- which.max(y)
  if (!refine || i == 1L || i == length(y)) return(tt[i])
  curv <- y[i - 1L] - 2 * y[i] + y[i + 1L]
  if (!(curv < 0)) return(tt[i])
  off <- 0.5 * (y[i - 1L] - y[i + 1L]) / curv
  off <- max(-0.5, min(0.5, off))
  tt[i] + off * if (off >= 0) tt[i + 1L] - tt[i] else tt[i] - tt[i - 1L]
}

# The spread of the reference's landmarks: for each landmark of `ref_lm` (the
# landmarks of the mean of the runs Y), the standard deviation of the same
# landmark's time over the runs (rows of Y). Runs whose landmarks come in
# another order in a window leave that window out.
landmark_spread <- function(Y, t, windows, features, refine, ref_lm, site) {
  times <- landmark_times(Y, t, windows, features, refine, ref_lm$window, ref_lm$feature)
  data.frame(site = site, window = ref_lm$window, feature = ref_lm$feature, t_after = ref_lm$t,
             sd = if (ncol(times) > 1L) apply(times, 1L, stats::sd) else rep(0, nrow(ref_lm)),
             stringsAsFactors = FALSE)
}

# The times of the landmarks named by (window, feature) in every curve (row)
# of Y: a matrix with one row per landmark and one column per curve, NA
# where a curve lacks the landmark.
landmark_times <- function(Y, t, windows, features, refine, window, feature) {
  key <- paste(window, feature)
  times <- vapply(seq_len(nrow(Y)), function(k) {
    lm <- curve_landmarks(Y[k, ], t, windows, features, refine)
    lm$t[match(key, paste(lm$window, lm$feature))]
  }, numeric(length(key)))
  matrix(times, nrow = length(key))
}

# Knots (before -> after) of the warp of one replicate, checked for
# monotonicity. In a window where the replicate's landmarks come in another
# order than the reference's (a change of shape at the event: a dip that the
# model puts before the peak and reality after it), the warp is tied to the
# largest set of the window's landmarks that keep the reference's order, and
# of those the set nearest the reference's times; `keep` marks the rows of
# `ref_lm` used and `t_rep` gives the replicate's time of each of them.
warp_knots_from <- function(rep_lm, ref_lm, t, site, replicate, call = rlang::caller_env()) {
  key <- function(d) paste(d$site %||% "", d$window, d$feature)
  t_rep <- rep_lm$t[match(key(ref_lm), key(rep_lm))]
  keep <- !is.na(t_rep)
  for (w in unique(ref_lm$window)) {
    i <- which(ref_lm$window == w & keep)
    if (length(i)) keep[i] <- ordered_landmarks(ref_lm$t[i], t_rep[i])
  }
  before <- c(t[1], t_rep[keep], t[length(t)])
  after <- c(t[1], ref_lm$t[keep], t[length(t)])
  keep_knot <- !(duplicated(before) & duplicated(after))
  before <- before[keep_knot]
  after <- after[keep_knot]
  if (any(diff(before) <= 0) || any(diff(after) <= 0)) {
    wv_abort(c(
      "The warp of replicate {replicate} (site {.val {site}}) is not monotone.",
      "x" = "A landmark sits on the end of the grid in the replicate but not in the reference (or the reverse).",
      "i" = "Move the windows away from the ends of the grid."
    ), call = call)
  }
  list(before = before, after = after, keep = keep, t_rep = t_rep)
}

# The warning for landmarks left out of the warps: which replicates, windows
# and features, and what it means.
warn_left_out <- function(left_out, n_rep) {
  wv_warn(c(
    "Landmarks came in another order than the reference's and were left out of the warps: {left_out_summary(left_out, n_rep)}.",
    "i" = "Each such window is registered on its landmarks that keep the reference's order (those nearest its times).",
    "i" = "A shape that differs from the model's at an event is a finding in itself: look at those replicates in that window ({.code attr(field$warps, \"left_out\")}), or choose the {.arg features} that mark the event in both."
  ), class = "landmarks")
}

# Which of one window's landmarks tie the warp: all of them when the
# replicate's times (t_rep) come in the order of the reference's (t_ref),
# strictly; otherwise the largest subset that does, the one with the smallest
# total distance between the two times among subsets of that size.
ordered_landmarks <- function(t_ref, t_rep) {
  n <- length(t_ref)
  in_order <- function(k) {
    o <- order(t_ref[k])
    !anyDuplicated(t_ref[k]) && !is.unsorted(t_rep[k][o], strictly = TRUE)
  }
  if (in_order(seq_len(n))) return(rep(TRUE, n))
  best <- NULL
  best_cost <- Inf
  for (size in rev(seq_len(n - 1L))) {
    for (k in utils::combn(n, size, simplify = FALSE)) {
      if (!in_order(k)) next
      cost <- sum(abs(t_rep[k] - t_ref[k]))
      if (cost < best_cost) { best <- k; best_cost <- cost }
    }
    if (!is.null(best)) break
  }
  seq_len(n) %in% best
}
