# The noise evidence field_runs() keeps from measured curves: the values
# averaged by time stamp and their scatter, the difference-based noise sd on
# the stamps, the map from the stamps onto the grid, and the points recovered
# as measured from a curve that was linearly interpolated before it came in.

# The noise evidence of one site's curves (rows) measured at `t` (stamps may
# repeat) and put on `grid`: the values averaged by stamp, their scatter (ss,
# df), the difference-based noise sd of the averaged curves on the stamps
# (detail_sd) and their difference residuals as data on the noise variance
# (detail_ss, detail_df: difference_evidence()), and
# the linear map from the stamps to `grid` (interpolation, held at the ends) with
# the variance factor 1 / (number of values) of each stamp.
measurement_noise <- function(m, t, stamps, grid) {
  k <- match(t, stamps)
  n_at <- tabulate(k, length(stamps))
  averaged <- t(apply(m, 1L, function(y) as.vector(rowsum(y, k, reorder = TRUE)) / n_at))
  if (nrow(m) == 1L) averaged <- matrix(averaged, nrow = 1L)
  ss <- sum((m - averaged[, k, drop = FALSE])^2)
  df <- as.numeric(nrow(m) * (length(t) - length(stamps)))
  lo <- findInterval(grid, stamps, all.inside = TRUE)
  w <- (grid - stamps[lo]) / (stamps[lo + 1L] - stamps[lo])
  w <- pmin(pmax(w, 0), 1)
  detail <-
    if (length(stamps) >= 5L) difference_evidence(averaged, stamps, 1 / n_at) else c(ss = 0, df = 0)
  list(averaged = averaged, ss = ss, df = df, n_stamps = length(stamps),
       n_repeated = sum(n_at > 1L),
       detail_sd = detail_noise_sd(averaged, stamps, 1 / n_at),
       detail_ss = detail[["ss"]], detail_df = detail[["df"]],
       map = list(lo = lo, w = w, var = 1 / n_at))
}

# The noise sd of curves (rows) at unequally spaced times, from each inner
# point's deviation from the line through its neighbours, scaled by its
# variance under white noise (`var`: each point's variance in units of
# sigma2), robustly: MAD / 0.6745, the mean over rows.
detail_noise_sd <- function(Y, t, var) {
  mean(apply(Y, 1L, function(y) difference_residuals(y, t, var)$sd))
}

# The points' difference residuals of one curve `y` at the stamps `t` (each
# value's variance `var` in units of sigma2), at the inner points `i`: each
# point's deviation from the line through its neighbours scaled to variance
# sigma2 under white noise (e), their lag-1 and lag-2 correlations (r1, r2:
# those of e[k] with e[k + 1] and e[k + 2] when those are the next points,
# else 0) and the MAD-based sd.
difference_residuals <- function(y, t, var, i = seq(2L, length(t) - 1L)) {
  a <- (t[i + 1L] - t[i]) / (t[i + 1L] - t[i - 1L])
  b <- 1 - a
  f <- var[i] + a^2 * var[i - 1L] + b^2 * var[i + 1L]
  e <- (y[i] - a * y[i - 1L] - b * y[i + 1L]) / sqrt(f)
  m <- length(i)
  lag <- function(k, gap, cov) {
    if (m <= k) return(numeric(0))
    j <- seq_len(m - k)
    ifelse(i[j + k] - i[j] == gap, cov(j, j + k), 0)
  }
  # e at point i and at i + 1 share y[i] and y[i + 1]; at i and i + 2, y[i + 1]
  r1 <- lag(1L, 1L, function(j, k) -(a[k] * var[i[j]] + b[j] * var[i[k]]) / sqrt(f[j] * f[k]))
  r2 <- lag(2L, 2L, function(j, k) b[j] * a[k] * var[i[j] + 1L] / sqrt(f[j] * f[k]))
  list(e = e, r1 = r1, r2 = r2, sd = stats::mad(e, center = 0))
}

# The residuals' squares are capped at this many MAD-based sds (a point where
# the curve bends sharply, or a misread point, counts as if it lay there) ...
difference_cap <- 3
# ... which keeps this share of the efficiency of the plain sum of squares
# (simulated for white noise at uneven stamps, 13 to 98 residuals: 0.97 to
# 0.99).
difference_efficiency <- 0.95

