#' Wavelet basis shared by model runs and field data
#'
#' Decomposes every model-run and field curve of every site with
#' [wavethresh::wd()] (periodic boundary, orthonormal) and chooses the index
#' set `I` of retained coefficients as in Appendix B of the method's report:
#' for each curve, the scaling coefficient and all detail coefficients of the
#' wavethresh levels in `keep_levels` (the default `0:2` is the report's
#' "levels 0 through 3"), plus the coefficients whose magnitude is in the top
#' `fraction` of all that curve's coefficients, i.e. at least the
#' `1 - fraction` quantile of their absolute values (the hard threshold of
#' [wavethresh::threshold()] with that value, ties kept). `I` is the union over
#' all curves and all sites, so every site uses one basis.
#'
#' Coefficients are indexed by their position in the full transform: index 1
#' is the scaling coefficient (`accessC(w, 0)`), and the k-th coefficient of
#' `accessD(w, l)` has index `2^l + k`. The report's level is 0 for the scaling
#' coefficient and `l + 1` for wavethresh detail level `l`.
#'
#' @inheritParams fit_emulators
#' @param field A `wv_field` object on the same grid (usually registered with
#'   [register_curves()]), or `NULL` to use the model runs only.
#' @param filter.number,family The wavelet, passed to [wavethresh::wd()];
#'   `family` is `"DaubExPhase"` or `"DaubLeAsymm"`.
#' @param keep_levels wavethresh detail levels kept whole.
#' @param fraction Share of each curve's coefficients (the largest in
#'   magnitude) kept in addition; `1` keeps every coefficient.
#' @return A `wv_basis` object: a list with `index` (sorted integer positions
#'   in the full coefficient vector), `level` (the report's level of each),
#'   `Psi` (T x |I| matrix whose column j is the curve with coefficient
#'   `index[j]` equal to one and all others zero; its columns are orthonormal),
#'   `t`, `sites`, `settings` (filter.number, family, keep_levels, fraction,
#'   n_t, n_levels), `by_site` (the index set each site would give alone) and
#'   `n_curves` (curves used, by site and source).
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
wavelet_basis <- function(runs, field = NULL, filter.number = 2, family = "DaubExPhase",
                          keep_levels = 0:2, fraction = 0.025) {
  check_class(runs, "wv_runs")
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
  settings <- basis_settings(length(runs$t), filter.number, family, keep_levels, fraction)
  n <- settings$n_t
  fixed <- c(1L, unlist(lapply(settings$keep_levels, function(l) 2L^l + seq_len(2L^l))))

  by_site <- list()
  n_curves <- list()
  for (s in sites) {
    m <- runs$curves[[s]]
    n_field <- 0L
    if (!is.null(field) && s %in% names(field$curves)) {
      n_field <- nrow(field$curves[[s]])
      m <- rbind(m, field$curves[[s]])
    }
    keep <- logical(n)
    keep[fixed] <- TRUE
    if (settings$fraction > 0) {
      for (r in seq_len(nrow(m))) {
        a <- abs(full_coef(m[r, ], settings))
        keep <- keep | a >= stats::quantile(a, 1 - settings$fraction, names = FALSE, type = 7)
      }
    }
    by_site[[s]] <- which(keep)
    n_curves[[s]] <- c(runs = nrow(runs$curves[[s]]), field = n_field)
  }
  index <- sort(unique(unlist(by_site, use.names = FALSE)))
  basis <- new_wv_basis(index = index, coef_level = index_level(index), Psi = basis_matrix(index, settings),
                        t = runs$t, sites = sites, settings = settings, by_site = by_site,
                        n_curves = do.call(rbind, n_curves))
  validate_wv_basis(basis)
}

