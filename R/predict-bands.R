#' Bias, reality and pure-model prediction with tolerance bands
#'
#' Curves are rebuilt draw by draw from the posterior coefficient draws of a
#' [calibrate()] fit (report section 5.2), one site at a time:
#' bias `b^h = Psi w^b_h`, reality `y^R_h = Psi (w^M_h + w^b_h)`. They are
#' rebuilt on demand, a block of time points at a time, while the bands are
#' computed, so that the curve draws of a site (draws x time points) are never
#' held whole.
#'
#' The retained basis leaves out the finest detail of the curves (the small
#' features the emulators are not asked to follow). With `residual = TRUE`
#' (default) reality also carries that detail as the field replicates show
#' it: the part of their mean outside the retained basis, plus a draw of its
#' sampling error (the replicates' own deviations outside the basis, mixed
#' with Gaussian weights, so its covariance is the replicates' empirical
#' covariance over the number of replicates, and scaled so that pointwise
#' bands are Student t intervals; with a single replicate, white noise of the
#' fit's field variance). This goes beyond the method's report,
#' whose reality lives on the retained basis only (`residual = FALSE`); the
#' bias is always the modelled bias on the retained basis. The draws of the
#' detail use a stream fixed by the fit's seed, so the bands of a fit are
#' reproducible.
#'
#' Two bands are given at each `t`:
#' * `lower`, `upper`: pointwise `(1 - level) / 2` and `(1 + level) / 2`
#'   quantiles of the curve draws (eq. 22-23);
#' * `lower_curve`, `upper_curve`: a simultaneous band holding whole curves.
#'   Each curve draw is scored by its largest standardised distance from the
#'   pointwise mean, `max_t |y_h(t) - mean(t)| / sd(t)`; the `ceiling(level * H)`
#'   curves with the smallest scores are kept and the band is their pointwise
#'   envelope. At most `100 (1 - level)`\% of the curve draws leave it, and,
#'   because the score follows the pointwise spread, it is close to the
#'   narrowest band with that property.
#'
#' `model_prediction()` gives the pure-model prediction of eq. (24): `mean` is
#' `Psi m(z_hat)`, the emulator mean at the posterior mean of the inputs. Its
#' error as a prediction of reality is judged from the draws
#' `y^R_h - mean` (section 5.2): `error_mean`, `error_lower`, `error_upper`
#' are their pointwise mean and quantiles; `lower`, `upper` (= `mean` plus the
#' error quantiles) and `lower_curve`, `upper_curve` bound reality around the
#' pure-model curve.
#'
#' @param fit A `wv_fit` object, from [calibrate()] or [validate()].
#' @param level Credibility: the probability content of the bands (default
#'   0.9).
#' @param residual Add the detail of the field curves outside the retained
#'   basis to reality (see Details).
#' @return A data frame with columns `site`, `t`, `mean`, `lower`, `upper`,
#'   `lower_curve`, `upper_curve` (and the `error_*` columns for
#'   `model_prediction()`).
#' @name bands
#' @examples
#' fit <- example_fit()
#' head(bias(fit))
#' head(reality(fit, level = 0.8))
#' head(model_prediction(fit))
NULL

#' @rdname bands
#' @export
bias <- function(fit, level = 0.9) {
  check_class(fit, "wv_fit")
  check_level(level)
  do.call(rbind, lapply(fit_sites(fit), function(s) {
    site_curves(fit, s, "bias",
                fun = function(src) band_frame(src, fit_get(fit, "basis")$t, s, level))
  }))
}

#' @rdname bands
#' @export
reality <- function(fit, level = 0.9, residual = TRUE) {
  check_class(fit, "wv_fit")
  check_level(level)
  check_flag(residual)
  do.call(rbind, lapply(fit_sites(fit), function(s) {
    site_curves(fit, s, "reality", residual = residual,
                fun = function(src) band_frame(src, fit_get(fit, "basis")$t, s, level))
  }))
}