# The difference residuals of curves (rows) as data on the noise variance,
# ss / sigma2 ~ chi^2_df: each row's squared residuals (capped at
# difference_cap MAD-based sds) over their expectation under the cap,
# with Satterthwaite's degrees of freedom for correlated residuals of
# variance sigma2, m^2 / (m + 2 sum r1^2 + 2 sum r2^2) (m residuals; at even
# stamps r1 = -2/3, r2 = 1/6, so about m / 1.94), times
# difference_efficiency, summed over rows. Where the true curve bends
# between the stamps its residuals hold that too: the evidence is an upper
# bound of the noise rather than its estimate. ss = df = 0 when a row's MAD
# is 0 or it has fewer than 3 residuals.
difference_evidence <- function(Y, t, var, i = seq(2L, length(t) - 1L)) {
  c2 <- difference_cap^2
  expected <-
    (2 * stats::pnorm(difference_cap) - 1) - 2 * difference_cap * stats::dnorm(difference_cap) +
    c2 * 2 * stats::pnorm(-difference_cap)
  out <- c(ss = 0, df = 0)
  for (r in seq_len(nrow(Y))) {
    d <- difference_residuals(Y[r, ], t, var, i)
    m <- length(d$e)
    if (m < 3L || !(d$sd > 0)) next
    df <- difference_efficiency * m^2 / (m + 2 * sum(d$r1^2) + 2 * sum(d$r2^2))
    out <- out + c(ss = df * mean(pmin(d$e^2, c2 * d$sd^2)) / expected, df = df)
  }
  out
}

# The noise variance of each retained coefficient of a curve resampled by
# `map` (measurement_noise()), in units of the variance of one measurement:
# diag(Psi' A D A' Psi), A the interpolation, D the stamps' variance factors.
# `map` may be a list of such maps, one per replicate on its own stamps: the
# mean of their multipliers is the noise of the replicates' mean (times R).
resampled_noise_multipliers <- function(map, Psi) {
  if (is.null(map$lo)) {
    return(rowMeans(matrix(vapply(map, resampled_noise_multipliers, numeric(ncol(Psi)), Psi = Psi),
                           ncol(Psi))))
  }
  n_s <- length(map$var)
  B <- rowsum(Psi * (1 - map$w), map$lo, reorder = TRUE)
  hi <- rowsum(Psi * map$w, map$lo + 1L, reorder = TRUE)
  A_t_Psi <- matrix(0, n_s, ncol(Psi))
  A_t_Psi[as.integer(rownames(B)), ] <- B
  A_t_Psi[as.integer(rownames(hi)), ] <- A_t_Psi[as.integer(rownames(hi)), ] + hi
  colSums(A_t_Psi^2 * map$var)
}


# --- curves interpolated before they came in ---------------------------------

# A curve is read as linearly interpolated when its second differences vanish
# (relative to its largest value) on a slope (not on a flat stretch) at this
# share of its inner points, and at least 3: measured noise never puts three
# values exactly on a line, and a flat stretch may have been measured so (a
# saturated sensor, a record before the load).
interpolated_share <- 0.05
# ... and as exactly on a line within this tolerance, relative to max |y|
# (the rounding of the interpolation and of a file written with 10 digits; a
# smooth curve on a fine grid has second differences well above it but near
# its inflections).
interpolated_tol <- 1e-9
# A point is on a slope when its neighbours differ by more than this, relative
# to max |y|: a thousand times the tolerance, so that the tail of a smooth
# curve that levels off (second differences tiny, but a fixed share of the
# first) is not read as a line.
interpolated_slope <- 1e-6
# The fewest residuals of measured points that estimate their noise, and the
# least share of the points read as measured that must be told exactly (where
# measured points lie closer than about two grid steps, the curve on the grid
# has lost them).
interpolated_min_residuals <- 8L
interpolated_min_exact <- 0.5

