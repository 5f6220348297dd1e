#' Wavelet basis shared by model runs and field data
#'
#' Decomposes every model-run and field curve of every site with
#' [wavethresh::wd()] (orthonormal) and chooses the index set `I` of retained
#' coefficients. `I` is the union over all curves and all sites, so every site
#' uses one basis.
#'
#' @section Retention rules:
#' `retain = "report"` is the rule of Appendix B of the method's report: for
#' each curve, all coefficients of the levels in `whole_levels` (the default
#' `0:3` is the report's "levels 0 through 3"; the scaling coefficient is
#' always kept), plus the coefficients whose magnitude is in the top
#' `fraction` of all that curve's coefficients, i.e. at least the
#' `1 - fraction` quantile of their absolute values (the hard threshold of
#' [wavethresh::threshold()] with that value, ties kept). How much of a curve
#' this keeps depends on the curve: on a short record with a sharp rise
#' (256 points, the flyer plate of [load_flyer()]) it keeps 10 coefficients and
#' leaves errors of 8% of the runs' norm.
#'
#' `retain = "error"` (the default) starts from the report's rule and adds
#' what the curves need to be reconstructed to their tolerance. Model runs:
#' the median of their relative L2 errors `||y - Psi Psi' y|| / ||y||` at
#' most `tolerance["runs"]` (while it is above, the run closest to its
#' tolerance gets its largest coefficients not yet kept until it meets it);
#' field curves, each of them: a relative L2 error at most
#' `tolerance["field"]`, or a root mean square of what the basis leaves out
#' at most the curve's noise standard deviation (estimated from its finest
#' wavelet level as `MAD / 0.6745`, as in [field_noise()]): below that, what
#' is left out is noise. Where the report's rule already meets the
#' tolerances the basis is the report's; the print gives the largest error
#' of the runs beside the median. The transform is orthonormal,
#' so a curve's relative error is the norm of its coefficients left out over
#' the norm of all of them.
#'
#' @section Boundary:
#' The periodic transform (`boundary = "periodic"`, the report's) treats the
#' record as one period of a periodic curve: a record that ends far from where
#' it starts has a jump at the wrap-around, which costs many fine-scale
#' coefficients at both ends, and a basis that leaves some of them out
#' reconstructs the start of the record with a trace of its end (on the flyer
#' plate, a velocity of 0.013 at the first time point, where the data are 0).
#' `boundary = "interval"` uses the wavelets on the interval of Cohen,
#' Daubechies and Vial (1993), through [wavethresh::wd()] with
#' `bc = "interval"` and no preconditioning: an orthonormal transform whose
#' boundary wavelets do not wrap around, for `family = "DaubExPhase"` and
#' `filter.number` 1 to 8. Coefficients keep the same positions and levels.
#'
#' @section Levels:
#' The package numbers wavelet levels one way, the report's: level 0 is the
#' scaling coefficient (the mean of the curve) and level `l + 1` is
#' wavethresh's detail level `l` (`accessD(w, l)`), so level 1 holds one
#' coefficient, level 2 two, level `j` `2^(j - 1)`, up to level `log2(T)` of
#' a grid of `T` points. Every argument, print and attribute that names a
#' wavelet level uses it: `whole_levels` here, `pool_levels` and
#' `inform_levels` of [bias_control()], the `level` column of the basis and
#' of `attr(where_fails(fit), "wavelet_levels")`, the groups `"site:level"` of
#' the bias variances. An argument called `level` is always a credibility,
#' never a wavelet level.
#'
#' Coefficients are indexed by their position in the full transform: index 1
#' is the scaling coefficient (`accessC(w, 0)`), and the k-th coefficient of
#' `accessD(w, l)` has index `2^l + k`, at level `l + 1`.
#'
#' @inheritParams fit_emulators
#' @param field A `wv_field` object on the same grid (usually registered with
#'   [register_curves()]), or `NULL` to use the model runs only.
#' @param filter.number,family The wavelet, passed to [wavethresh::wd()];
#'   `family` is `"DaubExPhase"` or `"DaubLeAsymm"`.
#' @param whole_levels Wavelet levels kept whole (the report's rule, and the
#'   floor of the error rule), numbered as in the section Levels: 0 the
#'   scaling coefficient, `l + 1` wavethresh's detail level `l`.
#' @param fraction Share of each curve's coefficients (the largest in
#'   magnitude) kept in addition; `1` keeps every coefficient.
#' @param retain `"error"` (default): the report's rule, plus what each curve
#'   needs to meet `tolerance`; `"report"`: the report's rule alone. See the
#'   section Retention rules.
#' @param tolerance For `retain = "error"`: the largest relative L2
#'   reconstruction error allowed, a named vector with `runs` (the median over
#'   the model runs, default 1%) and `field` (each field curve, default 2%, or its noise level
#'   when that is larger).
#' @param boundary `"periodic"` (default, the report's transform) or
#'   `"interval"` (wavelets on the interval). See the section Boundary.
#' @param ... Must be empty. `keep_levels`, wavethresh's detail levels
#'   counted from 0 (`keep_levels = 0:2` is `whole_levels = 0:3`), works for
#'   this version with a warning of class `wavevalid_warning_deprecated`.
#' @return A `wv_basis` object: a list with `index` (sorted integer positions
#'   in the full coefficient vector), `level` (the report's level of each),
#'   `Psi` (T x |I| matrix whose column j is the curve with coefficient
#'   `index[j]` equal to one and all others zero; its columns are orthonormal),
#'   `t`, `sites`, `settings` (filter.number, family, whole_levels, fraction,
#'   retain, tolerance, boundary, n_t, n_levels), `by_site` (the index set each
#'   site would give alone), `n_curves` (curves used, by site and source) and
#'   `error` (the relative L2 reconstruction error of every curve used: a data
#'   frame with `site`, `source`, `id`, `rel_l2`).
#' @seealso [wavelet_coef()], [wavelet_reconstruct()], [reconstruction_check()],
#'   [error_processes()].
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 256)
#' design <- data.frame(a = seq(0.5, 1.5, length.out = 6))
#' curves <- t(sapply(design$a, function(a) sin(8 * pi * t * a) * exp(-3 * t)))
#' runs <- model_runs(design, curves, t)
#' field <- field_runs(curves[2:3, ] + 0.01 * rnorm(512), t)
#' basis <- wavelet_basis(runs, field)
#' basis
#' summary(basis)
#' # the report's rule alone, and wavelets on the interval
#' wavelet_basis(runs, field, retain = "report")
#' wavelet_basis(runs, field, boundary = "interval")
wavelet_basis <- function(runs, field = NULL, filter.number = 2, family = "DaubExPhase",
                          whole_levels = 0:3, fraction = 0.025, retain = c("error", "report"),
                          tolerance = c(runs = 0.01, field = 0.02),
                          boundary = c("periodic", "interval"), ...) {
  if (...length()) whole_levels <- renamed_keep_levels(list(...), whole_levels)
  check_class(runs, "wv_runs")
  retain <- check_choice(retain)
  boundary <- check_choice(boundary)
  sites <- names(runs$curves)
  if (!is.null(field)) {
    check_class(field, "wv_field")
    check_same_grid(runs$t, field$t, "runs", "field")
    extra <- setdiff(names(field$curves), sites)
    if (length(extra)) {
      wv_abort(c(
        "Every field site needs model runs.",
        "x" = "Field site{?s} {.val {extra}} ha{?s/ve} no model runs.",
        "i" = "Model-run sites: {.val {sites}}."
      ))
    }
  }
  settings <- basis_settings(length(runs$t), filter.number, family, whole_levels, fraction,
                             retain = retain, tolerance = tolerance, boundary = boundary)
  n <- settings$n_t
  fixed <- c(1L,
             unlist(lapply(setdiff(settings$whole_levels, 0L) - 1L,
                           function(l) 2L^l + seq_len(2L^l))))

  by_site <- list()
  n_curves <- list()
  coefs <- list()
  for (s in sites) {
    m <- runs$curves[[s]]
    n_field <- 0L
    if (!is.null(field) && s %in% names(field$curves)) {
      n_field <- nrow(field$curves[[s]])
      m <- rbind(m, field$curves[[s]])
    }
    A <- t(apply(m, 1L, full_coef, settings = settings))
    if (nrow(m) == 1L) A <- matrix(A, nrow = 1L)
    source <- rep(c("run", "field"), c(nrow(m) - n_field, n_field))
    keep <- logical(n)
    keep[fixed] <- TRUE
    if (settings$fraction > 0) {
      for (r in seq_len(nrow(m))) {
        a <- abs(A[r, ])
        keep <- keep | a >= stats::quantile(a, 1 - settings$fraction, names = FALSE, type = 7)
      }
    }
    if (retain == "error") keep <- keep_to_tolerance(A, keep, source, settings)
    by_site[[s]] <- which(keep)
    n_curves[[s]] <- c(runs = nrow(runs$curves[[s]]), field = n_field)
    coefs[[s]] <- list(A = A, source = source)
  }
  index <- sort(unique(unlist(by_site, use.names = FALSE)))
  error <- do.call(rbind, lapply(sites, function(s) {
    A <- coefs[[s]]$A
    src <- coefs[[s]]$source
    data.frame(site = s, source = src, id = stats::ave(seq_along(src), src, FUN = seq_along),
               rel_l2 = sqrt(rowSums(A[, -index, drop = FALSE]^2) /
                             pmax(rowSums(A^2), .Machine$double.xmin)),
               stringsAsFactors = FALSE)
  }))
  error <- error[order(error$source != "run", match(error$site, sites), error$id), , drop = FALSE]
  rownames(error) <- NULL
  basis <- new_wv_basis(index = index, coef_level = index_level(index),
                        Psi = basis_matrix(index, settings),
                        t = runs$t, sites = sites, settings = settings, by_site = by_site,
                        n_curves = do.call(rbind, n_curves), error = error)
  validate_wv_basis(basis)
}