#' @rdname bands
#' @export
model_prediction <- function(fit, level = 0.9, residual = TRUE) {
  check_class(fit, "wv_fit")
  check_level(level)
  check_flag(residual)
  do.call(rbind, lapply(fit_sites(fit), function(s) {
    y_hat <- pure_model_curve(fit, s)
    b <- site_curves(fit, s, "reality", residual = residual, fun = function(src) {
      band_frame(shift_source(src, y_hat), fit_get(fit, "basis")$t, s, level)
    })
    data.frame(site = s, t = fit_get(fit, "basis")$t, mean = y_hat,
               lower = y_hat + b$lower, upper = y_hat + b$upper,
               lower_curve = y_hat + b$lower_curve, upper_curve = y_hat + b$upper_curve,
               error_mean = b$mean, error_lower = b$lower, error_upper = b$upper,
               stringsAsFactors = FALSE)
  }))
}

# Pointwise mean of reality's curve draws at every site, the `mean` of
# reality() without its bands (one pass over the blocks of each site): a data
# frame with `site`, `t`, `mean`.
reality_mean <- function(fit, residual = TRUE) {
  do.call(rbind, lapply(fit_sites(fit), function(s) {
    site_curves(fit, s, "reality", residual = residual, fun = function(src) {
      data.frame(site = s, t = fit_get(fit, "basis")$t, mean = curve_means(src),
                 stringsAsFactors = FALSE)
    })
  }))
}

# Pointwise mean of a source's curves, as curve_bands() computes it.
curve_means <- function(src) {
  src <- prepare_source(src)
  if (!is.null(src$linear)) on.exit(band_block_release_cpp(), add = TRUE)
  out <- block_outputs(src$n, 0L, 0L)
  threads <- band_threads()
  for (cols in col_blocks(src$n, src$H)) block_stats_into(src, cols, numeric(), 0L, out,
                                                          scores = FALSE, threads = threads)
  out$mean
}

# A source ready for block_stats_into(): its linear form in doubles.
prepare_source <- function(src) {
  lin <- src$linear
  if (!is.null(lin)) {
    if (!is.double(lin$W)) storage.mode(lin$W) <- "double"
    if (!is.null(lin$W2) && !is.double(lin$W2)) storage.mode(lin$W2) <- "double"
    lin$offset <- as.numeric(lin$offset)
    src$linear <- lin
  }
  src
}

# The outputs of the block statistics for n time points, np quantiles and nc
# candidates at each end (see band_block_into_cpp(), which writes them in
# place: each is made here and for this alone, not initialised).
block_outputs <- function(n, np, nc) band_outputs_cpp(as.integer(n), as.integer(np), as.integer(nc))

# The statistics of the block `cols` of a source, written into `out` at its
# columns; returns each curve's largest distance over the block (`zmax`;
# -Inf without `scores`) and the smallest spread (`smin`).
# `threads`: the block's time points shared out among that many threads, the
# same numbers (band_threads()).
block_stats_into <- function(src, cols, probs, nc, out, scores = TRUE, threads = 1L) {
  lin <- src$linear
  none <- matrix(0, 0L, 0L)
  if (is.null(lin)) {
    band_block_into_cpp(src$block(cols), none, none, none, none, as.integer(cols), numeric(),
                        as.numeric(probs), nc,
                        out, scores, threads)
  } else {
    band_block_into_cpp(none, lin$W, lin$B, lin$W2 %||% none, lin$B2 %||% none, as.integer(cols),
                        lin$offset,
                        as.numeric(probs), nc, out, scores, threads)
  }
}

# Threads for the curve summaries (each block's time points shared out, the
# same numbers under any count): the cores this R process may use
# (future::availableCores(): 1 within a future's worker), or the number set by
# options(wavevalid.workers = ) (1 keeps them on one).
band_threads <- function() {
  want <- getOption("wavevalid.workers", "auto")
  if (is.numeric(want) && length(want) == 1L && is.finite(want) && want >= 1) return(as.integer(want))
  if (!requireNamespace("future", quietly = TRUE)) return(1L)
  max(1L, as.integer(future::availableCores()))
}

# --- bands ----------------------------------------------------------------------

# x: an H x T matrix of curve draws or a curve source.
band_frame <- function(x, t, site, level) {
  a <- (1 - level) / 2
  b <- curve_bands(if (is.matrix(x)) matrix_source(x) else x, level, c(a, 1 - a))
  data.frame(site = site, t = t, mean = b$mean, lower = b$q[1, ], upper = b$q[2, ],
             lower_curve = b$lower, upper_curve = b$upper, stringsAsFactors = FALSE)
}