# The points of a curve (y at the increasing times x) that a linear
# interpolation went through, or NULL when the curve is not piecewise linear.
# Points on the line through their two neighbours are interior to a linear
# piece; the others are breakpoints, and the curve is the linear
# interpolation of its breakpoints. Two neighbouring pieces that each hold a
# point on their line meet at a measured point: the breakpoint they share, or
# the crossing of their lines when it lies between the grid points around it
# (`exact`). Where measured points are closer than two grid steps they cannot
# be told apart and the breakpoints there stand for them (`exact = FALSE`).
interpolation_knots <- function(x, y) {
  n <- length(x)
  if (n < 5L) return(NULL)
  i <- seq(2L, n - 1L)
  a <- (x[i + 1L] - x[i]) / (x[i + 1L] - x[i - 1L])
  e <- y[i] - a * y[i - 1L] - (1 - a) * y[i + 1L]
  tol <- interpolated_tol * max(abs(y))
  on_line <- c(FALSE, abs(e) <= tol, FALSE)
  sloped <- c(FALSE, abs(y[i + 1L] - y[i - 1L]) > interpolated_slope * max(abs(y)), FALSE)
  if (sum(on_line & sloped) < max(3, interpolated_share * (n - 2))) return(NULL)
  bp <- which(!on_line)
  long <- which(diff(bp) >= 2L)
  slope <- function(k) (y[bp[k + 1L]] - y[bp[k]]) / (x[bp[k + 1L]] - x[bp[k]])
  first <- bp[long[1]]
  kx <- x[seq_len(first)]
  ky <- y[seq_len(first)]
  exact <- seq_len(first) == 1L
  add <- function(px, py, ex) {
    kx <<- c(kx, px)
    ky <<- c(ky, py)
    exact <<- c(exact, rep_len(ex, length(px)))
  }
  for (j in seq_along(long)[-1L]) {
    p <- bp[long[j - 1L] + 1L]
    q <- bp[long[j]]
    if (q == p) {
      add(x[p], y[p], TRUE)
      next
    }
    if (q - p == 1L) {
      s1 <- slope(long[j - 1L])
      s2 <- slope(long[j])
      xs <- (y[q] - y[p] + s1 * x[p] - s2 * x[q]) / (s1 - s2)
      if (is.finite(xs) && xs > x[p] && xs < x[q]) {
        add(xs, y[p] + s1 * (xs - x[p]), TRUE)
        next
      }
    }
    add(x[p:q], y[p:q], FALSE)
  }
  last <- bp[long[length(long)] + 1L]
  add(x[last:n], y[last:n], last:n == n)
  keep <- !duplicated(kx)
  list(x = kx[keep], y = ky[keep], exact = exact[keep], n_breakpoints = length(bp), n_points = n)
}

# The difference-based noise sd (as detail_noise_sd(), one curve, each value
# measured once) from the residuals of the points that are exact together
# with both neighbours, and those residuals as data on the noise variance
# (difference_evidence(): ss, df); all 0 when fewer than
# interpolated_min_residuals, or fewer than interpolated_min_exact of the
# points are exact. knots_noise_sd(): the sd alone.
knots_noise_sd <- function(kn) knots_noise_evidence(kn)$sd
knots_noise_evidence <- function(kn) {
  none <- list(sd = 0, ss = 0, df = 0)
  n <- length(kn$x)
  if (mean(kn$exact) < interpolated_min_exact) return(none)
  i <- seq(2L, n - 1L)
  i <- i[kn$exact[i] & kn$exact[i - 1L] & kn$exact[i + 1L]]
  if (length(i) < interpolated_min_residuals) return(none)
  var <- rep(1, n)
  ev <- difference_evidence(matrix(kn$y, nrow = 1L), kn$x, var, i)
  list(sd = difference_residuals(kn$y, kn$x, var, i)$sd, ss = ev[["ss"]], df = ev[["df"]])
}

# The noise evidence of one curve (y at the non-decreasing stamps t) put on
# `grid`: measurement_noise() on its own stamps, or, when it is piecewise
# linear without repeated stamps, on the points recovered as measured (with
# `interpolated`: how many, and whether they estimate the noise).
curve_evidence <- function(y, t, grid) {
  stamps <- unique(t)
  ev <- measurement_noise(matrix(y, nrow = 1L), t, stamps, grid)
  kn <- if (length(stamps) == length(t)) interpolation_knots(t, y)
  if (is.null(kn)) return(ev)
  averaged <- ev$averaged
  ev <- measurement_noise(matrix(kn$y, nrow = 1L), kn$x, kn$x, grid)
  ev$averaged <- averaged
  kev <- knots_noise_evidence(kn)
  ev$detail_sd <- kev$sd
  ev$detail_ss <- kev$ss
  ev$detail_df <- kev$df
  ev$interpolated <- list(n_points = kn$n_points, n_breakpoints = kn$n_breakpoints,
                          n_measured = length(kn$x),
                          n_exact = sum(kn$exact), resolved = ev$detail_sd > 0)
  ev
}

