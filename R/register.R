#' Register field curves to a reference by landmarks
#'
#' Aligns the peaks and valleys of every field replicate with those of a
#' reference curve by a piecewise-linear time warp, as in Appendix B of the
#' method's report, generalised to any number of event windows. The figures
#' quoted below are in `studies/README.md` in the package's source
#' repository, "registration.R" unless stated.
#'
#' In each window the landmarks are the minimum and the maximum (or one of
#' them, see `features`) of the reference and of each replicate, ordered by
#' time, at a grid point (as in the report) or, with `refine = TRUE`, at the
#' vertex of the parabola through the extreme grid value and its neighbours.
#' An event that is a monotone change (a shock's rise, a step) has no
#' extremum; `features` then names landmarks of its shape: `"rise"` and
#' `"fall"`, the steepest rise and fall (largest central difference, refined
#' likewise), and `"cross"`, the first crossing of `cross_value`, or of the
#' value `cross_fraction` of the way from the curve's smallest to its largest
#' value in the window, so that a replicate of another amplitude is cut at
#' the same stage (refined by linear interpolation; a curve that does not
#' cross is refused).
#'
#' Near a sharp event a landmark off by a fraction of a grid step misaligns
#' the steep flanks; the refinement removes most of that error (more than an
#' order of magnitude on the suspension test bed), and the replicates then
#' agree more closely, so differences of shape from the reference weigh more.
#' The warp maps a replicate's landmarks onto the reference's, is linear in
#' between and keeps the grid's ends fixed; the registered curve is the
#' replicate at the inverse warp of the grid (linear interpolation). The time
#' jitter of a field test belongs to the test run, not the site, so by
#' default a replicate's landmarks are found on one site (`landmark_site`)
#' and its warp applied to every site.
#'
#' With `knots_every`, beyond the method's report, the warp gets further
#' knots every `knots_every` time units outside the event windows, each
#' placed by least squares against the reference outside the windows (a grid
#' search over a tenth of `knots_every` either side, then a one-dimensional
#' refinement; two sweeps), so that small features between the events line
#' up; data inside the windows never move a knot, so a difference of shape
#' at an event is not taken for a time shift. Where the system rings freely
#' after an event the runs' mean is blurred, and `knots_to = "replicates"`
#' places the knots against the replicates' own consensus instead (two
#' rounds, displacements centred at each knot): closer to the truth on the
#' suspension test bed, but the diagnosis was less reliable.
#'
#' A window that is not an increasing pair of times, falls outside the grid
#' or overlaps another is refused (class `wavevalid_error_input`). When a
#' replicate's landmarks come in another order than the reference's (a
#' change of shape at the event, as when a tire leaves the ground), that
#' window is registered on the largest set of landmarks that keep the order,
#' nearest the reference's times, the others listed in the attribute
#' `left_out` of the warps, with a warning (class
#' `wavevalid_warning_landmarks`); the shape that differs stays in the
#' registered curves, where the bias can show it.
#'
#' @param field A `wv_field` object, or a `wv_runs` object to register the
#'   model runs themselves (see Registering the model runs).
#' @param reference Either a `wv_runs` object on the same grid (the reference
#'   of each site is then the mean of the model runs at that site, as in the
#'   report) or a named list, by site, of reference curves (numeric vectors on
#'   the field grid).
#' @param windows A list of increasing pairs of times, one per event, in
#'   increasing and non-overlapping order, e.g. `list(c(6, 11), c(37, 41))`.
#' @param landmark_site The site (name or position) whose curves set the
#'   landmarks of each replicate, as in the method's report; `"all"`: one
#'   warp per replicate tied to the landmarks of every site in every window
#'   (an event that reaches the sites at different times, as a pothole the
#'   front and then the rear axle, is pinned where each site sees it; what
#'   [validate()] uses: on the suspension test bed it halved the replicates'
#'   scatter at the rear site); or `NULL` to register each site on its own
#'   landmarks with its own warp.
#' @param features Which landmarks to use in each window: one or more of
#'   `"min"`, `"max"` (both by default), `"rise"` (steepest rise), `"fall"`
#'   (steepest fall) and `"cross"` (first crossing of a level); see Details.
#' @param cross_fraction,cross_value For `"cross"`: the value crossed, as a
#'   fraction of the way from each curve's smallest to its largest value in
#'   the window (default 0.5), or, when `cross_value` is given, that value
#'   for every curve (`cross_level`, its former name, works for this version
#'   with a warning of class `wavevalid_warning_deprecated`).
#' @param knots_every `NULL` (the report's landmark warp) or the spacing, in
#'   time units, of the further warp knots fitted between the windows (see
#'   Details).
#' @param refine Locate the landmarks between grid points (see Details);
#'   `FALSE`, the default, keeps the report's grid points.
#' @param knots_to What the further knots are fitted to: `"reference"`
#'   (default) or `"replicates"`, their own consensus (see Details; needs at
#'   least two replicates).
#' @param check_runs With model runs as the reference: how many of the runs
#'   nearest the field data (by the mean square distance of each run from the
#'   registered field mean) are registered like a replicate, to measure what
#'   the registration does to a curve of the model itself (see the section
#'   The registration's own error); 0 (default) skips it. [validate()]
#'   registers 5 unless its `bias_control()` sets
#'   `registration_variance = FALSE` or `TRUE`.
#' @return A registered `wv_field`: the same object with registered curves and
#'   `warps`, a `wv_warps` data frame with one row per (site, replicate,
#'   window, feature) and columns `site` (the site whose curve set the
#'   landmark), `replicate`, `window`, `feature`, `t_before` (the landmark's
#'   time in the replicate as measured) and `t_after` (the reference's time it
#'   is moved to). The warp of a replicate is the piecewise-linear map through
#'   `(t_1, t_1)`, the `(t_before, t_after)` pairs and `(t_T, t_T)`;
#'   attributes `range`, `windows`, `landmark_site` and `sites` complete it.
#'   Plot them with `autoplot(x$warps)`. For `wv_runs`, registered `wv_runs`:
#'   the same design, the registered curves and the runs' `warps` (one
#'   `replicate` per run, in the design's order).
#' @param ... Further arguments of the method; none is taken beyond those
#'   above, and an unknown one is an error.
#'
#' @section The registration's own error:
#' Every replicate is warped onto the same reference, so whatever the
#' registration changes in a curve's shape it changes alike in every
#' replicate: the registered field mean carries an error the replicates'
#' scatter does not show (several times the mean's sampling error on the
#' suspension test bed). With model runs as the reference, `check_runs` runs
#' nearest the field are registered like a replicate; what that changes in
#' them (`registration_check`, by site the registered run less the run) is
#' the registration's error on a curve like the field's, which [calibrate()]
#' takes into the field mean's error by default (its section Registration).
#'
#' @section Registering the model runs:
#' The field is registered to the mean of the runs, whose landmarks sit where
#' the model puts the events on average, not at the inputs that fit the data;
#' where the events' timing depends on the inputs, the calibration reads the
#' difference as bias. Registering every run to the same reference with the
#' same windows puts model and field on one time axis, leaving differences of
#' amplitude and shape, but the events' timing no longer informs the inputs.
#' On the suspension test bed this left fewer flags with nothing hidden but
#' made [explain_bias()] with re-validated mechanisms over-claim
#' (`studies/README.md`, "second_wave.R"). The runs are registered like
#' replicates: `landmark_site` sets one warp per run for all sites, and a run
#' whose landmarks come in another order than the reference's is refused.
#' @export
#' @examples
#' t <- seq(0, 10, length.out = 256)
#' bump <- function(t, at) exp(-(t - at)^2) - 0.8 * exp(-(t - at - 1.5)^2)
#' ref <- bump(t, 3)
#' reps <- rbind(bump(t, 2.8), bump(t, 3.3), bump(t, 3.1))
#' field <- field_runs(reps, t)
#' reg <- register_curves(field, list(site1 = ref), windows = list(c(1, 7)))
#' reg
#' reg$warps
#' autoplot(reg$warps)
#'
#' # model runs registered to the same reference
#' runs <- model_runs(data.frame(a = c(2.7, 3, 3.4)),
#'                    rbind(bump(t, 2.7), bump(t, 3), bump(t, 3.4)), t)
#' register_curves(runs, list(site1 = ref), windows = list(c(1, 7)))$warps
#'
#' # a rise with no extremum: the crossing of a fifth of its range, then its
#' # steepest point
#' rise <- function(t, at) 2 * stats::plogis((t - at) / 0.2)
#' field <- field_runs(rbind(rise(t, 4.3), rise(t, 4.6)), t)
#' reg <- register_curves(field, list(site1 = rise(t, 4.5)), windows = list(c(2, 7)),
#'                        features = c("cross", "rise"), cross_fraction = 0.2, refine = TRUE)
#' reg$warps
register_curves <- function(field, reference, windows, ...) {
  UseMethod("register_curves")
}

