# --- wv_warps class ------------------------------------------------------------

# The columns every wv_warps has, and its attributes.
warps_columns <- c("site", "replicate", "window", "feature", "t_before", "t_after")
warps_attributes <- c("range", "windows", "landmark_site", "sites", "landmark_sd", "left_out")

# landmark_sd: NULL, or a data frame with one row per landmark of the
# reference (site, window, feature, t_after) and `sd`, the standard deviation
# of that landmark's time over the model runs the reference averages.
new_wv_warps <- function(x, range, windows, landmark_site, sites, landmark_sd = NULL,
                         left_out = NULL) {
  rownames(x) <- NULL
  structure(x, range = range, windows = windows, landmark_site = landmark_site, sites = sites,
            landmark_sd = landmark_sd, left_out = left_out, class = c("wv_warps", "data.frame"))
}

# Rows or columns of a wv_warps keep its attributes while every column the
# class needs is there; otherwise the result is a plain data frame.
#' @export
`[.wv_warps` <- function(x, ...) {
  out <- NextMethod()
  if (!is.data.frame(out)) return(out)
  if (!all(warps_columns %in% names(out))) {
    class(out) <- "data.frame"
    return(out)
  }
  keep <- stats::setNames(lapply(warps_attributes, function(a) attr(x, a)), warps_attributes)
  lo <- keep$left_out
  if (!is.null(lo)) {
    lo <- lo[paste(lo$site, lo$replicate) %in% paste(out$site, out$replicate), , drop = FALSE]
    keep["left_out"] <- list(if (nrow(lo)) lo)
  }
  do.call(new_wv_warps, c(list(out), keep))
}

validate_wv_warps <- function(x, call = rlang::caller_env()) {
  miss <- setdiff(warps_columns, names(x))
  if (length(miss)) wv_abort("{.cls wv_warps} lacks column{?s} {.field {miss}}.", call = call,
                             class = "state")
  rg <- attr(x, "range")
  if (!is.numeric(rg) || length(rg) != 2L) wv_abort("{.cls wv_warps} needs a {.field range} attribute.", call = call,
                                                    class = "state")
  x
}

#' @export
print.wv_warps <- function(x, ...) {
  n_rep <- length(unique(x$replicate))
  ls <- attr(x, "landmark_site")
  lm <- x$feature != "fitted"
  shift <- abs(x$t_before - x$t_after)[lm]
  n_lm <- length(unique(paste(if (identical(ls, "all")) x$site else "", x$window, x$feature)[lm]))
  cli::cat_line(sprintf("<wv_warps> piecewise-linear warps of %d replicate%s, %d window%s, %d landmark%s each",
                        n_rep, if (n_rep == 1) "" else "s", length(attr(x, "windows")),
                        if (length(attr(x, "windows")) == 1) "" else "s", n_lm,
                        if (n_lm == 1) "" else "s"))
  if (any(!lm)) {
    n_fit <- sum(!lm) / max(1, length(unique(paste(x$site, x$replicate)[!lm])))
    cli::cat_line(sprintf("  plus %s knots per replicate fitted between the windows",
                          format(round(n_fit, 1))))
  }
  cli::cat_line(if (is.na(ls)) "  landmarks found on each site separately"
                else if (ls == "all") "  landmarks found on every site, one warp per replicate through them all, applied to all sites"
                else sprintf("  landmarks found on site %s, warps applied to all sites", ls))
  cli::cat_line(sprintf("  landmark shift: median %s, max %s",
                        format(signif(stats::median(shift), 3)),
                        format(signif(max(shift), 3))))
  lo <- attr(x, "left_out")
  if (!is.null(lo) && nrow(lo)) {
    cli::cat_line(sprintf("  left out, in another order than the reference's: %s",
                          left_out_summary(lo, n_rep)))
  }
  print(as.data.frame(unclass_warps(x)), row.names = FALSE)
  invisible(x)
}

# "the min of window 1 at 7 of 7 replicates (site1)", one phrase per site,
# window and feature left out.
left_out_summary <- function(lo, n_rep) {
  key <- unique(lo[c("site", "window", "feature")])
  n <- vapply(seq_len(nrow(key)), function(i) {
    sum(lo$site == key$site[i] & lo$window == key$window[i] & lo$feature == key$feature[i])
  }, integer(1))
  paste(sprintf("the %s of window %d at %d of %d replicates (%s)", key$feature, key$window, n,
                n_rep, key$site),
        collapse = "; ")
}

unclass_warps <- function(x) {
  for (a in warps_attributes) attr(x, a) <- NULL
  class(x) <- "data.frame"
  x
}

#' @export
as.data.frame.wv_warps <- function(x, ...) unclass_warps(x)