basis_settings <- function(n_t, filter.number, family, keep_levels, fraction, call = rlang::caller_env()) {
  if (n_t < 4L || bitwAnd(n_t, n_t - 1L) != 0L) {
    wv_abort(c(
      "The grid must have a power of two of points (at least 4) for the wavelet transform.",
      "x" = "It has {n_t} points.",
      "i" = "Build the runs with {.fn model_runs}, which interpolates to a dyadic grid."
    ), call = call)
  }
  n_levels <- as.integer(round(log2(n_t)))
  check_number(filter.number, "filter.number", min = 1, max = 10, integer = TRUE, call = call)
  if (!is.character(family) || length(family) != 1L || !family %in% c("DaubExPhase", "DaubLeAsymm")) {
    wv_abort("{.arg family} must be {.val DaubExPhase} or {.val DaubLeAsymm}.", call = call)
  }
  if (family == "DaubLeAsymm" && filter.number < 4) {
    wv_abort("{.arg filter.number} must be 4 to 10 for {.val DaubLeAsymm}; it is {filter.number}.", call = call)
  }
  if (!is.numeric(keep_levels) || any(!is.finite(keep_levels)) || any(keep_levels != round(keep_levels)) ||
      any(keep_levels < 0) || any(keep_levels > n_levels - 1L)) {
    wv_abort(c(
      "{.arg keep_levels} must be whole wavethresh detail levels between 0 and {n_levels - 1}.",
      "x" = "It is {.code {deparse(keep_levels)}}."
    ), call = call)
  }
  check_number(fraction, "fraction", min = 0, max = 1, call = call)
  list(filter.number = as.integer(filter.number), family = family,
       keep_levels = sort(unique(as.integer(keep_levels))), fraction = fraction,
       n_t = n_t, n_levels = n_levels)
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
  w <- wavethresh::wd(y, filter.number = settings$filter.number, family = settings$family, bc = "periodic")
  n_levels <- wavethresh::nlevelsWT(w)
  c(wavethresh::accessC(w, 0), unlist(lapply(seq_len(n_levels) - 1L, function(l) wavethresh::accessD(w, l))))
}

# Inverse of full_coef(): the curve with the given full coefficient vector.
full_curve <- function(coef, settings) {
  n <- length(coef)
  w <- wavethresh::wd(numeric(n), filter.number = settings$filter.number, family = settings$family,
                      bc = "periodic")
  w <- wavethresh::putC(w, 0, coef[1])
  for (l in seq_len(wavethresh::nlevelsWT(w)) - 1L) w <- wavethresh::putD(w, l, coef[2L^l + seq_len(2L^l)])
  wavethresh::wr(w)
}