# The error rule. Model runs: while the median relative error of the runs
# exceeds tolerance "runs", the run closest to it (the smallest error above
# it) gets its largest coefficients not yet kept until it meets it; what one
# run gains helps the others, so their errors are computed again each time.
# Field curves, each in turn: its largest coefficients not yet kept until the
# energy left out is at most tolerance "field" of its norm, or T sigma^2 (a
# root mean square error of the noise standard deviation sigma, from the
# finest level) when that is larger.
keep_to_tolerance <- function(A, keep, source, settings) {
  n <- ncol(A)
  A2 <- A^2
  total <- pmax(rowSums(A2), .Machine$double.xmin)
  add_until <- function(keep, r, allowed) {
    a2 <- A2[r, ]
    lost <- sum(a2[!keep])
    if (lost <= allowed) return(keep)
    out <- which(!keep)
    out <- out[order(a2[out], decreasing = TRUE)]
    k <- which(lost - cumsum(a2[out]) <= allowed)[1]
    keep[out[seq_len(k)]] <- TRUE
    keep
  }
  runs <- which(source == "run")
  tol_runs <- settings$tolerance[["runs"]]
  if (length(runs)) {
    repeat {
      err <- sqrt(rowSums(A2[runs, !keep, drop = FALSE]) / total[runs])
      if (stats::median(err) <= tol_runs) break
      above <- which(err > tol_runs)
      r <- runs[above[which.min(err[above])]]
      keep <- add_until(keep, r, tol_runs^2 * total[r])
    }
  }
  finest <- seq(n %/% 2L + 1L, n)
  for (r in which(source == "field")) {
    if (sum(A2[r, ]) <= 0) next
    allowed <- max(settings$tolerance[["field"]]^2 * total[r],
                   n * stats::mad(A[r, finest], center = 0)^2)
    keep <- add_until(keep, r, allowed)
  }
  keep
}