#' @export
summary.wv_warps <- function(object, ...) {
  d <- unclass_warps(object)
  d$shift <- d$t_before - d$t_after
  by_rep <- stats::aggregate(shift ~ site + replicate, data = d, FUN = function(s) max(abs(s)))
  names(by_rep)[3] <- "max_abs_shift"
  structure(list(by_replicate = by_rep, landmark_site = attr(object, "landmark_site")),
            class = "summary_wv_warps")
}

#' @export
print.summary_wv_warps <- function(x, ...) {
  cli::cat_line("Largest landmark shift by replicate:")
  print(x$by_replicate, row.names = FALSE)
  invisible(x)
}

#' Plot registration warps
#'
#' Draws, for every replicate, the time shift of its warp, `h(t) - t`, where
#' `h` maps the time of the replicate as measured onto the registered
#' (reference) time; the landmarks are marked and the event windows shaded.
#'
#' @param object A `wv_warps` object (the `warps` element of a registered
#'   `wv_field`).
#' @param ... Unused.
#' @return A ggplot object.
#' @export
#' @examples
#' t <- seq(0, 10, length.out = 256)
#' bump <- function(t, at) exp(-(t - at)^2) - 0.8 * exp(-(t - at - 1.5)^2)
#' field <- field_runs(rbind(bump(t, 2.8), bump(t, 3.3)), t)
#' reg <- register_curves(field, list(site1 = bump(t, 3)), windows = list(c(1, 7)))
#' autoplot(reg$warps)
autoplot.wv_warps <- function(object, ...) {
  rg <- attr(object, "range")
  keys <- unique(as.data.frame(object)[, c("site", "replicate")])
  if (identical(attr(object, "landmark_site"), "all"))
    keys <- keys[!duplicated(keys$replicate), , drop = FALSE]
  lines <- do.call(rbind, lapply(seq_len(nrow(keys)), function(k) {
    kn <- warp_knots(object, keys$replicate[k], keys$site[k])
    data.frame(site = keys$site[k], replicate = factor(keys$replicate[k]), t = kn$before,
               shift = kn$after - kn$before)
  }))
  pts <- as.data.frame(object)
  pts$replicate <- factor(pts$replicate)
  pts$shift <- pts$t_after - pts$t_before
  win <- do.call(rbind,
                 lapply(attr(object, "windows"), function(w) data.frame(xmin = w[1], xmax = w[2])))
  p <- ggplot2::ggplot() +
    ggplot2::geom_rect(data = win,
                       ggplot2::aes(xmin = .data$xmin, xmax = .data$xmax, ymin = -Inf, ymax = Inf),
                       fill = "grey90") +
    ggplot2::geom_hline(yintercept = 0, colour = "grey50", linewidth = 0.3) +
    ggplot2::geom_line(data = lines, ggplot2::aes(.data$t, .data$shift, colour = .data$replicate)) +
    ggplot2::geom_point(data = pts, ggplot2::aes(.data$t_before, .data$shift,
                                                 colour = .data$replicate,
                                                 shape = .data$feature)) +
    ggplot2::labs(x = "time as measured", y = "registered time - measured time",
                  colour = "replicate",
                  shape = "landmark", title = "Registration warps") +
    ggplot2::coord_cartesian(xlim = rg) +
    ggplot2::theme_bw()
  if (length(unique(object$site)) > 1L) p <- p + ggplot2::facet_wrap(~site)
  p
}

#' @export
plot.wv_warps <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}

# --- warp knots ---------------------------------------------------------------

