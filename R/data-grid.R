# The time grid shared by the model runs and the field data: checks that a grid
# is dyadic and common, curves interpolated onto a dyadic grid, and a site list
# from a matrix or a list (used by model_runs(), field_runs() and the curves
# given on their own points).

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

check_grid <- function(t, call = rlang::caller_env()) {
  if (!is.numeric(t) || !is.null(dim(t))) {
    wv_abort("{.arg t} must be a numeric vector of time points, not {.obj_type_friendly {t}}.",
             call = call)
  }
  if (length(t) < 8L) {
    wv_abort("{.arg t} must have at least 8 time points; it has {length(t)}.", call = call)
  }
  if (any(!is.finite(t))) {
    wv_abort("{.arg t} must not contain NA or infinite values.", call = call)
  }
  if (any(diff(t) <= 0)) {
    i <- which(diff(t) <= 0)[1]
    wv_abort(c(
      "{.arg t} must be strictly increasing.",
      "x" = "t[{i + 1}] = {t[i + 1]} does not exceed t[{i}] = {t[i]}."
    ), call = call)
  }
  as.numeric(t)
}

# Turns a matrix or list of matrices into a named list of numeric matrices,
# checking dimensions.
as_site_list <- function(curves, site, n_rows, n_t, what, call = rlang::caller_env()) {
  if (is.data.frame(curves)) curves <- as.matrix(curves)
  if (is.matrix(curves)) curves <- list(curves)
  if (!is.list(curves) || length(curves) == 0L) {
    wv_abort("{.arg curves} must be a matrix (one site) or a list of matrices (one per site).",
             call = call)
  }
  nm <- names(curves)
  if (!is.null(site)) {
    if (!is.character(site) || length(site) != length(curves)) {
      wv_abort("{.arg site} must give one name per site ({length(curves)}).", call = call)
    }
    nm <- site
  }
  if (is.null(nm)) nm <- if (length(curves) == 1L) "site1" else paste0("site", seq_along(curves))
  if (anyNA(nm) || any(!nzchar(nm)) || anyDuplicated(nm)) {
    wv_abort("Site names must be unique and non-empty.", call = call)
  }
  names(curves) <- nm
  for (s in nm) {
    m <- curves[[s]]
    if (is.data.frame(m)) m <- as.matrix(m)
    if (is.numeric(m) && is.null(dim(m))) m <- matrix(m, nrow = 1L)
    if (!is.matrix(m) || !is.numeric(m)) {
      wv_abort("Curves of site {.val {s}} must be a numeric matrix, one row per {if (what == 'runs') 'run' else 'replicate'}.",
               call = call)
    }
    if (ncol(m) != n_t) {
      wv_abort(c(
        "{.arg curves} must have one column per time point.",
        "x" = "Site {.val {s}} has {ncol(m)} column{?s} and {.arg t} has {n_t} value{?s}."
      ), call = call)
    }
    if (!is.null(n_rows) && nrow(m) != n_rows) {
      wv_abort(c(
        "{.arg curves} must have one row per run of {.arg design}.",
        "x" = "Site {.val {s}} has {nrow(m)} row{?s} and {.arg design} has {n_rows}."
      ), call = call)
    }
    if (nrow(m) == 0L) wv_abort("Site {.val {s}} has no curves.", call = call)
    storage.mode(m) <- "double"
    dimnames(m) <- NULL
    curves[[s]] <- m
  }
  curves
}

is_dyadic_grid <- function(t) {
  n <- length(t)
  h <- diff(t)
  bitwAnd(n, n - 1L) == 0L && max(abs(h - mean(h))) <= 1e-8 * max(1, abs(mean(h)))
}

# Linear interpolation of every curve to 2^ceiling(log2(T)) equally spaced
# points on [min(t), max(t)], unless the grid is dyadic already.
to_dyadic <- function(t, curves) {
  if (is_dyadic_grid(t)) return(list(t = t, curves = curves))
  t_new <- dyadic_grid(t)
  wv_inform(c(
    "i" = "The grid of {length(t)} point{?s} is not dyadic; curves were linearly interpolated to {length(t_new)} equally spaced points on [{signif(t[1], 4)}, {signif(t[length(t)], 4)}]."
  ))
  list(t = t_new, curves = interpolate_curves(t, curves, t_new))
}

# 2^ceiling(log2(T)) equally spaced points on [min(t), max(t)].
dyadic_grid <- function(t) seq(t[1], t[length(t)], length.out = 2L^ceiling(log2(length(t))))

# Every curve (rows of each matrix of the list `curves`, at times `t`)
# linearly interpolated to `t_new`; `rule` as in stats::approx() (2: held at
# the end values beyond `t`).
interpolate_curves <- function(t, curves, t_new, rule = 1) {
  lapply(curves, function(m) {
    out <- t(apply(m, 1L, function(y) stats::approx(t, y, xout = t_new, rule = rule)$y))
    if (nrow(m) == 1L) out <- matrix(out, nrow = 1L)
    out
  })
}
