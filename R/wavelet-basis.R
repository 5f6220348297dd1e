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
#' @param runs A `wv_runs` object.
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
  basis <- new_wv_basis(index = index, level = index_level(index), Psi = basis_matrix(index, settings),
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

new_wv_basis <- function(index, level, Psi, t, sites, settings, by_site = NULL, n_curves = NULL) {
  structure(list(index = as.integer(index), level = as.integer(level), Psi = Psi, t = t, sites = sites,
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
#' @param basis A `wv_basis` object.
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
  type <- match.arg(type)
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

plot_reconstruction <- function(t, y, yhat, title) {
  d <- rbind(data.frame(t = t, y = y, curve = "original"), data.frame(t = t, y = yhat, curve = "reconstructed"))
  ggplot2::ggplot(d, ggplot2::aes(.data$t, .data$y, colour = .data$curve, linetype = .data$curve)) +
    ggplot2::geom_line(linewidth = 0.35) +
    ggplot2::scale_colour_manual(values = c(original = "black", reconstructed = "red")) +
    ggplot2::scale_linetype_manual(values = c(original = "solid", reconstructed = "dashed")) +
    ggplot2::labs(x = "time", y = "output", colour = NULL, linetype = NULL,
                  title = title %||% sprintf("Relative L2 error %.3g", sqrt(sum((y - yhat)^2) / sum(y^2)))) +
    ggplot2::theme_bw()
}

# --- diagnostics ---------------------------------------------------------------

#' Accuracy of the wavelet reconstruction
#'
#' Projects every model-run and field curve on the retained basis and reports
#' how much is lost: the relative L2 error `||y - Psi Psi' y|| / ||y||` and the
#' largest absolute error of each curve. `autoplot()` of the result draws one
#' curve and its reconstruction (report Figure 2).
#'
#' @param basis A `wv_basis` object.
#' @param runs,field `wv_runs` and `wv_field` objects on the basis grid (either
#'   may be `NULL`).
#' @return A `wv_reconstruction` data frame with columns `site`, `source`
#'   (`"run"` or `"field"`), `id` (run or replicate number), `rel_l2` and
#'   `max_abs`, one row per curve; the curves are kept as an attribute for
#'   plotting.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 256)
#' runs <- model_runs(data.frame(a = 1:6), t(sapply(1:6, function(a) sin(2 * pi * a * t^2))), t)
#' basis <- wavelet_basis(runs)
#' chk <- reconstruction_check(basis, runs)
#' chk
#' autoplot(chk)
reconstruction_check <- function(basis, runs = NULL, field = NULL) {
  check_class(basis, "wv_basis")
  sets <- list()
  if (!is.null(runs)) {
    check_class(runs, "wv_runs")
    check_same_grid(basis$t, runs$t, "basis", "runs")
    sets$run <- runs$curves
  }
  if (!is.null(field)) {
    check_class(field, "wv_field")
    check_same_grid(basis$t, field$t, "basis", "field")
    sets$field <- field$curves
  }
  if (!length(sets)) wv_abort("Give {.arg runs}, {.arg field} or both.")
  rows <- list()
  curves <- list()
  for (src in names(sets)) for (s in names(sets[[src]])) {
    m <- sets[[src]][[s]]
    err <- m - basis_curves(basis, basis_coef(basis, m))
    rows[[length(rows) + 1L]] <- data.frame(site = s, source = src, id = seq_len(nrow(m)),
                                            rel_l2 = sqrt(rowSums(err^2) / rowSums(m^2)),
                                            max_abs = apply(abs(err), 1L, max), stringsAsFactors = FALSE)
    curves[[paste(src, s)]] <- m
  }
  out <- do.call(rbind, rows)
  structure(out, basis = basis, curves = curves, class = c("wv_reconstruction", "data.frame"))
}

#' @export
print.wv_reconstruction <- function(x, ...) {
  d <- as.data.frame(x)
  cli::cat_line(sprintf("<wv_reconstruction> %d curves on %d of %d coefficients", nrow(d),
                        length(attr(x, "basis")$index), length(attr(x, "basis")$t)))
  agg <- stats::aggregate(rel_l2 ~ site + source, data = d,
                          FUN = function(v) c(median = stats::median(v), max = max(v)))
  agg <- data.frame(agg[c("site", "source")], median_rel_l2 = signif(agg$rel_l2[, "median"], 3),
                    max_rel_l2 = signif(agg$rel_l2[, "max"], 3))
  print(agg, row.names = FALSE)
  invisible(x)
}

#' @export
as.data.frame.wv_reconstruction <- function(x, ...) {
  attr(x, "basis") <- attr(x, "curves") <- NULL
  class(x) <- "data.frame"
  x
}

#' @export
summary.wv_reconstruction <- function(object, ...) {
  d <- as.data.frame(object)
  structure(list(worst = d[which.max(d$rel_l2), ], quantiles = stats::quantile(d$rel_l2, c(0, 0.5, 0.9, 1))),
            class = "summary_wv_reconstruction")
}

#' @export
print.summary_wv_reconstruction <- function(x, ...) {
  cli::cat_line("Relative L2 reconstruction error, quantiles over curves:")
  print(signif(x$quantiles, 3))
  cli::cat_line(sprintf("Worst: %s %s %d (%.3g)", x$worst$site, x$worst$source, x$worst$id, x$worst$rel_l2))
  invisible(x)
}

#' @rdname reconstruction_check
#' @param object A `wv_reconstruction` object.
#' @param which Row of `object` whose curve is drawn; by default the first
#'   field curve if there is one (as the report's Figure 2), else the worst
#'   reconstructed curve.
#' @param ... Unused.
#' @export
autoplot.wv_reconstruction <- function(object, which = NULL, ...) {
  d <- as.data.frame(object)
  if (is.null(which)) which <- if (any(d$source == "field")) which(d$source == "field")[1] else which.max(d$rel_l2)
  check_number(which, "which", min = 1, max = nrow(d), integer = TRUE)
  r <- d[which, ]
  y <- attr(object, "curves")[[paste(r$source, r$site)]][r$id, ]
  basis <- attr(object, "basis")
  plot_reconstruction(basis$t, y, basis_curves(basis, basis_coef(basis, y))[1, ],
                      sprintf("%s %s %d: relative L2 error %.3g", r$site, r$source, r$id, r$rel_l2))
}

#' @export
plot.wv_reconstruction <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}

#' Field residual processes against the independent-coefficient error model
#'
#' The method models the measurement error of each retained wavelet
#' coefficient as independent across coefficients, with its own variance.
#' This check (report Figure 3) sets the residual processes of the field data
#' (each replicate minus the replicate mean) beside R processes simulated from
#' that model, `Psi %*% rnorm(|I|, sd = sigma)`, with `sigma_i^2 = s_i^2 / (R -
#' 1)` the unbiased replicate variance of coefficient i. Similar time
#' correlation in both panels supports the model.
#'
#' @param basis A `wv_basis` object.
#' @param field A `wv_field` object with at least two replicates.
#' @param site Site to check (name or position; default the first).
#' @param seed Seed for the simulated processes; `NULL` draws one from R's RNG.
#' @param project If `TRUE`, the field residuals are projected on the retained
#'   basis first, so both panels hold processes in the span of `Psi` (the
#'   simulated ones always are); by default they are the raw residuals, as in
#'   the report.
#' @return A `wv_error_processes` data frame with columns `site`, `process`
#'   (`"field residuals"` or `"simulated"`), `replicate`, `t`, `y`; attributes
#'   `sigma2` (per retained coefficient) and `seed`.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 128)
#' runs <- model_runs(data.frame(a = 1:5), t(sapply(1:5, function(a) sin(2 * pi * a * t))), t)
#' field <- field_runs(t(replicate(4, sin(4 * pi * t) + cumsum(rnorm(128, sd = 0.05)))), t)
#' basis <- wavelet_basis(runs, field)
#' ep <- error_processes(basis, field, seed = 1)
#' ep
#' autoplot(ep)
error_processes <- function(basis, field, site = 1L, seed = NULL, project = FALSE) {
  check_class(basis, "wv_basis")
  check_class(field, "wv_field")
  check_same_grid(basis$t, field$t, "basis", "field")
  site <- resolve_site(site, names(field$curves), "site")
  m <- field$curves[[site]]
  n_rep <- nrow(m)
  if (n_rep < 2L) wv_abort("Site {.val {site}} has {n_rep} replicate; the check needs at least two.")
  seed <- resolve_seed(seed)
  w <- basis_coef(basis, m)
  sigma2 <- colSums(sweep(w, 2L, colMeans(w))^2) / (n_rep - 1L)
  resid <- sweep(m, 2L, colMeans(m))
  if (isTRUE(project)) resid <- basis_curves(basis, basis_coef(basis, resid))
  z <- with_seed(seed, matrix(stats::rnorm(n_rep * length(sigma2)), n_rep))
  sim <- basis_curves(basis, sweep(z, 2L, sqrt(sigma2), `*`))
  out <- rbind(
    data.frame(curves_long(resid, basis$t, site, "replicate"), process = "field residuals"),
    data.frame(curves_long(sim, basis$t, site, "replicate"), process = "simulated")
  )
  out <- out[c("site", "process", "replicate", "t", "y")]
  structure(out, sigma2 = sigma2, seed = seed, class = c("wv_error_processes", "data.frame"))
}

with_seed <- function(seed, code) {
  env <- globalenv()
  old <- if (exists(".Random.seed", envir = env, inherits = FALSE)) get(".Random.seed", envir = env) else NULL
  on.exit(if (is.null(old)) rm(".Random.seed", envir = env) else assign(".Random.seed", old, envir = env))
  set.seed(seed)
  code
}

# Mean pointwise sd and mean lag-k autocorrelation of each process.
error_process_stats <- function(x, lags = c(1L, 10L)) {
  d <- as.data.frame(x)
  do.call(rbind, lapply(split(d, d$process), function(p) {
    m <- do.call(rbind, split(p$y, p$replicate))
    acf_k <- vapply(lags, function(k) mean(apply(m, 1L, function(y) stats::cor(y[-seq_len(k)], y[seq_len(length(y) - k)]))),
                    numeric(1))
    data.frame(process = p$process[1], mean_sd = mean(apply(m, 2L, stats::sd)),
               t(stats::setNames(acf_k, paste0("acf_lag", lags))))
  }))
}

#' @export
as.data.frame.wv_error_processes <- function(x, ...) {
  attr(x, "sigma2") <- attr(x, "seed") <- NULL
  class(x) <- "data.frame"
  x
}

#' @export
print.wv_error_processes <- function(x, ...) {
  cli::cat_line(sprintf("<wv_error_processes> site %s: %d field residual and %d simulated processes",
                        x$site[1], length(unique(x$replicate)), length(unique(x$replicate))))
  s <- error_process_stats(x)
  s[-1] <- signif(s[-1], 3)
  print(s, row.names = FALSE)
  invisible(x)
}

#' @export
summary.wv_error_processes <- function(object, ...) {
  structure(list(stats = error_process_stats(object), sigma2 = attr(object, "sigma2")),
            class = "summary_wv_error_processes")
}

#' @export
print.summary_wv_error_processes <- function(x, ...) {
  cli::cat_line("Residual vs simulated error processes:")
  print(x$stats, row.names = FALSE)
  cli::cat_line("Coefficient error variances: ", paste(format(signif(stats::quantile(x$sigma2, c(0, 0.5, 1)), 3)),
                                                        collapse = " / "), " (min / median / max)")
  invisible(x)
}

#' @rdname error_processes
#' @param object A `wv_error_processes` object.
#' @param ... Unused.
#' @export
autoplot.wv_error_processes <- function(object, ...) {
  d <- as.data.frame(object)
  d$replicate <- factor(d$replicate)
  ggplot2::ggplot(d, ggplot2::aes(.data$t, .data$y, colour = .data$replicate)) +
    ggplot2::geom_line(linewidth = 0.3) +
    ggplot2::facet_wrap(~process, nrow = 1) +
    ggplot2::labs(x = "time", y = "error process", colour = "replicate",
                  title = sprintf("Site %s: field residuals and processes from the error model", d$site[1])) +
    ggplot2::theme_bw()
}

#' @export
plot.wv_error_processes <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}