#' @rdname register_curves
#' @export
register_curves.default <- function(field, reference, windows, ...) {
  check_class(field, c("wv_field", "wv_runs"))
}

#' @rdname register_curves
#' @export
register_curves.wv_runs <- function(field, reference, windows, ...) {
  runs <- validate_wv_runs(field)
  as_field <- validate_wv_field(new_wv_field(runs$t, runs$curves))
  reg <- register_curves(as_field, reference, windows, ...)
  out <- new_wv_runs(runs$design, runs$t, reg$curves)
  out$warps <- reg$warps
  validate_wv_runs(out)
}

#' @rdname register_curves
#' @export
register_curves.wv_field <- function(field, reference, windows, landmark_site = 1L,
                                     features = c("min", "max"), knots_every = NULL, refine = FALSE,
                                     knots_to = c("reference", "replicates"), cross_fraction = 0.5,
                                     cross_value = NULL, check_runs = 0L, ...) {
  if (...length()) {
    call <- renamed_arg(sys.call(), "cross_level", "cross_value", "register_curves")
    if (!is.null(call)) return(eval(call, parent.frame()))
    check_dots_none(...)
  }
  t <- field$t
  sites <- names(field$curves)
  ref <- resolve_reference(reference, t, sites)
  windows <- check_windows(windows, t)
  features <- check_features(features, cross_fraction, cross_value)
  check_flag(refine)
  knots_to <- check_choice(knots_to)
  if (!is.null(knots_every)) {
    check_number(knots_every, min = 4 * diff(t[1:2]), max = diff(range(t)) / 2)
    if (knots_to == "replicates" && min(vapply(field$curves, nrow, integer(1))) < 2L) {
      wv_abort(c(
        "{.code knots_to = \"replicates\"} needs at least two replicates at every site.",
        "i" = "With a single replicate use {.code knots_to = \"reference\"}."
      ))
    }
  }
  check_number(check_runs, min = 0, integer = TRUE)
  settings <- list(windows = windows, landmark_site = landmark_site, features = features,
                   knots_every = knots_every,
                   refine = refine, cross_fraction = cross_fraction, cross_value = cross_value)
  pooled <- identical(landmark_site, "all") && !"all" %in% sites
  if (pooled && length(sites) == 1L) {
    landmark_site <- sites
    pooled <- FALSE
  }
  if (!is.null(landmark_site) && !pooled) landmark_site <- resolve_site(landmark_site, sites,
                                                                        "landmark_site")

  curves <- field$curves
  observed <- field$observed
  n_rep <- vapply(curves, nrow, integer(1))
  if (length(unique(n_rep)) > 1L && !is.null(landmark_site)) {
    wv_abort(c(
      "Every site must have the same replicates to share one warp per replicate.",
      "x" = "Replicates by site: {paste(sites, n_rep, sep = ' = ', collapse = ', ')}.",
      "i" = "Use {.code landmark_site = NULL} to register each site on its own landmarks."
    ))
  }
  marker_sites <- if (pooled) sites[1] else if (is.null(landmark_site)) sites else landmark_site
  # the sites whose landmarks tie each warp: every site with "all"
  lm_sites <- function(s) if (pooled) sites else s
  site_landmarks <- function(y_of, s) {
    do.call(rbind, lapply(lm_sites(s), function(m) cbind(site = m,
                                                         curve_landmarks(y_of(m), t, windows,
                                                                         features, refine),
                                                         stringsAsFactors = FALSE)))
  }
  rows <- list()
  left_out <- list()
  spread <- list()
  for (s in marker_sites) {
    ref_lm <- site_landmarks(function(m) ref[[m]], s)
    ref_lm <- ref_lm[order(ref_lm$window, ref_lm$t), , drop = FALSE]
    if (inherits(reference, "wv_runs")) {
      for (m in lm_sites(s)) {
        spread[[m]] <- landmark_spread(reference$curves[[m]], t, windows, features, refine,
                                       ref_lm[ref_lm$site == m, c("window", "feature", "t"),
                                              drop = FALSE], m)
      }
    }
    targets <- if (is.null(landmark_site)) s else sites
    R <- n_rep[[s]]
    rep_lms <- lapply(seq_len(R), function(r) {
      within_extent(site_landmarks(function(m) curves[[m]][r, ], s), field$observed, r, t, windows)
    })
    knots <- lapply(seq_len(R),
                    function(r) warp_knots_from(rep_lms[[r]], ref_lm, t, site = s, replicate = r))
    fitted <- NULL
    if (!is.null(knots_every)) {
      fitted <- if (knots_to == "reference") {
        lapply(seq_len(R),
               function(r) fit_warp_knots(curves[[s]][r, ], ref[[s]], t, knots[[r]], windows,
                                          knots_every))
      } else {
        consensus_warp_knots(curves[[s]], t, knots, windows, knots_every)
      }
    }
    for (r in seq_len(R)) {
      kept <- knots[[r]]$keep
      beyond <- is.na(knots[[r]]$t_rep)
      row <- data.frame(
        site = ref_lm$site[kept], replicate = r, window = ref_lm$window[kept],
        feature = ref_lm$feature[kept],
        t_before = knots[[r]]$t_rep[kept], t_after = ref_lm$t[kept], stringsAsFactors = FALSE
      )
      if (!all(kept | beyond)) {
        out_i <- !kept & !beyond
        left_out[[length(left_out) + 1L]] <- data.frame(
          site = ref_lm$site[out_i], replicate = r, window = ref_lm$window[out_i],
          feature = ref_lm$feature[out_i],
          t_before = knots[[r]]$t_rep[out_i], t_after = ref_lm$t[out_i], stringsAsFactors = FALSE
        )
      }
      kn <- knots[[r]][c("before", "after")]
      if (!is.null(fitted)) {
        kn <- fitted[[r]]$knots
        if (length(fitted[[r]]$after)) {
          row <- rbind(row, data.frame(site = s, replicate = r, window = NA_integer_,
                                       feature = "fitted",
                                       t_before = fitted[[r]]$before, t_after = fitted[[r]]$after,
                                       stringsAsFactors = FALSE))
          row <- row[order(row$t_after), , drop = FALSE]
        }
      }
      for (s2 in targets) {
        curves[[s2]][r, ] <- apply_inverse_warp(field$curves[[s2]][r, ], t, kn)
        if (!is.null(observed[[s2]])) {
          observed[[s2]][r, ] <- apply_inverse_warp(as.numeric(field$observed[[s2]][r, ]), t, kn) > 0.5
        }
      }
      rows[[length(rows) + 1L]] <- row
    }
  }
  left_out <- if (length(left_out)) do.call(rbind, left_out)
  if (!is.null(left_out)) warn_left_out(left_out, max(n_rep))
  warps <- new_wv_warps(do.call(rbind, rows), range = range(t), windows = windows,
                        landmark_site = if (pooled) "all" else
                          if (is.null(landmark_site)) NA_character_ else landmark_site,
                        sites = sites,
                        landmark_sd = if (length(spread)) do.call(rbind, unname(spread)),
                        left_out = left_out)
  attr(warps, "landmark_settings") <- list(features = features, refine = refine)
  validate_wv_warps(warps)
  for (s in names(observed)) curves[[s]] <- fill_missing(curves[[s]], observed[[s]])
  out <- validate_wv_field(new_wv_field(t, curves, field$x_nom, warps, noise = field$noise,
                                        units = field$units, observed = observed))
  if (inherits(reference, "wv_runs") && check_runs > 0L) {
    out$registration_check <- registration_check(out, reference, settings, check_runs)
  }
  out
}