# The noise standard deviation of a curve from its finest wavelet level.
finest_level_sd <- function(y, settings) {
  n <- length(y)
  stats::mad(full_coef(y, settings)[seq(n %/% 2L + 1L, n)], center = 0)
}

basis_settings <- function(n_t, filter.number, family, whole_levels, fraction, retain = "report",
                           tolerance = c(runs = 0.01, field = 0.02), boundary = "periodic",
                           call = rlang::caller_env()) {
  if (n_t < 4L || bitwAnd(n_t, n_t - 1L) != 0L) {
    wv_abort(c(
      "The grid must have a power of two of points (at least 4) for the wavelet transform.",
      "x" = "It has {n_t} points.",
      "i" = "Build the runs with {.fn model_runs}, which interpolates to a dyadic grid."
    ), call = call)
  }
  n_levels <- as.integer(round(log2(n_t)))
  check_number(filter.number, "filter.number", min = 1, max = 10, integer = TRUE, call = call)
  if (!is.character(family) || length(family) != 1L || !family %in%
      c("DaubExPhase", "DaubLeAsymm")) {
    wv_abort("{.arg family} must be {.val DaubExPhase} or {.val DaubLeAsymm}.", call = call)
  }
  if (family == "DaubLeAsymm" && filter.number < 4) {
    wv_abort("{.arg filter.number} must be 4 to 10 for {.val DaubLeAsymm}; it is {filter.number}.",
             call = call)
  }
  if (boundary == "interval" && (family != "DaubExPhase" || filter.number > 8)) {
    wv_abort(c(
      "Wavelets on the interval exist for {.val DaubExPhase} with {.arg filter.number} 1 to 8.",
      "x" = "The wavelet is {.val {family}} {filter.number}.",
      "i" = "Use {.code family = \"DaubExPhase\"} with a smaller {.arg filter.number}, or {.code boundary = \"periodic\"}."
    ), call = call)
  }
  if (boundary == "interval" && n_t < 4L * filter.number) {
    wv_abort("Wavelets on the interval with {.arg filter.number} {filter.number} need at least {4 * filter.number} time points; the grid has {n_t}.",
             call = call)
  }
  if (!is.numeric(whole_levels) || any(!is.finite(whole_levels)) ||
      any(whole_levels != round(whole_levels)) ||
      any(whole_levels < 0) || any(whole_levels > n_levels)) {
    wv_abort(c(
      "{.arg whole_levels} must be whole wavelet levels between 0 (the scaling coefficient) and {n_levels}.",
      "x" = "It is {.code {deparse(whole_levels)}}."
    ), call = call)
  }
  check_number(fraction, "fraction", min = 0, max = 1, call = call)
  tolerance <- check_tolerance(tolerance, call = call)
  list(filter.number = as.integer(filter.number), family = family,
       whole_levels = sort(unique(c(0L, as.integer(whole_levels)))), fraction = fraction,
       retain = retain, tolerance = tolerance, boundary = boundary,
       n_t = n_t, n_levels = n_levels)
}

