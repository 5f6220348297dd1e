# Curves as they come: each curve on its own time points (a list of `t` by
# site) and long data frames (one row per measured value), for field_runs()
# and model_runs(). Both are turned into one curve per site and replicate (or
# run), each with its own times, then onto one grid.

# Is this a call in the long form: a data frame of curves and `t` a column name?
is_long_form <- function(curves, t) is.data.frame(curves) && is.character(t)

# The curves of a long data frame: list(t, curves), each a list by site of
# lists by replicate (or run) of vectors, rows of a curve ordered by time, and
# `ids` the replicate (run) values by site. `cols` names the columns: t, y and
# optionally site and id (the replicate or run column).
long_curves <- function(data, cols, id_arg, strict, call = rlang::caller_env()) {
  for (arg in names(cols)) {
    col <- cols[[arg]]
    if (is.null(col)) next
    if (!is.character(col) || length(col) != 1L || is.na(col) || !nzchar(col)) {
      wv_abort(c("{.arg {arg}} must name one column of {.arg data} (a string) in the long form.",
                 "x" = "It is {.obj_type_friendly {col}}."), class = c("column", "input"),
               call = call)
    }
    if (!col %in% names(data)) {
      near <- names(data)[utils::adist(col, names(data), ignore.case = TRUE) <= 2]
      wv_abort(c("Column {.val {col}} (given as {.arg {arg}}) is not in {.arg data}.",
                 "i" = "Its columns are {.val {names(data)}}.",
                 "i" = if (length(near)) "Did you mean {.code {arg} = \"{near[1]}\"}?"),
               class = c("column", "input"), call = call)
    }
  }
  if (is.null(cols$y)) {
    wv_abort(c("The long form needs the column of the curves' values.",
               "i" = "Name it with {.arg y}, e.g. {.code y = \"stress\"}."),
             class = c("column", "input"), call = call)
  }
  for (arg in c("t", "y")) {
    v <- data[[cols[[arg]]]]
    if (!is.numeric(v)) {
      wv_abort("Column {.val {cols[[arg]]}} ({.arg {arg}}) must be numeric, not {.obj_type_friendly {v}}.",
               class = c("column", "input"), call = call)
    }
  }
  if (anyNA(data[[cols$t]]) || any(!is.finite(data[[cols$t]]))) {
    wv_abort("Column {.val {cols$t}} ({.arg t}) must not hold NA or infinite times; row {which(!is.finite(data[[cols$t]]))[1]} does.",
             class = c("column", "input"), call = call)
  }
  key <- function(col) {
    if (is.null(col)) return(list(values = "site1", index = rep(1L, nrow(data))))
    v <- data[[col]]
    if (anyNA(v)) wv_abort("Column {.val {col}} must not hold NA; row {which(is.na(v))[1]} does.",
                           class = c("column", "input"), call = call)
    lev <- if (is.factor(v)) levels(droplevels(v)) else as.character(sort(unique(v)))
    list(values = lev, index = match(as.character(v), lev))
  }
  site <- key(cols$site)
  id <- key(cols[[id_arg]])
  out_t <- out_y <- ids <- stats::setNames(vector("list", length(site$values)), site$values)
  for (k in seq_along(site$values)) {
    rows_s <- which(site$index == k)
    reps <- sort(unique(id$index[rows_s]))
    ids[[k]] <- id$values[reps]
    out_t[[k]] <- out_y[[k]] <- vector("list", length(reps))
    for (r in seq_along(reps)) {
      rows <- rows_s[id$index[rows_s] == reps[r]]
      tt <- data[[cols$t]][rows]
      if (anyDuplicated(tt) && (strict || is.unsorted(tt))) {
        d <- tt[duplicated(tt)][1]
        who <- paste0("Site ", site$values[k],
                      if (!is.null(cols[[id_arg]])) paste0(", ", id_arg, " ", ids[[k]][r]))
        wv_abort(c("{who}: the time {signif(d, 6)} appears {sum(tt == d)} times.",
                   "x" = if (strict) "A model run has one value per time." else
                     "Its rows are not in time order, so these are not read as repeated measurements.",
                   "i" = if (is.null(cols[[id_arg]])) "If the rows hold several curves, name the column that tells them apart with {.arg {id_arg}}.",
                   "i" = if (!strict) "If they are repeated measurements at one time, sort the rows of each curve by time."),
                 class = c("stamps", "input"), call = call)
      }
      o <- order(tt)
      out_t[[k]][[r]] <- tt[o]
      out_y[[k]][[r]] <- data[[cols$y]][rows][o]
    }
  }
  list(t = out_t, curves = out_y, ids = ids)
}

