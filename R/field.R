# Field data: the measured curves of each site on the model's grid, with
# the noise of curves measured off the grid, and their print and summary.

#' Field measurements
#'
#' Holds the replicate field curves of one physical system at one or several
#' sites. Missing values inside a field curve are refused: field data are not
#' dropped silently.
#'
#' The curves are put on a dyadic grid for the wavelet basis: `t` itself when
#' it is one, else `grid` (the model runs' grid, say) or 2^k equally spaced
#' points on the range of `t`, by linear interpolation (with a message).
#'
#' @section Noise evidence kept from the measurements:
#' A measured curve on its own grid holds evidence of the measurement noise
#' that the interpolated curve loses, and `field_runs()` keeps it for the
#' noise learned with one replicate ([noise_prior()], the default in
#' [calibrate()] with one replicate):
#' * **Repeated time stamps.** `t` may repeat a time stamp (a velocimeter
#'   that records some times twice). The values at one time stamp are
#'   averaged; their scatter about their mean, a sum of squares `ss` with
#'   `df` degrees of freedom (the number of values less the number of
#'   distinct stamps, summed over replicates), is independent of the averaged
#'   curve and enters the likelihood of the noise variance `sigma2` of one
#'   measurement as `ss / sigma2 ~ chi^2_df`.
#' * **The detail of the measured curve.** The noise standard deviation is
#'   estimated on the distinct time stamps before interpolation, from each
#'   point's deviation from the straight line through its two neighbours
#'   (the difference-based estimate of Gasser, Sroka and Jennen-Steinmetz,
#'   1986, made robust by the median absolute deviation). It is the default
#'   scale of [noise_prior()] for the site.
#' * **The resampling.** Averaging and interpolation turn white measurement
#'   noise of variance `sigma2` into noise of known covariance on the grid:
#'   [calibrate()] gives each retained wavelet coefficient its own noise
#'   variance, `sigma2` times the diagonal of that covariance carried through
#'   the basis (an interpolated curve's finest coefficients hold little of
#'   the noise; its coarse ones hold more than `sigma2`). Correlations between
#'   coefficients are left out, and so is the resampling of a later
#'   registration ([register_curves()]).
#'
#' On a dyadic `t` without repeated stamps there is nothing to keep: the
#' noise is then learned from the curve on its own grid, as in the method.
#'
#' @param curves An R x T matrix of replicate curves (one site) or a named list
#'   of such matrices, one column per element of `t`.
#' @param t The time of each column of `curves`, non-decreasing; a time stamp
#'   may repeat (repeated measurements, see the section on noise evidence).
#' @param site Optional site names (one per matrix of `curves`).
#' @param x_nom Optional named numeric vector of nominal input values of the
#'   tested system (defaults to the nominals of the I/U map at calibration).
#' @param grid Optional dyadic time grid to put the curves on (the model runs'
#'   `runs$t`); it must lie within the range of `t` up to one step of `t` at
#'   either end, where the curves are held at their first and last values.
#'   `NULL`: `t` when it is dyadic without repeats, else 2^k equally spaced
#'   points on the range of `t`.
#' @return A `wv_field` object: a list with `t`, `curves` (named list of R x T
#'   matrices), `x_nom`, and `noise` (by site, the noise evidence kept from
#'   the measurements, `NULL` when the curves are on their own dyadic grid).
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' reps <- t(replicate(3, sin(2 * pi * t) + rnorm(64, sd = 0.1)))
#' field_runs(reps, t)
#'
#' # one curve with every fourth time stamp measured twice, onto 128 points
#' t_obs <- sort(c(seq(0, 1, length.out = 100), seq(0, 1, length.out = 100)[c(TRUE, FALSE, FALSE, FALSE)]))
#' y <- sin(2 * pi * t_obs) + rnorm(length(t_obs), sd = 0.05)
#' f <- field_runs(rbind(y), t_obs, grid = seq(0, 1, length.out = 128))
#' f
#' f$noise$site1$detail_sd
field_runs <- function(curves, t, x_nom = NULL, site = NULL, grid = NULL) {
  t <- check_stamps(t)
  curves <- as_site_list(curves, site, NULL, length(t), what = "field")
  for (s in names(curves)) {
    bad <- which(!is.finite(curves[[s]]), arr.ind = TRUE)
    if (nrow(bad)) {
      reps <- unique(bad[, 1])
      wv_abort(c(
        "Field curves must be complete: site {.val {s}} has {nrow(bad)} missing or non-finite value{?s}.",
        "x" = "{cli::qty(length(reps))}Replicate{?s} {reps}; the first gap is at t = {signif(t[bad[1, 2]], 5)}.",
        "i" = "Fill the gap (e.g. by interpolation) or remove the replicate."
      ), class = "input")
    }
  }
  if (!is.null(x_nom)) {
    if (!is.numeric(x_nom) || is.null(names(x_nom)) || any(!is.finite(x_nom))) {
      wv_abort("{.arg x_nom} must be a named numeric vector of finite nominal input values.")
    }
  }
  stamps <- unique(t)
  if (length(stamps) < 8L) {
    wv_abort("{.arg t} must have at least 8 distinct time points; it has {length(stamps)}.", class = "input")
  }
  repeats <- length(stamps) < length(t)
  if (!is.null(grid)) grid <- check_field_grid(grid, stamps)
  if (!repeats && is.null(grid)) {
    regridded <- to_dyadic(t, curves)
    noise <- if (identical(regridded$t, t)) NULL else
      lapply(curves, function(m) measurement_noise(m, t, stamps, regridded$t))
    return(validate_wv_field(new_wv_field(regridded$t, regridded$curves, x_nom, noise = noise)))
  }
  noise <- lapply(curves, function(m) measurement_noise(m, t, stamps, grid %||% dyadic_grid(stamps)))
  averaged <- lapply(noise, function(nz) nz$averaged)
  if (is.null(grid)) {
    regridded <- to_dyadic(stamps, averaged)
  } else {
    wv_inform(c("i" = "The curves were linearly interpolated from {length(stamps)} distinct time stamp{?s} to the {length(grid)} points of {.arg grid}."))
    regridded <- list(t = grid, curves = interpolate_curves(stamps, averaged, grid, rule = 2))
  }
  noise <- lapply(noise, function(nz) {
    nz$averaged <- NULL
    nz
  })
  validate_wv_field(new_wv_field(regridded$t, regridded$curves, x_nom, noise = noise))
}