# A named tolerance vector c(runs = , field = ); a missing name keeps its
# default.
check_tolerance <- function(tolerance, call = rlang::caller_env()) {
  out <- c(runs = 0.01, field = 0.02)
  nm <- names(tolerance)
  if (!is.numeric(tolerance) || !length(tolerance) || length(tolerance) > 2L || is.null(nm) ||
      !all(nm %in% names(out)) || anyDuplicated(nm) || any(!is.finite(tolerance)) ||
      any(tolerance <= 0) || any(tolerance >= 1)) {
    wv_abort(c(
      "{.arg tolerance} must be a named vector of relative errors in (0, 1): {.code c(runs = 0.01, field = 0.02)}.",
      "x" = "It is {.code {deparse(tolerance)}}."
    ), call = call)
  }
  out[nm] <- tolerance
  out
}

# Report level of each index: 0 for the scaling coefficient, l + 1 for
# wavethresh detail level l (indices 2^l + 1 .. 2^(l + 1)).
index_level <- function(index) {
  index <- as.integer(index)
  out <- integer(length(index))
  d <- index > 1L
  out[d] <- as.integer(floor(log2(index[d] - 1L) + 1e-9)) + 1L
  out
}

#' Full wavelet coefficient vector of a curve
#'
#' The T coefficients of [wavethresh::wd()] of `y` in the package's index
#' order: the scaling coefficient, then the detail coefficients of wavethresh
#' levels 0, 1, ..., J - 1.
#'
#' @param y A numeric vector of T = 2^J values.
#' @param settings The `settings` of a `wv_basis` (or a list with
#'   `filter.number` and `family`).
#' @return A numeric vector of length T.
#' @keywords internal
#' @noRd
full_coef <- function(y, settings) {
  if (identical(settings$boundary, "interval")) return(interval_wd(y, settings)$transformed.vector)
  w <- wavethresh::wd(y, filter.number = settings$filter.number, family = settings$family,
                      bc = "periodic")
  n_levels <- wavethresh::nlevelsWT(w)
  c(wavethresh::accessC(w, 0),
    unlist(lapply(seq_len(n_levels) - 1L, function(l) wavethresh::accessD(w, l))))
}

