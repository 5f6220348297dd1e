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
#' that the interpolated curve loses; `field_runs()` keeps it for the noise
#' learned with one replicate ([noise_prior()], the default in [calibrate()]
#' with one replicate):
#' * **Repeated time stamps.** Values at one repeated stamp are averaged; their
#'   scatter, a sum of squares `ss` on `df` degrees of freedom (values less
#'   distinct stamps), enters the likelihood of the variance `sigma2` of one
#'   measurement as `ss / sigma2 ~ chi^2_df`.
#' * **The detail of the measured curve.** The noise sd is estimated on the
#'   distinct stamps before interpolation from each point's deviation from the
#'   line through its neighbours (Gasser, Sroka and Jennen-Steinmetz 1986, made
#'   robust by the median absolute deviation): the default scale of
#'   [noise_prior()] for the site. The deviations (their squares capped at 3
#'   sds) also enter as `detail_ss / sigma2 ~ chi^2_detail_df`, `detail_df`
#'   about (stamps - 2) / 1.94 for their correlation.
#' * **The resampling.** Averaging and interpolation give white noise a known
#'   covariance on the grid; [calibrate()] gives each retained coefficient
#'   `sigma2` times the diagonal of that covariance carried through the basis
#'   (correlations between coefficients, and a later registration's
#'   resampling, are left out).
#'
#' On a dyadic `t` without repeated stamps there is nothing to keep: the
#' noise is learned from the curve on its own grid, as in the method.
#'
#' @section Curves each on their own times:
#' Give `t` as a list by site, each element a vector (every replicate of the
#' site on it) or a list with one vector per replicate, and `curves` as a list
#' by site of vectors (one replicate), lists of vectors (one per replicate,
#' of any lengths) or matrices. Each curve keeps its own noise evidence on its
#' own times (scatter and deviations summed over the site's curves, sd
#' averaged, resampling averaged as the noise of their mean). The curves go
#' onto `grid` when given (`grid = runs$t` for the model runs' grid), else
#' onto 2^k equally spaced points on the longest record, 2^k the next power
#' of two of the most times of any curve. Curves on the same times give the
#' result of the one-`t` form.
#'
#' @section Curves of their own extent:
#' Curves that end (or start) at different times (a specimen breaks, a run
#' stops), given on their own times or as rows of a matrix with `NA` after
#' their end (or before their start), are each observed over their own
#' extent: `observed` holds, by
#' site, which grid points each curve covers. Where fewer curves cover a
#' point, their mean has its larger variance in [calibrate()]; where none
#' does, the data give no weight to any coefficient reaching there (the
#' bias there is its prior's: the bands are wide), registration takes no
#' landmark from a window a curve does not cover, and [misfit_check()]
#' judges only where some curve reaches. A site whose curves all stop early
#' loses the record-wide coefficients: cut the runs to the measured range
#' when one curve per site stops well before the others.
#'
#' @section Long data frames:
#' `field_runs(data, t = "strain", y = "stress", site = "temperature",
#' replicate = "rep")`: a data frame as `curves`, and `t`, `y` and optionally
#' `site` and `replicate` the names of its columns (one row per measured
#' value). Sites and replicates come in sorted order (a factor's levels'
#' order), the rows of each curve in time order. Repeated times within one
#' curve are repeated measurements only when the curve's rows are in time
#' order; otherwise they are refused (a missing `replicate` column is the
#' usual cause). A misspelt column is an error of class
#' `wavevalid_error_column` that lists the columns; a curve with fewer than 8
#' distinct times, or times out of order, one of class `wavevalid_error_stamps`.
#'
#' @section A curve interpolated before it came in:
#' A curve linearly interpolated onto a grid (from digitised or sparse
#' measurements) has empty finest details, and a noise learned from them is
#' close to zero. `field_runs()` reads a curve as interpolated when at 5% of
#' its inner points, and at least 3, it lies on the line through its
#' neighbours (within 1e-9 of its largest value, while rising or falling by
#' more than 1e-6 of it: measured noise never puts three values exactly on a
#' line). It then says so (message class `wavevalid_message_interpolated`)
#' and finds the measured points, where two linear pieces meet, and uses them
#' as the curve's own stamps for the noise evidence above. They are found
#' exactly when the grid has about three points or more per measured
#' interval. When fewer than half are found exactly, or fewer than 8 have
#' both neighbours found exactly, the noise cannot be told: a warning (class
#' `wavevalid_warning_interpolated`) and a difference-based sd of 0, so that
#' [calibrate()] refuses a noise learned with the default prior scale
#' (`wavevalid_error_numeric`) until it is given,
#' `bias_control(sigma2 = noise_prior(scale = ))`: the curve holds no noise
#' below its resolution, and any floor would be made up. Better, give the
#' measured points themselves (curves on their own times, above).
#'
#' @param curves An R x T matrix of replicate curves (one site) or a named list
#'   of such matrices, one column per element of `t`; with `t` a list, a list
#'   by site of curves on their own times; or a long data frame (with `t` a
#'   column name).
#' @param t The time of each column of `curves`, non-decreasing; a time stamp
#'   may repeat (repeated measurements, see the section on noise evidence).
#'   Or a list by site of the times of each curve (see "Curves each on their
#'   own times"), or, with a data frame as `curves`, the name of its column
#'   of times.
#' @param site Optional site names (one per matrix of `curves`); with a data
#'   frame as `curves`, the name of its column of sites (optional).
#' @param y,replicate With a data frame as `curves`: the names of its column
#'   of values and (optional) of replicates.
#' @param x_nom Optional named numeric vector of nominal input values of the
#'   tested system (defaults to the nominals of the I/U map at calibration).
#' @param units How the replicates are declared: `NULL` (the default) when
#'   they are repeated tests of one unit, whose spread is measurement noise;
#'   or, when they are different units (subjects, specimens, vehicles of one
#'   type), the unit of each replicate: a vector in the replicates' order
#'   (the same at every site) or a list of such vectors by site; with a long
#'   data frame, the name of its column of units. A unit may have one
#'   replicate or several. [misfit_check()] then judges the population's
#'   misfit net of what each unit's own inputs explain (see there).
#' @param grid Optional dyadic time grid to put the curves on (the model runs'
#'   `runs$t`); it must lie within the range of `t` (of each curve's times)
#'   up to one step at either end, where the curves are held at their first
#'   and last values. `NULL`: `t` when it is dyadic without repeats, else 2^k
#'   equally spaced points on the range of `t` (on the range every curve
#'   covers).
#' @return A `wv_field` object: a list with `t`, `curves` (named list of R x T
#'   matrices), `x_nom`, and `noise` (by site, the noise evidence kept from
#'   the measurements, `NULL` when the curves are on their own dyadic grid):
#'   `ss`, `df` (repeated stamps), `n_stamps`, `n_repeated`, `detail_sd`,
#'   `detail_ss`, `detail_df` (the difference residuals on the stamps as
#'   data on the noise variance, see [noise_prior()]),
#'   `units` (by site, the unit of each replicate, or `NULL`),
#'   `observed` (by site, the replicates x points mask of where each curve
#'   was measured, only when some curve does not cover the grid),
#'   `map` (the resampling onto the grid; a list of them when the curves had
#'   their own times) and, for curves read as interpolated, `interpolated`
#'   (`n_points`, `n_breakpoints`, `n_measured`: the points read as measured,
#'   `n_exact`: those found exactly, `resolved`).
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' reps <- t(replicate(3, sin(2 * pi * t) + rnorm(64, sd = 0.1)))
#' field_runs(reps, t)
#'
#' # one curve with every fourth time stamp measured twice, onto 128 points
#' t_100 <- seq(0, 1, length.out = 100)
#' t_obs <- sort(c(t_100, t_100[c(TRUE, FALSE, FALSE, FALSE)]))
#' y <- sin(2 * pi * t_obs) + rnorm(length(t_obs), sd = 0.05)
#' f <- field_runs(rbind(y), t_obs, grid = seq(0, 1, length.out = 128))
#' f
#' f$noise$site1$detail_sd
#'
#' # two test temperatures, each curve on its own strains, from a long data frame
#' tests <- do.call(rbind, lapply(c(20, 300), function(temp) {
#'   strain <- sort(runif(25, 0, 0.1))
#'   data.frame(temperature = temp, strain = strain,
#'              stress = 200 * (1 - exp(-strain / (0.01 + temp / 1e4))) + rnorm(25, sd = 2))
#' }))
#' f <- field_runs(tests, t = "strain", y = "stress", site = "temperature")
#' f
#' sapply(f$noise, function(nz) nz$detail_sd)
#'
#' # the same curves as a list by site
#' by_site <- split(tests, tests$temperature)
#' field_runs(lapply(by_site, function(d) d$stress), lapply(by_site, function(d) d$strain))
#'
#' # a curve someone interpolated onto 256 points from 30 measured ones: the
#' # noise evidence is taken from the 30 points found again
#' x <- c(0, (1:28 - runif(28, 0.2, 0.8)) / 28, 1)
#' grid <- seq(0, 1, length.out = 256)
#' y <- approx(x, 100 + 20 * sin(2 * pi * x) + rnorm(30, sd = 1), xout = grid)$y
#' f <- field_runs(rbind(y), grid)
#' f$noise$site1[c("detail_sd", "n_stamps")]
field_runs <- function(curves, t, x_nom = NULL, site = NULL, grid = NULL, y = NULL,
                       replicate = NULL, units = NULL) {
  unit_ids <- NULL
  if (is_long_form(curves, t) && !is.null(units)) {
    unit_ids <- long_units(curves, units, site, replicate)
  } else if (!is.null(units)) {
    unit_ids <- units
  }
  out <- field_from_curves(curves, t, x_nom, site, grid, y, replicate)
  if (!is.null(unit_ids)) out$units <- check_units(unit_ids, out$curves)
  out
}