# Curves each on their own times: `t` a list by site, each a vector (all
# replicates of the site on it) or a list by replicate; `curves` a list by
# site, each a vector (one replicate), a list of vectors, or a matrix with
# one row per replicate on the site's vector of times. Returns a list by site
# of lists of list(t, y), checked: times finite, non-decreasing (`strict`:
# increasing), at least 8 distinct, one value each.
own_points <- function(curves, t, site, strict, what, labels = NULL, call = rlang::caller_env()) {
  unit <- if (what == "runs") "run" else "replicate"
  if (!is.list(curves) || is.data.frame(curves) || length(curves) != length(t)) {
    wv_abort(c("With {.arg t} a list by site, {.arg curves} must be a list with one element per site.",
               "x" = "{.arg t} has {length(t)} element{?s}; {.arg curves} is {.obj_type_friendly {curves}}{if (is.list(curves)) paste0(' of length ', length(curves)) else ''}.",
               "i" = "Give each site's curves as a vector (one {unit}), a list of vectors (one per {unit}) or a matrix."),
             call = call)
  }
  nm <- site %||% names(curves) %||% names(t)
  if (!is.null(site) && length(site) != length(curves)) {
    wv_abort("{.arg site} must give one name per site ({length(curves)}).", call = call)
  }
  if (is.null(nm)) nm <- paste0("site", seq_along(curves))
  if (anyNA(nm) || any(!nzchar(nm)) || anyDuplicated(nm))
    wv_abort("Site names must be unique and non-empty.", call = call)
  if (is.null(site) && !is.null(names(curves)) && !is.null(names(t))) {
    if (!setequal(names(t), names(curves))) {
      wv_abort(c("{.arg t} and {.arg curves} must name the same sites.",
                 "x" = "{.arg t} names {.val {names(t)}}; {.arg curves} {.val {names(curves)}}."),
               call = call)
    }
    t <- t[names(curves)]
  }
  out <- stats::setNames(vector("list", length(nm)), nm)
  for (k in seq_along(nm)) {
    ys <- curves[[k]]
    if (is.matrix(ys) || is.data.frame(ys)) ys <- lapply(seq_len(nrow(ys)),
                                                         function(r) as.numeric(as.matrix(ys)[r, ]))
    if (is.numeric(ys)) ys <- list(ys)
    ts <- t[[k]]
    if (!is.list(ts)) ts <- rep(list(ts), length(ys))
    if (!is.list(ys) || length(ts) != length(ys)) {
      wv_abort(c("Site {.val {nm[k]}}: {.arg t} and {.arg curves} must hold one curve per {unit} alike.",
                 "x" = "{.arg t} has {length(ts)} and {.arg curves} {if (is.list(ys)) length(ys) else 'no'} curve{?s}."),
               call = call)
    }
    if (!length(ys)) wv_abort("Site {.val {nm[k]}} has no curves.", call = call)
    out[[k]] <- lapply(seq_along(ys), function(r) {
      who <- sprintf("Site %s, %s", nm[k], curve_label(labels, nm[k], r, unit))
      check_own_curve(ts[[r]], ys[[r]], who, strict, call)
    })
  }
  out
}

check_own_curve <- function(tt, y, who, strict, call) {
  if (!is.numeric(tt) || !is.null(dim(tt)) || !is.numeric(y) || !is.null(dim(y))) {
    wv_abort("{who}: the times and the values must be numeric vectors.", call = call)
  }
  if (length(tt) != length(y)) {
    wv_abort("{who}: {length(tt)} time{?s} but {length(y)} value{?s}; give one value per time.",
             call = call)
  }
  if (any(!is.finite(tt))) wv_abort("{who}: the times must not hold NA or infinite values.",
                                    call = call)
  if (any(diff(tt) < 0) || (strict && any(diff(tt) == 0))) {
    i <- which(if (strict) diff(tt) <= 0 else diff(tt) < 0)[1]
    wv_abort(c("{who}: the times must be {if (strict) 'increasing' else 'non-decreasing (a time may repeat: a repeated measurement)'}.",
               "x" = "Time {i + 1} is {tt[i + 1]}, time {i} is {tt[i]}."),
             class = c("stamps", "input"), call = call)
  }
  n <- length(unique(tt))
  if (n < 8L) {
    wv_abort(c("{who} has {n} distinct time{?s}; a curve needs at least 8.",
               "i" = "Drop the curve, or measure it at more times."), class = c("stamps", "input"),
             call = call)
  }
  list(t = as.numeric(tt), y = as.numeric(y))
}