# Inverse of full_coef(): the curve with the given full coefficient vector.
full_curve <- function(coef, settings) {
  n <- length(coef)
  if (identical(settings$boundary, "interval")) {
    w <- interval_wd(numeric(n), settings)
    w$transformed.vector <- as.numeric(coef)
    return(suppressWarnings(wavethresh::wr(w)))
  }
  w <- wavethresh::wd(numeric(n), filter.number = settings$filter.number, family = settings$family,
                      bc = "periodic")
  w <- wavethresh::putC(w, 0, coef[1])
  for (l in seq_len(wavethresh::nlevelsWT(w)) - 1L)
    w <- wavethresh::putD(w, l, coef[2L^l + seq_len(2L^l)])
  wavethresh::wr(w)
}

# Column j: the curve whose only non-zero coefficient is index[j], equal to one.
# On the interval, one inverse transform per column. In the periodic transform
# the k-th wavelet of detail level l is the first one circularly shifted by
# (k - 1) T / 2^l points, so one inverse transform per level suffices.
basis_matrix <- function(index, settings) {
  n <- settings$n_t
  if (identical(settings$boundary, "interval")) {
    return(vapply(index, function(i) full_curve(replace(numeric(n), i, 1), settings), numeric(n)))
  }
  zero <- wavethresh::wd(numeric(n), filter.number = settings$filter.number,
                         family = settings$family,
                         bc = "periodic")
  psi <- matrix(0, n, length(index))
  lev <- index_level(index) - 1L
  for (l in unique(lev)) {
    cols <- which(lev == l)
    if (l < 0L) {
      psi[, cols] <- wavethresh::wr(wavethresh::putC(zero, 0, 1))
      next
    }
    first <- wavethresh::wr(wavethresh::putD(zero, l, c(1, numeric(2L^l - 1L))))
    for (j in cols) {
      sh <- (index[j] - 2L^l - 1L) * (n %/% 2L^l)
      psi[, j] <- if (sh == 0L) first else c(first[(n - sh + 1L):n], first[seq_len(n - sh)])
    }
  }
  psi
}

new_wv_basis <- function(index, coef_level, Psi, t, sites, settings, by_site = NULL,
                         n_curves = NULL,
                         error = NULL) {
  structure(list(index = as.integer(index), level = as.integer(coef_level), Psi = Psi, t = t,
                 sites = sites,
                 settings = settings, by_site = by_site, n_curves = n_curves, error = error),
            class = "wv_basis")
}

validate_wv_basis <- function(x, call = rlang::caller_env()) {
  n <- length(x$t)
  if (is.unsorted(x$index, strictly = TRUE) || any(x$index < 1L) || any(x$index > n)) {
    wv_abort("{.field index} must be strictly increasing positions in 1..{n}.", call = call,
             class = "state")
  }
  if (!identical(x$level, index_level(x$index))) {
    wv_abort("{.field level} does not match {.field index}.", call = call, class = "state")
  }
  if (!identical(dim(x$Psi), c(n, length(x$index)))) {
    wv_abort("{.field Psi} must be {n} x {length(x$index)}.", call = call, class = "state")
  }
  x
}

# --- coefficients and curves ---------------------------------------------------

# N x T curves -> N x |I| coefficients.
basis_coef <- function(basis, curves) {
  if (is.null(dim(curves))) curves <- matrix(curves, nrow = 1L)
  if (basis_uses_transform(basis)) return(transform_coef(basis, curves))
  curves %*% basis$Psi
}

# The part of curves (a vector or N x T) the basis does not retain: each
# curve less its projection on the retained coefficients.
basis_remainder <- function(basis, curves) curves - basis_curves(basis, basis_coef(basis, curves))