# What the registration does to the `n` model runs nearest the registered
# field `field` (by mean square distance from its mean over the sites): each
# registered like a replicate, with the field's settings, to the same
# reference. A named list by site of n x T matrices, the registered run less
# the run; NULL when the runs' landmarks cannot be registered.
registration_check <- function(field, runs, settings, n) {
  sites <- names(field$curves)
  d <- Reduce(`+`,
              lapply(sites,
                     function(s) rowMeans(sweep(runs$curves[[s]], 2L,
                                                colMeans(field$curves[[s]]))^2)))
  near <- order(d)[seq_len(min(n, length(d)))]
  f <- new_wv_field(runs$t, lapply(runs$curves[sites], function(m) m[near, , drop = FALSE]))
  reg <- tryCatch(suppressWarnings(do.call(register_curves,
                                           c(list(f, runs), settings, list(check_runs = 0L)))),
                  wavevalid_error = function(e) NULL)
  if (is.null(reg)) return(NULL)
  stats::setNames(lapply(sites, function(s) reg$curves[[s]] - f$curves[[s]]), sites)
}

# --- input checks ------------------------------------------------------------

resolve_reference <- function(reference, t, sites, call = rlang::caller_env()) {
  if (inherits(reference, "wv_runs")) {
    check_same_grid(reference$t, t, "reference", "field", call = call)
    missing <- setdiff(sites, names(reference$curves))
    if (length(missing)) {
      wv_abort("{.arg reference} has no model runs for field site{?s} {.val {missing}}.",
               call = call)
    }
    return(lapply(reference$curves[sites], colMeans))
  }
  if (!is.list(reference) || is.null(names(reference))) {
    wv_abort(c(
      "{.arg reference} must be a {.cls wv_runs} object or a named list of reference curves, one per site.",
      "x" = "It is {.obj_type_friendly {reference}}."
    ), call = call)
  }
  missing <- setdiff(sites, names(reference))
  if (length(missing)) {
    wv_abort("{.arg reference} has no curve for field site{?s} {.val {missing}}.", call = call)
  }
  out <- lapply(sites, function(s) {
    y <- reference[[s]]
    if (!is.numeric(y) || length(y) != length(t) || any(!is.finite(y))) {
      wv_abort(c(
        "The reference curve of site {.val {s}} must be a finite numeric vector on the field grid.",
        "x" = "It has {length(y)} value{?s}; the field grid has {length(t)} points."
      ), call = call)
    }
    as.numeric(y)
  })
  stats::setNames(out, sites)
}