# The time stamps of field data: finite, non-decreasing (a stamp may repeat).
check_stamps <- function(t, call = rlang::caller_env()) {
  if (!is.numeric(t) || !is.null(dim(t))) {
    wv_abort("{.arg t} must be a numeric vector of time points, not {.obj_type_friendly {t}}.", call = call)
  }
  if (length(t) < 8L) wv_abort("{.arg t} must have at least 8 time points; it has {length(t)}.", call = call)
  if (any(!is.finite(t))) wv_abort("{.arg t} must not contain NA or infinite values.", call = call)
  if (any(diff(t) < 0)) {
    i <- which(diff(t) < 0)[1]
    wv_abort(c(
      "{.arg t} must be non-decreasing (a time stamp may repeat).",
      "x" = "t[{i + 1}] = {t[i + 1]} is below t[{i}] = {t[i]}.",
      "i" = "Sort the columns of {.arg curves} by time."
    ), call = call)
  }
  as.numeric(t)
}

# `grid` for field_runs(): dyadic, within the stamps' range up to one step at
# either end.
check_field_grid <- function(grid, stamps, call = rlang::caller_env()) {
  grid <- check_grid(grid, call = call)
  if (!is_dyadic_grid(grid)) {
    wv_abort(c("{.arg grid} must be dyadic: 2^k equally spaced points.",
               "x" = "It has {length(grid)} points{if (bitwAnd(length(grid), length(grid) - 1L) == 0L) ', unequally spaced' else ''}.",
               "i" = "Give the model runs' grid ({.code runs$t}), which {.fn model_runs} makes dyadic."),
             class = "grid", call = call)
  }
  h <- max(diff(stamps))
  if (grid[1] < stamps[1] - h || grid[length(grid)] > stamps[length(stamps)] + h) {
    wv_abort(c("{.arg grid} reaches beyond the measured times by more than one step.",
               "x" = "{.arg grid} spans [{signif(grid[1], 5)}, {signif(grid[length(grid)], 5)}]; the measurements [{signif(stamps[1], 5)}, {signif(stamps[length(stamps)], 5)}].",
               "i" = "Give a grid inside the measured times (cut the model runs to them)."),
             class = "grid", call = call)
  }
  grid
}