# One site's noise evidence from the evidence of each of its curves: the
# scatter of repeated stamps and the difference residuals' (ss, df) summed,
# the detail sd averaged over the curves
# that estimate it (0 when none does), one map or, when the curves' maps
# differ, the list of them.
site_evidence <- function(evs) {
  evs <- lapply(evs, function(ev) {
    ev$averaged <- NULL
    ev
  })
  if (length(evs) == 1L) return(evs[[1]])
  sds <- vapply(evs, function(ev) ev$detail_sd, numeric(1))
  maps <- lapply(evs, function(ev) ev$map)
  out <- list(ss = sum(vapply(evs, function(ev) ev$ss, numeric(1))),
              df = sum(vapply(evs, function(ev) ev$df, numeric(1))),
              n_stamps = sum(vapply(evs, function(ev) ev$n_stamps, integer(1))),
              n_repeated = sum(vapply(evs, function(ev) ev$n_repeated, integer(1))),
              detail_sd = if (any(sds > 0)) mean(sds[sds > 0]) else 0,
              detail_ss = sum(vapply(evs, function(ev) ev$detail_ss %||% 0, numeric(1))),
              detail_df = sum(vapply(evs, function(ev) ev$detail_df %||% 0, numeric(1))),
              map = if (all(vapply(maps, identical, logical(1), maps[[1]]))) maps[[1]] else maps)
  interp <- lapply(evs, function(ev) ev$interpolated)
  if (any(!vapply(interp, is.null, logical(1)))) out$interpolated <- interp
  out
}

# Says which sites' curves were read as interpolated before they came in: a
# message where the measured points estimate the noise, a warning where they
# cannot (the noise is then not learned from the curve: see field_runs()).
report_interpolated <- function(noise) {
  for (s in names(noise)) {
    interp <- noise[[s]]$interpolated
    if (is.null(interp)) next
    if (!is.null(interp$n_points)) interp <- list(interp)
    interp <- interp[!vapply(interp, is.null, logical(1))]
    n_pts <- vapply(interp, function(z) z$n_points, integer(1))
    n_meas <- vapply(interp, function(z) z$n_measured, integer(1))
    what <- "{cli::qty(length(interp))}Site {.val {s}}: {length(interp)} curve{?s} {?is/are} piecewise linear (interpolated before {?it/they} came in): {sum(n_meas)} point{?s} of {sum(n_pts)} read as measured."
    if (noise[[s]]$detail_sd > 0) {
      wv_inform(c("i" = what, " " = "The noise evidence is taken from the measured points (difference-based sd {signif(noise[[s]]$detail_sd, 3)}), not from the interpolated curve."),
                class = "interpolated")
    } else {
      wv_warn(c("!" = what,
                "x" = "Too few measured points can be told from the curve to estimate its noise: the interpolated curve holds no noise below its own resolution.",
                "i" = "With one replicate, give the noise: {.code bias_control(sigma2 = noise_prior(scale = ))} with the instrument's noise sd, or the curves on their own time stamps."),
              class = "interpolated")
    }
  }
  invisible(noise)
}

# How much the replicates' spread changes along the record, by site (sites
# with two replicates or more): the root mean square of the pointwise
# replicate sd over blocks of max(8, T / 32) points, and the ratio of its
# largest to its smallest block (the smallest held above 1e-8 of the
# largest). NULL when no site has two replicates.
spread_along_record <- function(field) {
  out <- lapply(names(field$curves), function(s) {
    Y <- field$curves[[s]]
    if (nrow(Y) < 2L) return(NULL)
    v <- apply(Y, 2L, stats::var)
    n <- length(v)
    L <- max(8L, n %/% 32L)
    block <- ceiling(seq_len(n) / L)
    rms <- sqrt(tapply(v, block, mean))
    hi <- max(rms)
    lo <- max(min(rms), 1e-8 * hi)
    k_hi <- which.max(rms)
    k_lo <- which.min(rms)
    t <- field$t
    data.frame(site = s, ratio = hi / lo, largest = hi, smallest = min(rms),
               at_largest = mean(t[block == k_hi]), at_smallest = mean(t[block == k_lo]),
               stringsAsFactors = FALSE)
  })
  out <- do.call(rbind, out)
  if (is.null(out)) NULL else out
}

# A sentence on the sites whose replicates' spread changes more than
# tenfold along the record, or NULL.
spread_text <- function(sp, what = "replicates") {
  if (is.null(sp)) return(NULL)
  big <- sp[sp$ratio > 10, , drop = FALSE]
  if (!nrow(big)) return(NULL)
  f <- function(v) format(signif(v, 3), trim = TRUE)
  paste0(sprintf("the %s' spread changes %s-fold along the record at %s (sd %s near t = %s, %s near t = %s)",
                 what, f(big$ratio), big$site, f(big$largest), f(big$at_largest), f(big$smallest),
                 f(big$at_smallest)), collapse = "; ")
}