check_windows <- function(windows, t, call = rlang::caller_env()) {
  if (is.numeric(windows) && length(windows) == 2L) windows <- list(windows)
  if (!is.list(windows) || length(windows) == 0L) {
    wv_abort("{.arg windows} must be a list of increasing pairs of times, e.g. {.code list(c(6, 11), c(37, 41))}.",
             call = call)
  }
  for (w in seq_along(windows)) {
    x <- windows[[w]]
    if (!is.numeric(x) || length(x) != 2L || any(!is.finite(x)) || x[1] >= x[2]) {
      wv_abort(c(
        "Window {w} must be an increasing pair of finite times.",
        "x" = "It is {.code {deparse(x)}}."
      ), call = call)
    }
    if (x[1] < t[1] || x[2] > t[length(t)]) {
      wv_abort(c(
        "Window {w} ({x[1]}, {x[2]}) falls outside the grid [{signif(t[1], 5)}, {signif(t[length(t)], 5)}].",
        "i" = "Give windows inside the time range of the curves."
      ), call = call)
    }
    if (sum(t >= x[1] & t <= x[2]) < 2L) {
      wv_abort("Window {w} ({x[1]}, {x[2]}) holds fewer than two grid points; widen it.",
               call = call)
    }
    if (w > 1L && x[1] <= windows[[w - 1L]][2]) {
      wv_abort(c(
        "Windows must be in increasing order and must not overlap.",
        "x" = "Window {w} starts at {x[1]}, before window {w - 1} ends at {windows[[w - 1L]][2]}."
      ), call = call)
    }
  }
  lapply(windows, as.numeric)
}