# Further knots of a warp between the event windows, each placed by least
# squares between the registered curve and the reference over the points
# outside the windows: a vectorised grid search, then optimize(); two sweeps.
fit_warp_knots <- function(y, ref, t, knots, windows, every, sweeps = 2L, n_grid = 41L) {
  inside <- Reduce(`|`, lapply(windows, function(w) t > w[1] & t < w[2]))
  at <- seq(t[1], t[length(t)], by = every)
  near <- vapply(at, function(x) any(vapply(windows, function(w) x > w[1] - every / 2 &&
                                            x < w[2] + every / 2,
                                            logical(1))), logical(1))
  at <- at[!near & at > t[1] + every / 2 & at < t[length(t)] - every / 2]
  at <- setdiff(at, knots$after)
  if (!length(at)) return(list(knots = knots, before = numeric(), after = numeric()))
  start <- stats::approx(knots$after, knots$before, xout = at)$y
  after <- c(knots$after, at)
  before <- c(knots$before, start)
  o <- order(after)
  after <- after[o]
  before <- before[o]
  free <- match(at, after)
  reach <- every / 10
  eps <- 1e-3 * diff(t[1:2])
  # the points each knot moves (outside the windows) and their weight on it;
  # the knot times in registered time never change
  span <- lapply(free, function(j) {
    idx <- which(t >= after[j - 1L] & t <= after[j + 1L] & !inside)
    tt <- t[idx]
    left <- tt <= after[j]
    w <- ifelse(left, (tt - after[j - 1L]) / (after[j] - after[j - 1L]),
                (after[j + 1L] - tt) / (after[j + 1L] - after[j]))
    list(idx = idx, left = left, w = w)
  })
  sse <- function(k, b) {
    # squared distance for candidate positions b of knot free[k] (vectorised over b)
    sp <- span[[k]]
    if (length(sp$idx) < 4L) return(rep(0, length(b)))
    j <- free[k]
    base <- ifelse(sp$left, before[j - 1L], before[j + 1L])
    src <- outer(base * (1 - sp$w), rep(1, length(b))) + outer(sp$w, b)
    val <- matrix(stats::approx(t, y, xout = src, rule = 2)$y, nrow = length(sp$idx))
    colSums((val - ref[sp$idx])^2)
  }
  for (pass in seq_len(sweeps)) {
    for (k in seq_along(free)) {
      j <- free[k]
      lo <- max(before[j - 1L] + eps, start[k] - reach)
      hi <- min(before[j + 1L] - eps, start[k] + reach)
      if (hi <= lo) next
      g <- seq(lo, hi, length.out = n_grid)
      v <- sse(k, g)
      if (all(v == 0)) next
      i <- which.min(v)
      before[j] <- stats::optimize(function(b) sse(k, b),
                                   c(g[max(1L, i - 1L)], g[min(n_grid, i + 1L)]),
                                   tol = 1e-4 * diff(t[1:2]))$minimum
    }
  }
  list(knots = list(before = before, after = after), before = before[free], after = after[free])
}

# Knots of the warps of all replicates (rows of Y) between the windows, fitted
# to the replicates' own consensus instead of the reference: the mean of the
# replicates registered so far (by their landmarks first), each replicate's
# knots placed by least squares against it (fit_warp_knots()), then shifted
# together so that at each knot the replicates' displacements from their
# landmark warps average zero (the consensus keeps the time of the landmark
# warps between the events); `iters` rounds.
consensus_warp_knots <- function(Y, t, knots, windows, every, iters = 2L) {
  R <- nrow(Y)
  current <- knots
  fitted <- NULL
  for (it in seq_len(iters)) {
    cons <- colMeans(do.call(rbind,
                             lapply(seq_len(R),
                                    function(r) apply_inverse_warp(Y[r, ], t, current[[r]]))))
    fitted <- lapply(seq_len(R),
                     function(r) fit_warp_knots(Y[r, ], cons, t, knots[[r]], windows, every))
    if (!length(fitted[[1]]$after)) return(fitted)
    start <- vapply(seq_len(R), function(r) stats::approx(knots[[r]]$after, knots[[r]]$before,
                                                          xout = fitted[[r]]$after)$y,
                    numeric(length(fitted[[1]]$after)))
    moved <- vapply(fitted, function(f) f$before, numeric(length(fitted[[1]]$after)))
    shift <- rowMeans(matrix(moved - start, ncol = R))
    fitted <- lapply(fitted, function(f) {
      b <- f$knots$before
      b[match(f$after, f$knots$after)] <- f$before - shift
      # a shift that would fold the warp leaves that replicate's own fit
      if (is.unsorted(b, strictly = TRUE)) return(f)
      f$before <- f$before - shift
      f$knots$before <- b
      f
    })
    current <- lapply(fitted, function(f) f$knots)
  }
  fitted
}

# Registered curve: y evaluated at the inverse warp of the grid.
apply_inverse_warp <- function(y, t, knots) {
  t_src <- stats::approx(knots$after, knots$before, xout = t, rule = 2)$y
  stats::approx(t, y, xout = t_src, rule = 2)$y
}

# Knots of the warp of one replicate from a wv_warps table.
warp_knots <- function(warps, replicate, site = NULL) {
  d <- warps[warps$replicate == replicate, , drop = FALSE]
  # one warp from every site's landmarks: all of a replicate's rows
  if (!is.null(site) && !identical(attr(warps, "landmark_site"), "all"))
    d <- d[d$site == site, , drop = FALSE]
  d <- d[order(d$t_after), , drop = FALSE]
  rg <- attr(warps, "range")
  before <- c(rg[1], d$t_before, rg[2])
  after <- c(rg[1], d$t_after, rg[2])
  keep <- !(duplicated(before) & duplicated(after))
  list(before = before[keep], after = after[keep])
}