# N x |I| coefficients -> N x T curves.
basis_curves <- function(basis, W) {
  if (is.null(dim(W))) W <- matrix(W, nrow = 1L)
  if (basis_uses_transform(basis)) {
    # many curves: the product from the wavelets not zero at each stretch of
    # points (its scan of Psi paid once) beats one inverse transform a curve
    if (nrow(W) > length(basis$index) / 60) return(basis_curves_block(W, basis$Psi, seq_len(nrow(basis$Psi))))
    return(transform_curves(basis, W))
  }
  tcrossprod(W, basis$Psi)
}

#' Wavelet coefficients of curves on a basis, and curves from coefficients
#'
#' `wavelet_coef()` gives the retained wavelet coefficients of curves (one row
#' per curve, one column per element of `basis$index`, named `w<index>`);
#' `wavelet_reconstruct()` gives the curves (one row per curve, one column per
#' time point) from such coefficients. Reconstructing the coefficients of a
#' curve gives its projection on the retained basis.
#'
#' @param basis A `wv_basis` object ([wavelet_basis()]).
#' @param curves A numeric vector of T values, an N x T matrix, or a `wv_runs`
#'   or `wv_field` object on the basis grid (then a named list by site is
#'   returned).
#' @param coef A vector of |I| coefficients, an N x |I| matrix, or a named list
#'   of such matrices.
#' @return A matrix (or a named list of matrices by site).
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 128)
#' runs <- model_runs(data.frame(a = 1:5), t(sapply(1:5, function(a) sin(2 * pi * a * t))), t)
#' basis <- wavelet_basis(runs)
#' w <- wavelet_coef(basis, runs)
#' y <- wavelet_reconstruct(basis, w)
#' max(abs(y$site1 - runs$curves$site1))
wavelet_coef <- function(basis, curves) {
  check_class(basis, "wv_basis")
  if (inherits(curves, c("wv_runs", "wv_field"))) {
    check_same_grid(basis$t, curves$t, "basis", "curves")
    return(lapply(curves$curves, function(m) wavelet_coef(basis, m)))
  }
  if (is.numeric(curves) && is.null(dim(curves))) curves <- matrix(curves, nrow = 1L)
  if (!is.matrix(curves) || !is.numeric(curves) || ncol(curves) != length(basis$t)) {
    wv_abort(c(
      "{.arg curves} must have one column per time point of the basis ({length(basis$t)}).",
      "x" = "It is {.obj_type_friendly {curves}} with {NCOL(curves)} column{?s}."
    ))
  }
  out <- basis_coef(basis, curves)
  colnames(out) <- paste0("w", basis$index)
  out
}

#' @rdname wavelet_coef
#' @export
wavelet_reconstruct <- function(basis, coef) {
  check_class(basis, "wv_basis")
  if (is.list(coef) && !is.data.frame(coef))
    return(lapply(coef, function(m) wavelet_reconstruct(basis, m)))
  if (is.numeric(coef) && is.null(dim(coef))) coef <- matrix(coef, nrow = 1L)
  if (!is.matrix(coef) || !is.numeric(coef) || ncol(coef) != length(basis$index)) {
    wv_abort(c(
      "{.arg coef} must have one column per retained coefficient ({length(basis$index)}).",
      "x" = "It has {NCOL(coef)} column{?s}."
    ))
  }
  unname(basis_curves(basis, coef))
}

# wavelet_basis(keep_levels =) counted wavethresh's detail levels from 0: the
# same levels are `keep_levels + 1` in the package's numbering.
renamed_keep_levels <- function(dots, whole_levels, call = rlang::caller_env()) {
  if (!"keep_levels" %in% names(dots)) {
    do.call(check_dots_none, c(dots, list(call = call)))
  }
  old <- dots$keep_levels
  rest <- dots[names(dots) != "keep_levels"]
  if (length(rest)) do.call(check_dots_none, c(rest, list(call = call)))
  wv_warn(c("The argument {.arg keep_levels} of {.fn wavelet_basis} is deprecated.",
            "i" = "Use {.arg whole_levels}, which numbers levels from 0 for the scaling coefficient: {.code keep_levels = 0:2} is {.code whole_levels = 0:3}."),
          class = "deprecated")
  if (!is.numeric(old)) return(old)
  c(0L, old + 1L)
}
