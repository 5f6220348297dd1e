# The engine behind the bands: curve draws at a site rebuilt on demand from the
# coefficient draws of a fit (curve sources), the draws of the field detail
# outside the retained basis, and their random streams.

# Pure-model curve of eq. (24) at one site: Psi m(z_hat).
pure_model_curve <- function(fit, site, z = posterior_mean_inputs(fit)) {
  bank <- site_bank(fit$emulators, site)
  m <- bank_predict(bank, shift_inputs(fit, site, matrix(z[fit$inputs], nrow = 1L,
                                                         dimnames = list(NULL, fit$inputs))))$mean
  drop(fit$basis$Psi %*% t(m))
}

# --- curve draws on demand ------------------------------------------------------
# A source of curve draws: H draws on n time points, handed out block by block
# of time points by block(cols) (consecutive columns, in increasing order
# within a pass over the blocks). Passes can be repeated and give the same
# values. Summaries read the curves in a few passes, so that the H x n curves
# of a site are never held whole; source_matrix() builds them when they are
# wanted.
#
# A source whose curves are W %*% t(B) (+ W2 %*% t(B2)) + offset (each curve)
# also carries `linear` = list(W, B, W2, B2, offset) (W2, B2 optional): the
# summaries then rebuild its blocks in C++ (band_block_into_cpp()), and
# block(cols) gives the same values.
curve_source <- function(H, n, block, linear = NULL) {
  if (!is.null(linear)) {
    block <- function(cols) {
      Y <- linear_block(linear, cols)
      if (length(linear$offset)) Y + rep(linear$offset[cols], each = H) else Y
    }
  }
  list(H = H, n = n, block = block, linear = linear)
}

# The curves of a source minus `shift` (a curve) from each.
shift_source <- function(src, shift) {
  lin <- src$linear
  if (!is.null(lin)) {
    lin$offset <- if (length(lin$offset)) lin$offset - shift else -shift
    return(curve_source(src$H, src$n, NULL, lin))
  }
  curve_source(src$H, src$n, function(cols) src$block(cols) - rep(shift[cols], each = src$H))
}

matrix_source <- function(Y) curve_source(nrow(Y), ncol(Y), function(cols) Y[, cols, drop = FALSE])

source_matrix <- function(src) {
  Y <- matrix(0, src$H, src$n)
  for (cols in col_blocks(src$n, src$H)) Y[, cols] <- src$block(cols)
  Y
}


# W %*% t(B[cols, ]) (+ W2 %*% t(B2[cols, ])) of a linear source, as
# band_block_into_cpp() computes it.
linear_block <- function(linear, cols) {
  Y <- basis_curves_block(linear$W, linear$B, cols)
  if (is.null(linear$W2)) return(Y)
  Y + basis_curves_block(linear$W2, linear$B2, cols)
}

# Consecutive blocks of column indices, each of about `cells` matrix cells for
# H rows: the unit of work of the curve summaries.
col_blocks <- function(n_col, H, cells = 2^20) {
  if (n_col < 1L) return(list())
  size <- max(1L, min(n_col, floor(cells / max(H, 1L))))
  starts <- seq.int(1L, n_col, by = size)
  lapply(starts, function(a) a:min(n_col, a + size - 1L))
}

# Source of the curve draws at one site, rebuilt from the coefficient draws:
# "bias" (Psi w^b), "reality" (Psi (w^M + w^b)), "model" (Psi w^M) or
# "field_run" (reality plus eps ~ N(0, sigma2) on every coefficient, drawn
# here); with `residual`, reality also carries the field detail outside the
# basis (residual_source(), to be read within the fit's stream for the site:
# see site_curves()).
draw_source <- function(fit, site, what = c("bias", "reality", "model", "field_run"), seed = NULL,
                        residual = FALSE) {
  what <- match.arg(what)
  if (!site %in% names(fit$wb)) {
    wv_abort("{.arg site} must be one of {.val {names(fit$wb)}}, not {.val {site}}.")
  }
  W <- switch(what,
    bias = fit$wb[[site]],
    reality = fit$wM[[site]] + fit$wb[[site]],
    model = fit$wM[[site]],
    field_run = {
      S <- fit$sigma2[[site]]
      eps <- with_draw_seed(seed, matrix(stats::rnorm(length(S)), nrow(S)) * sqrt(S))
      fit$wM[[site]] + fit$wb[[site]] + eps
    }
  )
  Psi <- fit$basis$Psi
  extra <- if (residual && what == "reality") residual_source(fit, site, nrow(W))
  if (is.null(extra)) return(curve_source(nrow(W), nrow(Psi), NULL,
                                          list(W = W, B = Psi, offset = numeric())))
  lin <- attr(extra, "linear")
  if (!is.null(lin)) {
    return(curve_source(nrow(W), nrow(Psi), NULL, list(W = W, B = Psi, W2 = lin$W, B2 = lin$B,
                                                       offset = lin$offset)))
  }
  curve_source(nrow(W), nrow(Psi), function(cols) basis_curves_block(W, Psi, cols) + extra(cols))
}