field_from_curves <- function(curves, t, x_nom, site, grid, y, replicate,
                              call = rlang::caller_env()) {
  labels <- NULL
  if (is_long_form(curves, t)) {
    long <- long_curves(curves, list(t = t, y = y, site = site, replicate = replicate), "replicate",
                        strict = FALSE, call = call)
    if (!is.null(replicate)) labels <- lapply(long$ids, function(v) paste(replicate, v))
    curves <- long$curves
    t <- long$t
    site <- NULL
  } else if (!is.null(y) || !is.null(replicate)) {
    wv_abort(c("{.arg y} and {.arg replicate} name columns of a long data frame.",
               "i" = "Give the data frame as {.arg curves} and the column of the times as {.arg t}, e.g. {.code field_runs(data, t = \"strain\", y = \"stress\")}."),
             class = c("column", "input"))
  }
  check_x_nom(x_nom)
  if (is.list(t)) {
    pts <- own_points(curves, t, site, strict = FALSE, what = "field", labels = labels)
    t <- common_times(pts)
    beyond <- !is.null(t) && !is.null(grid) && length(grid) > 1L &&
      (min(grid) < min(t) - diff(grid[1:2]) || max(grid) > max(t) + diff(grid[1:2]))
    if (is.null(t) || beyond) return(field_on_own_points(pts, x_nom, grid, labels))
    curves <- lapply(pts, function(p) do.call(rbind, lapply(p, function(cv) cv$y)))
    site <- NULL
  }
  t <- check_stamps(t)
  curves <- as_site_list(curves, site, NULL, length(t), what = "field")
  if (ends_missing_only(curves)) {
    # curves that end (or start) at their own times: NA before or after them
    pts <- lapply(curves, function(m) lapply(seq_len(nrow(m)), function(r) {
      ok <- is.finite(m[r, ])
      list(t = t[ok], y = m[r, ok])
    }))
    if (is.null(grid) && is_dyadic_grid(t) && !anyDuplicated(t)) grid <- t
    return(field_on_own_points(pts, x_nom, grid, labels))
  }
  for (s in names(curves)) {
    bad <- which(!is.finite(curves[[s]]), arr.ind = TRUE)
    if (nrow(bad)) {
      reps <- curve_label(labels, s, unique(bad[, 1]))
      wv_abort(c(
        "Field curves must be complete: site {.val {s}} has {nrow(bad)} missing or non-finite value{?s}.",
        "x" = "{.val {reps}}; the first gap is at t = {signif(t[bad[1, 2]], 5)}.",
        "i" = "Fill the gap (e.g. by interpolation) or remove the replicate.",
        "i" = "NA only before a curve's start or after its end are read as its own extent."
      ), class = "input")
    }
  }
  stamps <- unique(t)
  if (length(stamps) < 8L) {
    wv_abort("{.arg t} must have at least 8 distinct time points; it has {length(stamps)}.",
             class = "input")
  }
  repeats <- length(stamps) < length(t)
  if (!is.null(grid)) grid <- check_field_grid(grid, stamps)
  if (!repeats && is.null(grid)) {
    regridded <- to_dyadic(t, curves)
    noise <- if (identical(regridded$t, t)) NULL else
      lapply(curves, function(m) measurement_noise(m, t, stamps, regridded$t))
    noise <- interpolated_evidence(noise, curves, t, regridded$t)
    return(validate_wv_field(new_wv_field(regridded$t, regridded$curves, x_nom, noise = noise)))
  }
  noise <- lapply(curves,
                  function(m) measurement_noise(m, t, stamps, grid %||% dyadic_grid(stamps)))
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
  if (!repeats) noise <- interpolated_evidence(noise, curves, t, regridded$t)
  validate_wv_field(new_wv_field(regridded$t, regridded$curves, x_nom, noise = noise))
}

