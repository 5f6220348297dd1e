# --- curves to coefficients and back: the fast wavelet transform, and the --
# --- product from the wavelets not zero at each stretch of points --------

# Multiply-adds per curve (points x retained coefficients) above which one
# wavethresh::wd() or wr() per curve is cheaper than the dense product with
# Psi: the two cost the same near 2^19 (1024 points x 512 coefficients, 4096
# x 128), the transform is 2-3 times faster at 2^21 and 4-6 times at 2^24
# (8192 x 2048), bench/bench_transform.R. Both give the same numbers to
# rounding (within 2e-14): Psi's columns are the transform's own.
transform_min_work <- 2^19

# Whether basis_coef() and basis_curves() go through the transform.
basis_uses_transform <- function(basis) {
  s <- basis$settings
  !is.null(s$n_t) && !is.null(s$boundary) &&
    as.double(s$n_t) * length(basis$index) > transform_min_work
}

# Where each coefficient of the package's index order sits in a wd object of
# `settings`: positions in c(w$C, w$D) (periodic; n_all their length) or in
# w$transformed.vector (interval), with an empty transform to fill. Kept per
# setting for the session.
transform_layouts <- new.env(parent = emptyenv())

transform_layout <- function(settings) {
  key <- paste(settings$n_t, settings$filter.number, settings$family, settings$boundary)
  if (!is.null(transform_layouts[[key]])) return(transform_layouts[[key]])
  n <- settings$n_t
  if (identical(settings$boundary, "interval")) {
    out <- list(zero = interval_wd(numeric(n), settings), pos = seq_len(n), n_all = n)
  } else {
    zero <- wavethresh::wd(numeric(n), filter.number = settings$filter.number,
                           family = settings$family, bc = "periodic")
    lab <- zero
    n_c <- length(zero$C)
    lab$C <- seq_len(n_c)
    lab$D <- n_c + seq_along(zero$D)
    pos <- c(wavethresh::accessC(lab, 0),
             unlist(lapply(seq_len(wavethresh::nlevelsWT(zero)) - 1L,
                           function(l) wavethresh::accessD(lab, l))))
    out <- list(zero = zero, pos = as.integer(pos), n_c = n_c, n_all = n_c + length(zero$D))
  }
  transform_layouts[[key]] <- out
  out
}

# N x T curves -> N x |I| retained coefficients, one transform per curve.
transform_coef <- function(basis, curves) {
  s <- basis$settings
  lay <- transform_layout(s)
  at <- lay$pos[basis$index]
  interval <- identical(s$boundary, "interval")
  out <- matrix(0, nrow(curves), length(at))
  for (i in seq_len(nrow(curves))) {
    if (interval) {
      out[i, ] <- interval_wd(curves[i, ], s)$transformed.vector[at]
    } else {
      w <- wavethresh::wd(curves[i, ], filter.number = s$filter.number, family = s$family,
                          bc = "periodic")
      out[i, ] <- c(w$C, w$D)[at]
    }
  }
  out
}

# N x |I| coefficients -> N x T curves, one inverse transform per curve.
transform_curves <- function(basis, W) {
  s <- basis$settings
  lay <- transform_layout(s)
  at <- lay$pos[basis$index]
  w <- lay$zero
  n <- s$n_t
  out <- matrix(0, nrow(W), n)
  v <- numeric(lay$n_all)
  for (i in seq_len(nrow(W))) {
    v[at] <- W[i, ]
    if (identical(s$boundary, "interval")) {
      w$transformed.vector <- v
      out[i, ] <- suppressWarnings(wavethresh::wr(w))
    } else {
      w$C <- v[seq_len(lay$n_c)]
      w$D <- v[-seq_len(lay$n_c)]
      out[i, ] <- wavethresh::wr(w)
    }
  }
  out
}

# The transform on the interval (Cohen, Daubechies and Vial), without
# preconditioning so that it is orthonormal. Its coefficient vector holds the
# scaling coefficient and then the detail levels 0, 1, ..., J - 1, level l at
# positions 2^l + 1 .. 2^(l + 1): the package's index order.
interval_wd <- function(y, settings) {
  wavethresh::wd(y, filter.number = settings$filter.number, family = "DaubExPhase", bc = "interval",
                 precond = FALSE)
}

# Curve draws W %*% t(Psi[cols, ]) at the time points `cols`, from the basis
# functions that are not zero there (basis_block_cpp()).
basis_curves_block <- function(W, Psi, cols) {
  if (!is.double(W)) storage.mode(W) <- "double"
  basis_block_cpp(W, Psi, as.integer(cols))
}