# The times all curves share, or NULL when they differ.
common_times <- function(pts) {
  first <- pts[[1]][[1]]$t
  same <- all(vapply(pts,
                     function(p) all(vapply(p, function(cv) identical(cv$t, first), logical(1))),
                     logical(1)))
  if (same) first
}

# The grid for curves on their own times: `grid` (dyadic; where it reaches
# beyond every curve, no curve is observed), or 2^k equally spaced
# points on that range (the longest record), 2^k the next power of two of
# the most distinct times of any curve. A curve that ends earlier (or
# starts later) is missing beyond its own extent (own_extent_mask()); each
# curve must cover at least 8 points of the grid.
own_points_grid <- function(pts, grid, labels = NULL, call = rlang::caller_env()) {
  curves <- unlist(pts, recursive = FALSE)
  firsts <- vapply(curves, function(cv) cv$t[1], numeric(1))
  lasts <- vapply(curves, function(cv) cv$t[length(cv$t)], numeric(1))
  lo <- min(firsts)
  hi <- max(lasts)
  n_range <- range(vapply(curves, function(cv) length(unique(cv$t)), integer(1)))
  n_text <- if (n_range[1] == n_range[2]) n_range[1] else paste(n_range, collapse = " to ")
  own <- diff(range(firsts)) > 0 || diff(range(lasts)) > 0
  if (!is.null(grid)) {
    # the grid may reach beyond every curve: no curve is observed there
    grid <- check_field_grid(grid, range(c(grid, firsts, lasts)), call = call)
    own <- own || grid[1] < lo || grid[length(grid)] > hi
    wv_inform(c("i" = "The curves were linearly interpolated from their own times ({n_text} per curve) to the {length(grid)} points of {.arg grid}{if (own) ', each over its own extent' else ''}."))
  } else {
    grid <- seq(lo, hi, length.out = 2L^ceiling(log2(n_range[2])))
    wv_inform(c("i" = "The curves were linearly interpolated from their own times ({n_text} per curve) to {length(grid)} equally spaced points on [{signif(lo, 4)}, {signif(hi, 4)}]{if (own) ', the longest record; each curve is observed over its own extent' else ', the range every curve covers'}."))
  }
  for (s in names(pts)) {
    for (r in seq_along(pts[[s]])) {
      n_in <- sum(own_extent(pts[[s]][[r]]$t, grid))
      if (n_in < 8L) {
        wv_abort(c("Site {.val {s}}, {curve_label(labels, s, r, 'curve')} covers {n_in} point{?s} of the grid; a curve needs at least 8.",
                   "i" = "Give a finer {.arg grid}, or leave the curve out."), class = "grid", call = call)
      }
    }
  }
  grid
}

# The grid points a curve measured at times `tt` covers: within its first
# and last times up to one step of the grid.
own_extent <- function(tt, grid) {
  h <- if (length(grid) > 1L) grid[2] - grid[1] else 0
  grid >= tt[1] - h * (1 - 1e-9) & grid <= tt[length(tt)] + h * (1 - 1e-9)
}

# By site, the R x T mask of the grid points each curve covers (NULL for a
# site whose curves all cover the whole grid; NULL when none is cut).
own_extent_mask <- function(pts, grid) {
  out <- lapply(pts, function(p) do.call(rbind, lapply(p, function(cv) own_extent(cv$t, grid))))
  out[vapply(out, all, logical(1))] <- list(NULL)
  if (all(vapply(out, is.null, logical(1)))) NULL else out
}

# Curves (R x T) with their values where they are missing (`observed`
# FALSE) filled. Where other curves cover the point, a curve keeps its
# deviation from them at its nearest covered point (its unit's offset, or
# its noise there: the mean of the covering curves is then not moved by
# which curves cover); where none does, it is held at its nearest covered
# value. What the fill carries is weighted in the likelihood by
# missing_fill_variance().
fill_missing <- function(m, observed) {
  if (is.null(observed)) return(m)
  y <- m
  n_at <- colSums(observed)
  for (r in seq_len(nrow(m))) {
    own <- which(observed[r, ])
    if (!length(own)) next
    for (j in which(!observed[r, ])) {
      b <- own[which.min(abs(own - j))]
      both <- which(observed[, j] & observed[, b])
      y[r, j] <- if (length(both)) {
        m[r, b] + mean(m[both, j]) - mean(m[both, b])
      } else if (n_at[j] > 0L) mean(m[observed[, j], j]) else m[r, b]
    }
  }
  y
}

# How a message names curves `r` of site `s`: by the user's id column
# (`labels`, by site, e.g. "subject S07") when the data came with one, else
# by position ("replicate 3").
curve_label <- function(labels, s, r, what = "replicate") {
  if (!is.null(labels[[s]])) labels[[s]][r] else paste(what, r)
}