# Column j: the curve whose only non-zero coefficient is index[j], equal to one.
# In the periodic transform the k-th wavelet of detail level l is the first
# one circularly shifted by (k - 1) T / 2^l points, so one inverse transform
# per level suffices.
basis_matrix <- function(index, settings) {
  n <- settings$n_t
  zero <- wavethresh::wd(numeric(n), filter.number = settings$filter.number, family = settings$family,
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

new_wv_basis <- function(index, coef_level, Psi, t, sites, settings, by_site = NULL, n_curves = NULL) {
  structure(list(index = as.integer(index), level = as.integer(coef_level), Psi = Psi, t = t, sites = sites,
                 settings = settings, by_site = by_site, n_curves = n_curves), class = "wv_basis")
}

validate_wv_basis <- function(x, call = rlang::caller_env()) {
  n <- length(x$t)
  if (is.unsorted(x$index, strictly = TRUE) || any(x$index < 1L) || any(x$index > n)) {
    wv_abort("{.field index} must be strictly increasing positions in 1..{n}.", call = call, class = "state")
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
  curves %*% basis$Psi
}

# N x |I| coefficients -> N x T curves.
basis_curves <- function(basis, W) {
  if (is.null(dim(W))) W <- matrix(W, nrow = 1L)
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
  if (is.list(coef) && !is.data.frame(coef)) return(lapply(coef, function(m) wavelet_reconstruct(basis, m)))
  if (is.numeric(coef) && is.null(dim(coef))) coef <- matrix(coef, nrow = 1L)
  if (!is.matrix(coef) || !is.numeric(coef) || ncol(coef) != length(basis$index)) {
    wv_abort(c(
      "{.arg coef} must have one column per retained coefficient ({length(basis$index)}).",
      "x" = "It has {NCOL(coef)} column{?s}."
    ))
  }
  unname(basis_curves(basis, coef))
}

# --- print, summary, plot ----------------------------------------------------------

family_label <- function(settings) {
  sprintf("%s %d", settings$family, settings$filter.number)
}

#' @export
print.wv_basis <- function(x, ...) {
  st <- x$settings
  cli::cat_line(sprintf("<wv_basis> %d of %d wavelet coefficients kept (%s, periodic)",
                        length(x$index), st$n_t, family_label(st)))
  alone <- vapply(x$by_site, length, integer(1))
  cli::cat_line("  sites: ", paste(sprintf("%s (%d alone)", names(alone), alone), collapse = ", "))
  if (!is.null(x$n_curves)) {
    cli::cat_line(sprintf("  from %d model-run and %d field curves", sum(x$n_curves[, "runs"]),
                          sum(x$n_curves[, "field"])))
  }
  lv <- if (length(st$keep_levels)) paste0(" and all of levels ", paste(range(st$keep_levels + 1L), collapse = "-"))
        else ""
  cli::cat_line(sprintf("  rule: scaling coefficient%s, plus each curve's top %s%% of coefficients",
                        lv, format(100 * st$fraction)))
  tab <- table(factor(x$level, levels = 0:st$n_levels))
  tab <- tab[tab > 0]
  cli::cat_line("  kept by level: ", paste(sprintf("%s:%d", names(tab), tab), collapse = " "))
  invisible(x)
}

#' @export
summary.wv_basis <- function(object, ...) {
  st <- object$settings
  lev <- 0:st$n_levels
  total <- c(1L, 2L^(lev[-1] - 1L))
  kept <- as.integer(table(factor(object$level, levels = lev)))
  structure(list(
    by_level = data.frame(level = lev, total = total, kept = kept, share = kept / total),
    n_kept = length(object$index), n_t = st$n_t, by_site = vapply(object$by_site, length, integer(1)),
    settings = st
  ), class = "summary_wv_basis")
}

#' @export
print.summary_wv_basis <- function(x, ...) {
  cli::cat_line(sprintf("Wavelet basis: %d of %d coefficients kept (%s)", x$n_kept, x$n_t,
                        family_label(x$settings)))
  cli::cat_line("Sites alone: ", paste(sprintf("%s %d", names(x$by_site), x$by_site), collapse = ", "))
  d <- x$by_level
  d$share <- sprintf("%.1f%%", 100 * d$share)
  print(d, row.names = FALSE)
  invisible(x)
}

#' Plot a wavelet basis
#'
#' `type = "levels"` shows which coefficients are kept: one point per retained
#' coefficient at the time its wavelet is centred on, by level.
#' `type = "reconstruction"` draws `curve` and its reconstruction from the
#' retained coefficients (report Figure 2; see also [reconstruction_check()]).
#'
#' @param object A `wv_basis` object.
#' @param type `"levels"` or `"reconstruction"`.
#' @param curve For `type = "reconstruction"`: a numeric vector on the basis
#'   grid.
#' @param ... Unused.
#' @return A ggplot object.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 128)
#' runs <- model_runs(data.frame(a = 1:5), t(sapply(1:5, function(a) sin(2 * pi * a * t^2))), t)
#' basis <- wavelet_basis(runs)
#' autoplot(basis)
#' autoplot(basis, type = "reconstruction", curve = runs$curves$site1[5, ])
autoplot.wv_basis <- function(object, type = c("levels", "reconstruction"), curve = NULL, ...) {
  type <- check_choice(type)
  if (type == "reconstruction") {
    if (!is.numeric(curve) || length(curve) != length(object$t)) {
      wv_abort("{.arg curve} must be a numeric vector of {length(object$t)} values on the basis grid.")
    }
    return(plot_reconstruction(object$t, curve, basis_curves(object, basis_coef(object, curve))[1, ], NULL))
  }
  rg <- range(object$t)
  pos <- ifelse(object$level == 0L, 0.5, (object$index - 2^pmax(object$level - 1L, 0) - 0.5) /
                  2^pmax(object$level - 1L, 0))
  d <- data.frame(t = rg[1] + pos * diff(rg), level = object$level)
  ggplot2::ggplot(d, ggplot2::aes(.data$t, .data$level)) +
    ggplot2::geom_point(size = 0.8) +
    ggplot2::scale_y_reverse(breaks = 0:object$settings$n_levels) +
    ggplot2::labs(x = "time (centre of the wavelet)", y = "level",
                  title = sprintf("%d retained wavelet coefficients", length(object$index))) +
    ggplot2::theme_bw()
}

#' @export
plot.wv_basis <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}