# The noise evidence of one site's curves (rows) measured at `t` (stamps may
# repeat) and put on `grid`: the values averaged by stamp, their scatter (ss,
# df), the difference-based noise sd of the averaged curves on the stamps, and
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
  list(averaged = averaged, ss = ss, df = df, n_stamps = length(stamps), n_repeated = sum(n_at > 1L),
       detail_sd = detail_noise_sd(averaged, stamps, 1 / n_at),
       map = list(lo = lo, w = w, var = 1 / n_at))
}

# The noise sd of curves (rows) at unequally spaced times, from each inner
# point's deviation from the line through its neighbours, scaled by its
# variance under white noise (`var`: each point's variance in units of
# sigma2), robustly: MAD / 0.6745, the mean over rows.
detail_noise_sd <- function(Y, t, var) {
  n <- length(t)
  i <- seq(2L, n - 1L)
  a <- (t[i + 1L] - t[i]) / (t[i + 1L] - t[i - 1L])
  b <- 1 - a
  f <- var[i] + a^2 * var[i - 1L] + b^2 * var[i + 1L]
  mean(apply(Y, 1L, function(y) {
    e <- (y[i] - a * y[i - 1L] - b * y[i + 1L]) / sqrt(f)
    stats::mad(e, center = 0)
  }))
}

# The noise variance of each retained coefficient of a curve resampled by
# `map` (measurement_noise()), in units of the variance of one measurement:
# diag(Psi' A D A' Psi), A the interpolation, D the stamps' variance factors.
resampled_noise_multipliers <- function(map, Psi) {
  n_s <- length(map$var)
  B <- rowsum(Psi * (1 - map$w), map$lo, reorder = TRUE)
  hi <- rowsum(Psi * map$w, map$lo + 1L, reorder = TRUE)
  A_t_Psi <- matrix(0, n_s, ncol(Psi))
  A_t_Psi[as.integer(rownames(B)), ] <- B
  A_t_Psi[as.integer(rownames(hi)), ] <- A_t_Psi[as.integer(rownames(hi)), ] + hi
  colSums(A_t_Psi^2 * map$var)
}

new_wv_field <- function(t, curves, x_nom = NULL, warps = NULL, noise = NULL) {
  structure(list(t = t, curves = curves, x_nom = x_nom, warps = warps, noise = noise), class = "wv_field")
}

validate_wv_field <- function(x, call = rlang::caller_env()) {
  n <- vapply(x$curves, nrow, integer(1))
  for (s in names(x$curves)) {
    if (ncol(x$curves[[s]]) != length(x$t)) {
      wv_abort("Site {.val {s}}: {ncol(x$curves[[s]])} columns but {length(x$t)} time points.", call = call)
    }
  }
  x
}

#' @export
print.wv_field <- function(x, ...) {
  n <- vapply(x$curves, nrow, integer(1))
  cli::cat_line(sprintf("<wv_field> field data on %d time points in [%s, %s]%s", length(x$t),
                        format(signif(min(x$t), 4)), format(signif(max(x$t), 4)),
                        if (!is.null(x$warps)) ", registered" else ""))
  for (s in names(n)) cli::cat_line(sprintf("  %s: %d replicate%s", s, n[[s]], if (n[[s]] == 1) "" else "s"))
  if (!is.null(x$x_nom)) {
    cli::cat_line("  nominal inputs: ", paste(sprintf("%s = %s", names(x$x_nom), format(signif(x$x_nom, 4))),
                                                collapse = ", "))
  }
  invisible(x)
}

#' @export
summary.wv_field <- function(object, ...) {
  structure(list(
    n_t = length(object$t),
    range_t = range(object$t),
    replicates = vapply(object$curves, nrow, integer(1)),
    spread = vapply(object$curves, function(m) if (nrow(m) > 1) mean(apply(m, 2, stats::sd)) else NA_real_, numeric(1)),
    registered = !is.null(object$warps),
    x_nom = object$x_nom
  ), class = "summary_wv_field")
}

#' @export
print.summary_wv_field <- function(x, ...) {
  cli::cat_line(sprintf("Field data on %d time points in [%s, %s]%s", x$n_t, format(signif(x$range_t[1], 4)),
                        format(signif(x$range_t[2], 4)), if (x$registered) " (registered)" else ""))
  print(data.frame(site = names(x$replicates), replicates = x$replicates,
                   mean_pointwise_sd = signif(x$spread, 4), row.names = NULL), row.names = FALSE)
  invisible(x)
}