# Whether the only missing values of the curves (matrices by site) are runs
# of NA at the start or the end of some rows, each row keeping 8 values.
ends_missing_only <- function(curves) {
  any_na <- FALSE
  for (m in curves) {
    for (r in seq_len(nrow(m))) {
      ok <- is.finite(m[r, ])
      if (all(ok)) next
      if (any(!is.na(m[r, !ok])) || sum(ok) < 8L) return(FALSE)
      w <- which(ok)
      if (!all(ok[w[1]:w[length(w)]])) return(FALSE)
      any_na <- TRUE
    }
  }
  any_na
}

# Field curves each on their own times (own_points()), onto one grid: each
# curve's values averaged by time, its noise evidence, then interpolated.
field_on_own_points <- function(pts, x_nom, grid, labels = NULL, call = rlang::caller_env()) {
  for (s in names(pts)) {
    for (r in seq_along(pts[[s]])) {
      y <- pts[[s]][[r]]$y
      if (any(!is.finite(y))) {
        who <- curve_label(labels, s, r)
        wv_abort(c("Field curves must be complete: site {.val {s}}, {who} has {sum(!is.finite(y))} missing or non-finite value{?s}.",
                   "x" = "The first is at t = {signif(pts[[s]][[r]]$t[which(!is.finite(y))[1]], 5)}.",
                   "i" = "Drop the missing values (each curve is on its own times) or remove the replicate."),
                 class = "input", call = call)
      }
    }
  }
  grid <- own_points_grid(pts, grid, labels, call = call)
  evs <- lapply(pts, function(p) lapply(p, function(cv) curve_evidence(cv$y, cv$t, grid)))
  curves <- lapply(names(pts), function(s) {
    do.call(rbind, lapply(seq_along(pts[[s]]), function(r) {
      stats::approx(unique(pts[[s]][[r]]$t), evs[[s]][[r]]$averaged[1, ], xout = grid, rule = 2)$y
    }))
  })
  names(curves) <- names(pts)
  observed <- own_extent_mask(pts, grid)
  for (s in names(observed)) curves[[s]] <- fill_missing(curves[[s]], observed[[s]])
  noise <- report_interpolated(lapply(evs, site_evidence))
  validate_wv_field(new_wv_field(grid, curves, x_nom, noise = noise, observed = observed))
}