landmark_features <- c("min", "max", "rise", "fall", "cross")

check_features <- function(features, cross_fraction = 0.5, cross_value = NULL,
                           call = rlang::caller_env()) {
  if (!is.character(features) || length(features) == 0L || !all(features %in% landmark_features) ||
      anyDuplicated(features)) {
    wv_abort(c(
      "{.arg features} must be one or more of {.val {landmark_features}}, each once.",
      "x" = "It is {.code {deparse(features)}}."
    ), call = call)
  }
  check_number(cross_fraction, "cross_fraction", min = 0, max = 1, call = call)
  if (cross_fraction %in% c(0, 1)) {
    wv_abort("{.arg cross_fraction} must lie strictly between 0 and 1: a curve never crosses its own extreme.",
             call = call)
  }
  if (!is.null(cross_value)) check_number(cross_value, "cross_value", call = call)
  out <- intersect(landmark_features, features)
  if ("cross" %in% out) attr(out, "cross") <- list(fraction = cross_fraction, value = cross_value)
  out
}

# A replicate's landmarks (rows of curve_landmarks()) in the windows its
# curve covers whole: a window that reaches beyond the curve's own extent
# (`observed`, by site, NULL when every curve covers the grid) gives no
# landmark of that replicate; its warp is tied by the others.
within_extent <- function(lm, observed, r, t, windows) {
  if (is.null(observed) || !nrow(lm)) return(lm)
  keep <- vapply(seq_len(nrow(lm)), function(i) {
    obs <- observed[[lm$site[i]]]
    if (is.null(obs)) return(TRUE)
    w <- windows[[lm$window[i]]]
    all(obs[r, t >= w[1] & t <= w[2]])
  }, logical(1))
  lm[keep, , drop = FALSE]
}