# Pointwise mean and `probs` quantiles and the simultaneous band of a source's
# curves: (1) mean, spread and quantiles at each t and each curve's largest
# standardised distance from the mean, max_t |y_h(t) - mean(t)| / sd(t), in
# one pass over blocks of time points (band_block_into_cpp()); (2) the envelope of
# the ceiling(level * H) curves with the smallest distances. For (2) the pass
# keeps, at each t, the H - ceiling(level * H) + 1 smallest and largest values
# and their curves (one of them is a kept curve) when they are few (at most a
# quarter of the draws), and reads the blocks a second time otherwise. A block
# whose spread falls below the floor of sd (1e-12 of its largest value) is
# read again for the distances.
curve_bands <- function(src, level, probs = numeric()) {
  H <- src$H
  blocks <- col_blocks(src$n, H)
  n_keep <- ceiling(level * H)
  n_cand <- H - n_keep + 1L
  cand <- n_cand <= max(1L, H %/% 4L)
  # a bar when the blocks are many (cli shows it only after two seconds)
  bar <- length(blocks) >= 4L && !isTRUE(getOption("wavevalid.quiet", FALSE))
  if (bar) {
    cli::cli_progress_bar("Summarising curve draws", total = (2L - cand) * length(blocks),
                          .envir = environment())
  }
  env <- environment()
  tick <- function() if (bar) cli::cli_progress_update(.envir = env)
  zmax <- matrix(-Inf, H, length(blocks))
  smin <- numeric(length(blocks))
  nc <- if (cand) n_cand else 0L
  src <- prepare_source(src)
  if (!is.null(src$linear)) on.exit(band_block_release_cpp(), add = TRUE)
  out <- block_outputs(src$n, length(probs), nc)
  threads <- band_threads()
  for (k in seq_along(blocks)) {
    tick()
    st <- block_stats_into(src, blocks[[k]], probs, nc, out, threads = threads)
    zmax[, k] <- st$zmax
    smin[k] <- st$smin
  }
  centre <- out$mean
  ss <- out$ss
  q <- out$q
  s <- sqrt(ss / max(H - 1, 1))
  s_floor <- 1e-12 * max(s, 1e-300)
  s <- pmax(s, s_floor)
  # blocks with a spread below the floor: their distances again, with it
  for (k in which(smin < s_floor)) {
    cols <- blocks[[k]]
    zmax[, k] <- band_score_cpp(src$block(cols), centre[cols], s[cols])
  }
  score <- if (length(blocks)) do.call(pmax,
                                       lapply(seq_along(blocks),
                                              function(k) zmax[, k])) else rep(-Inf, H)
  keep <- order(score)[seq_len(n_keep)]
  dropped <- rep(TRUE, H)
  dropped[keep] <- FALSE
  if (cand) {
    lower <- band_envelope_cpp(out$lo_val, out$lo_idx, dropped, TRUE)
    upper <- band_envelope_cpp(out$hi_val, out$hi_idx, dropped, FALSE)
  } else {
    lower <- upper <- numeric(src$n)
    none <- matrix(0L, 0L, 0L)
    for (cols in blocks) {
      tick()
      Y <- src$block(cols)
      lower[cols] <- band_envelope_cpp(Y, none, dropped, TRUE)
      upper[cols] <- band_envelope_cpp(Y, none, dropped, FALSE)
    }
  }
  list(mean = centre, q = q, lower = lower, upper = upper, score = score, keep = keep)
}

# Type-7 quantiles of every column of Y (length(probs) x T), from the order
# statistics they need (a partial sort of one column at a time).
pointwise_quantiles <- function(Y, probs) {
  band_block_cpp(Y, as.numeric(probs), 0L)$q
}

# Band holding the ceiling(level * H) curves of Y closest to the pointwise
# mean (see curve_bands()).
simultaneous_band <- function(Y, level) {
  curve_bands(matrix_source(Y), level)[c("lower", "upper", "score", "keep")]
}