# fun(source) for the curve draws of one site (see draw_source()); the draws of
# the field detail come from a stream fixed by the fit's seed, so the bands of
# a fit are reproducible and the caller's stream is left alone.
site_curves <- function(fit, site, what, seed = NULL, residual = FALSE, fun) {
  if (residual && what == "reality") {
    with_rng_seed(residual_seed(fit, site),
                  fun(draw_source(fit, site, what, seed, residual = TRUE)))
  } else {
    fun(draw_source(fit, site, what, seed))
  }
}

# H x T matrix of the curve draws at one site (see draw_source()).
curve_draws <- function(fit, site, what = c("bias", "reality", "model", "field_run"), seed = NULL,
                        residual = FALSE) {
  what <- match.arg(what)
  site_curves(fit, site, what, seed, residual, fun = source_matrix)
}

# H x T draws of the field detail outside the retained basis at one site: the
# replicates' mean detail plus a draw of its sampling error (and, for a new
# field run, of a new replicate's detail). With R >= 2 replicates the error
# draws are G D, G an H x R matrix of N(0, c / (R - 1)) weights and D the
# replicates' deviations from their mean outside the basis, whose covariance
# is c times the replicates' empirical covariance; c = 1 / R for the mean
# (plus 1 for a new replicate); each draw is scaled by sqrt((R - 1) / chi2),
# chi2 on R - 1 degrees of freedom, so that pointwise bands are Student t
# intervals. With one replicate: white noise of variance c times the median
# field variance of each posterior draw.
residual_draws <- function(fit, site, H, new_run = FALSE) {
  src <- residual_source(fit, site, H, new_run)
  source_matrix(curve_source(H, ncol(fit$field$curves[[site]]), src))
}

# The draws of residual_draws() as a function of a block of time points: the
# weights G and the chi2 scales are drawn here, the white noise of a single
# replicate block by block (replayable_normals()).
residual_source <- function(fit, site, H, new_run = FALSE) {
  Y <- fit$field$curves[[site]]
  R <- nrow(Y)
  ybar <- colMeans(Y)
  detail <- drop(basis_remainder(fit$basis, matrix(ybar, nrow = 1L)))
  scale <- 1 / R + as.numeric(new_run)
  if (R >= 2L) {
    D <- basis_remainder(fit$basis, sweep(Y, 2L, ybar))
    G <- matrix(stats::rnorm(H * R, sd = sqrt(scale / (R - 1))), H)
    # the replicates' variance is itself estimated on R - 1 degrees of freedom
    chi <- sqrt((R - 1) / stats::rchisq(H, R - 1))
    # linear in the weights: (chi G) D + detail (see curve_source())
    structure(function(cols) (G %*% D[, cols, drop = FALSE]) * chi + rep(detail[cols], each = H),
              linear = list(W = G * chi, B = t(D), offset = detail))
  } else {
    S <- fit$sigma2[[site]]
    idx <- rep_len(seq_len(nrow(S)), H)
    sd_draw <- sqrt(scale * apply(S[idx, , drop = FALSE], 1L, stats::median))
    normals <- replayable_normals(H)
    function(cols) matrix(normals(cols), H) * sd_draw + rep(detail[cols], each = H)
  }
}

# Standard normal draws filling an H-row matrix block by block of columns.
# The first pass over the blocks draws from the current stream, which ends as
# if the whole matrix had been drawn at once; later passes replay the same
# numbers from a private copy of the stream and leave the current one alone.
replayable_normals <- function(H) {
  start <- NULL
  replay <- NULL
  drawn <- 0L
  function(cols) {
    n <- H * length(cols)
    if (cols[1L] > drawn) {
      if (is.null(start)) start <<- rng_state()
      drawn <<- cols[length(cols)]
      return(stats::rnorm(n))
    }
    if (cols[1L] == 1L) replay <<- start
    current <- rng_state()
    on.exit(assign(".Random.seed", current, envir = globalenv()), add = TRUE)
    assign(".Random.seed", replay, envir = globalenv())
    z <- stats::rnorm(n)
    replay <<- get(".Random.seed", envir = globalenv(), inherits = FALSE)
    z
  }
}

rng_state <- function() {
  if (!exists(".Random.seed", envir = globalenv(), inherits = FALSE)) stats::runif(1L)
  get(".Random.seed", envir = globalenv(), inherits = FALSE)
}

# A stream for the detail draws fixed by the fit, one per site.
residual_seed <- function(fit, site) {
  as.integer(fit$seed %% 1e6 + match(site, names(fit$wb)))
}

with_draw_seed <- function(seed, code) {
  if (is.null(seed)) code else with_rng_seed(seed, code)
}
