# Synthetic stand-in for the test bed's Site 1 (used when the package has no
# testbed_suspension() or wavelet_basis()): 66 runs of 9 inputs from a
# maximin-ish Latin hypercube, load-like curves on 4096 points whose wavelet
# coefficients depend smoothly and non-linearly on the inputs.
synthetic_lhd <- function(K, p, tries = 50) {
  best <- NULL
  best_d <- -Inf
  for (i in seq_len(tries)) {
    X <- sapply(seq_len(p), function(j) (sample.int(K) - stats::runif(K)) / K)
    d <- min(stats::dist(X))
    if (d > best_d) {
      best <- X
      best_d <- d
    }
  }
  best
}

synthetic_curves <- function(X, t) {
  ev <- function(t0, amp, freq, damp) {
    s <- pmax(t - t0, 0)
    amp * exp(-damp * s) * sin(2 * pi * freq * s) * (t > t0)
  }
  rough <- 0.05 * sin(2 * pi * 0.7 * t) + 0.03 * sin(2 * pi * 2.3 * t + 1)
  t(apply(X, 1, function(z) {
    ev(6 + 0.5 * z[9], 1 + 0.6 * z[1] - 0.4 * z[3]^2, 1.2 + 0.8 * sqrt(z[4] + 0.1), 0.4 + 0.6 * z[2]) +
      ev(37 + 0.3 * z[8], 0.6 + 0.3 * sin(3 * z[5]) + 0.2 * z[6], 2 + z[7], 0.8 + 0.4 * z[1] * z[2]) +
      (1 + 0.2 * z[4]) * rough + 0.3 * z[3] * exp(-((t - 20) / (3 + z[5]))^2)
  }))
}

# wv_basis by hand: scaling coefficient, wavethresh detail levels 0-2 and the
# top `fraction` of each curve's finer coefficients.
synthetic_basis <- function(curves, t, fraction = 0.025, filter.number = 2, family = "DaubExPhase") {
  nT <- length(t)
  J <- log2(nT)
  coefs <- t(apply(curves, 1, function(y) {
    w <- wavethresh::wd(y, filter.number = filter.number, family = family)
    c(wavethresh::accessC(w, 0), unlist(lapply(0:(J - 1), function(l) wavethresh::accessD(w, l))))
  }))
  lev <- c(0L, rep(seq_len(J), 2^(0:(J - 1))))
  keep <- lev <= 3L
  for (r in seq_len(nrow(coefs))) {
    a <- abs(coefs[r, ])
    keep <- keep | (a >= stats::quantile(a, 1 - fraction) & lev > 3L)
  }
  index <- which(keep)
  w0 <- wavethresh::wd(rep(0, nT), filter.number = filter.number, family = family)
  Psi <- vapply(index, function(i) {
    w <- w0
    if (i == 1L) {
      w <- wavethresh::putC(w, 0, 1)
    } else {
      l <- floor(log2(i - 1))
      v <- rep(0, 2^l)
      v[i - 2^l] <- 1
      w <- wavethresh::putD(w, l, v)
    }
    wavethresh::wr(w)
  }, numeric(nT))
  structure(list(index = as.integer(index), level = as.integer(lev[index]), Psi = Psi, t = t,
                 sites = "site1", settings = list(filter.number = filter.number, family = family,
                                                  keep_levels = 0:3, fraction = fraction)),
            class = "wv_basis")
}