# The noise evidence of sites whose curves (rows, at the distinct stamps t)
# are piecewise linear, each curve's from its own points or from those
# recovered as measured (curve_evidence()), in place of `noise` (that of the
# curves as given; NULL by site when there is none).
interpolated_evidence <- function(noise, curves, t, grid) {
  for (s in names(curves)) {
    m <- curves[[s]]
    if (!any(apply(m, 1L, function(y) !is.null(interpolation_knots(t, y))))) next
    if (is.null(noise)) noise <- stats::setNames(vector("list", length(curves)), names(curves))
    noise[[s]] <- site_evidence(lapply(seq_len(nrow(m)),
                                       function(r) curve_evidence(m[r, ], t, grid)))
  }
  if (!is.null(noise)) report_interpolated(noise)
  noise
}

check_x_nom <- function(x_nom, call = rlang::caller_env()) {
  if (!is.null(x_nom) && (!is.numeric(x_nom) || is.null(names(x_nom)) || any(!is.finite(x_nom)))) {
    wv_abort("{.arg x_nom} must be a named numeric vector of finite nominal input values.",
             call = call)
  }
  invisible(x_nom)
}

# The time stamps of field data: finite, non-decreasing (a stamp may repeat).
check_stamps <- function(t, call = rlang::caller_env()) {
  if (!is.numeric(t) || !is.null(dim(t))) {
    wv_abort("{.arg t} must be a numeric vector of time points, not {.obj_type_friendly {t}}.",
             call = call)
  }
  if (length(t) < 8L) wv_abort("{.arg t} must have at least 8 time points; it has {length(t)}.",
                               call = call)
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

new_wv_field <- function(t, curves, x_nom = NULL, warps = NULL, noise = NULL, units = NULL,
                         observed = NULL) {
  out <- list(t = t, curves = curves, x_nom = x_nom, warps = warps, noise = noise)
  if (!is.null(units)) out$units <- units
  if (!is.null(observed)) out$observed <- observed
  structure(out, class = "wv_field")
}

# The unit of each replicate, by site (a character vector per site), from a
# vector (every site's replicates in the same order) or a list by site;
# units may not be shared by fewer than two of them.
check_units <- function(units, curves, call = rlang::caller_env()) {
  n_rep <- vapply(curves, nrow, integer(1))
  if (!is.list(units)) {
    if (length(unique(n_rep)) != 1L) {
      wv_abort(c("{.arg units} as one vector needs the same number of replicates at every site.",
                 "x" = "The sites have {.val {n_rep}} replicates.",
                 "i" = "Give a list by site, each with the unit of every replicate."),
               class = "input", call = call)
    }
    units <- rep(list(units), length(curves))
    names(units) <- names(curves)
  }
  if (is.null(names(units))) names(units) <- names(curves)
  if (!setequal(names(units), names(curves))) {
    wv_abort(c("{.arg units} must name the sites of the curves.",
               "x" = "It names {.val {names(units)}}; the curves {.val {names(curves)}}."),
             class = "input", call = call)
  }
  units <- units[names(curves)]
  for (s in names(curves)) {
    u <- units[[s]]
    if (!is.atomic(u) || anyNA(u) || length(u) != n_rep[[s]]) {
      wv_abort(c("{.arg units} must give the unit of each replicate, without NA.",
                 "x" = "Site {.val {s}} has {n_rep[[s]]} replicate{?s}; {.arg units} gives {length(u)} value{?s}{if (anyNA(u)) ', some NA' else ''}."),
               class = "input", call = call)
    }
    if (length(unique(u)) < 2L) {
      wv_abort(c("{.arg units} must name at least two units at each site.",
                 "x" = "Site {.val {s}} has one unit, {.val {unique(u)}}.",
                 "i" = "Replicates of one unit are repeats: leave {.arg units} out."),
               class = "input", call = call)
    }
    units[[s]] <- as.character(u)
  }
  units
}

# The unit of each replicate of a long data frame, by site, in the order of
# the replicates field_runs() makes (sorted ids); a replicate must belong to
# one unit.
long_units <- function(data, units, site, replicate, call = rlang::caller_env()) {
  if (!is.character(units) || length(units) != 1L || !units %in% names(data)) {
    wv_abort(c("With a long data frame, {.arg units} names its column of units.",
               "i" = "Its columns are {.val {names(data)}}."),
             class = c("column", "input"), call = call)
  }
  if (is.null(replicate)) {
    wv_abort(c("{.arg units} needs {.arg replicate}: the column telling the curves apart.",
               "i" = "Give e.g. {.code replicate = \"test\", units = \"{units}\"}."),
             class = c("column", "input"), call = call)
  }
  lev <- function(v) if (is.factor(v)) levels(droplevels(v)) else as.character(sort(unique(v)))
  sites <- if (is.null(site)) rep("site1", nrow(data)) else as.character(data[[site]])
  site_lev <- if (is.null(site)) "site1" else lev(data[[site]])
  out <- lapply(site_lev, function(s) {
    d <- data[sites == s, , drop = FALSE]
    ids <- lev(d[[replicate]])
    vapply(ids, function(r) {
      u <- unique(as.character(d[[units]][as.character(d[[replicate]]) == r]))
      if (length(u) != 1L) {
        wv_abort(c("Each curve belongs to one unit.",
                   "x" = "Site {.val {s}}, {replicate} {.val {r}} has rows of units {.val {u}}."),
                 class = c("column", "input"), call = call)
      }
      u
    }, character(1), USE.NAMES = FALSE)
  })
  stats::setNames(out, site_lev)
}

validate_wv_field <- function(x, call = rlang::caller_env()) {
  n <- vapply(x$curves, nrow, integer(1))
  for (s in names(x$curves)) {
    if (ncol(x$curves[[s]]) != length(x$t)) {
      wv_abort("Site {.val {s}}: {ncol(x$curves[[s]])} columns but {length(x$t)} time points.",
               call = call)
    }
  }
  x
}

# Where the curves of site `s` of `field` were measured (curves of their own
# extent): the replicates x points mask, and the points some curve covers.
observed_mask <- function(field, s) {
  field$observed[[s]] %||% matrix(TRUE, nrow(field$curves[[s]]), ncol(field$curves[[s]]))
}
covered_points <- function(field, s) colSums(observed_mask(field, s)) > 0
