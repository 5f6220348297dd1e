# calibrate(), stage 2: the weight of the inputs' likelihood for the errors
# that many wavelet coefficients share.
#
# The method's likelihood of the inputs is a product over the retained
# coefficients, as though their errors were independent. The errors of the
# emulators at one input point, and of the registration of one replicate, are
# shared by many coefficients, so that product counts the same evidence many
# times and the inputs' posterior is too narrow. The magnitude adjustment of a
# composite likelihood (Ribatet, Cooley and Davison 2012) raises it to the
# power w = p / tr(H^-1 J), with H = G' D^-1 G its curvature and
# J = G' D^-1 Sigma D^-1 G the variance of its score: G the gradient of the
# emulators' means in the inputs, D the variances the product takes, Sigma
# the errors' covariance. Sigma is estimated from the data: the emulators'
# leave-one-out errors across coefficients (their correlation, scaled by the
# emulators' variances at the inputs), the replicates' scatter across
# coefficients (their covariance over R, for a site with two or more), the
# bias variances' own diagonal. With independent errors J = H and w = 1.
# H and J are taken at the posterior mean of a short pilot chain (on the
# suspension test bed the weight moved by less than 0.03 between pilots with a
# burn-in of 200 and of 10,000 cycles).

# The weight w and what it came from: a list with `weight`, `p` (the inputs
# it counts), `trace` (tr(H^-1 J)), `n_coef` (the coefficients informing the
# inputs), `at` (the inputs where it was taken).
shared_error_weight <- function(spec, field, tau, seed, sm) {
  pilot_sm <- sampler_control(n_draws = 20L, n_inner = 5L, step = 0.1, proposal = sm$proposal,
                              burnin = min(sm$burnin, 500L), global_moves = 0,
                              n_search = sm$n_search,
                              threads = sm$threads, quiet = TRUE)
  pilot <- run_chains(spec, pilot_sm, chains = 1L, seed = seed, tau = tau)[[1L]]
  z <- colMeans(pilot$inputs)
  tau2 <- colMeans(pilot$tau2)
  sigma2 <- lapply(pilot$sigma2, colMeans)
  composite_weight(spec, field, z, tau2, sigma2)
}

# w at inputs z (own units), bias variances tau2 (by group) and field noise
# variances sigma2 (by site, one per coefficient).
composite_weight <- function(spec, field, z, tau2, sigma2) {
  sites <- names(spec$sites)
  p <- length(z)
  width <- spec$prior_iu$upper - spec$prior_iu$lower
  h <- 1e-4 * ifelse(width > 0, width, 1)
  informs <- spec$informs %||% rep(1L, nrow(spec$groups))
  parts <- lapply(seq_along(sites), function(k) {
    d <- spec$sites[[k]]
    zs <- z + (d$shift %||% 0)
    Z <- rbind(zs, t(zs + diag(h, p)), t(zs - diag(h, p)))
    pr <- bank_predict(d$bank, Z)
    G <- (pr$mean[1L + seq_len(p), , drop = FALSE] - pr$mean[1L + p + seq_len(p), , drop = FALSE]) /
      (2 * h)
    v <- pmax(pr$var[1L, ], 0)
    e <- sigma2[[k]] / d$R + (d$extra %||% 0)
    keep <- informs[d$group + 1L] == 1L
    W <- NULL
    if (d$R >= 2) {
      W <- field$curves[[sites[k]]] %*% spec$basis$Psi
      W <- sweep(W, 2L, colMeans(W))[, keep, drop = FALSE] / sqrt((d$R - 1) * d$R)
    }
    # the leave-one-out errors scaled to unit mean square by coefficient (their
    # correlation); flat emulators' are zero
    loo <- bank_loo_errors(d$bank)[, keep, drop = FALSE]
    rms <- sqrt(colMeans(loo^2))
    list(G = t(G)[keep, , drop = FALSE], v = v[keep], e = e[keep], t2 = tau2[d$group[keep] + 1L],
         loo = sweep(loo, 2L, ifelse(rms > 0, rms, 1), `/`), flat = rms == 0,
         X = bank_design(d$bank), W = W)
  })
  A <- do.call(rbind, lapply(parts, function(q) q$G / (q$v + q$e + q$t2)))
  G <- do.call(rbind, lapply(parts, `[[`, "G"))
  H <- crossprod(G, A)
  # J: the emulators' errors, correlated across coefficients (and across the
  # sites whose emulators share a design), the field's (the replicates'
  # covariance where there are two or more, else independent), the bias
  # independent
  offs <- cumsum(c(0L, vapply(parts, function(q) length(q$v), integer(1))))
  rows <- function(k) offs[k] + seq_len(length(parts[[k]]$v))
  J <- matrix(0, p, p)
  design <- integer(length(parts))
  for (k in seq_along(parts)) {
    same <- which(vapply(parts[seq_len(k - 1L)], function(q) identical(q$X, parts[[k]]$X),
                         logical(1)))
    design[k] <- if (length(same)) design[same[1L]] else k
  }
  for (dz in unique(design)) {
    ks <- which(design == dz)
    M <- Reduce(`+`,
                lapply(ks, function(k) parts[[k]]$loo %*%
                       (sqrt(parts[[k]]$v) * A[rows(k), , drop = FALSE])))
    J <- J + crossprod(M) / nrow(M)
    for (k in ks) {
      q <- parts[[k]]
      if (any(q$flat)) J <- J + crossprod(A[rows(k)[q$flat], , drop = FALSE] * sqrt(q$v[q$flat]))
    }
  }
  for (k in seq_along(parts)) {
    q <- parts[[k]]
    Ak <- A[rows(k), , drop = FALSE]
    J <- J + crossprod(Ak * sqrt(q$t2))
    J <- J + if (is.null(q$W)) crossprod(Ak * sqrt(q$e)) else crossprod(q$W %*% Ak)
  }
  eg <- eigen(H, symmetric = TRUE)
  ok <- eg$values > 1e-10 * max(eg$values, 0)
  if (!any(ok)) return(list(weight = 1, p = 0L, trace = 0, n_coef = nrow(G), at = z))
  U <- eg$vectors[, ok, drop = FALSE]
  tr <- sum(diag(crossprod(U, J %*% U)) / eg$values[ok])
  list(weight = min(1, sum(ok) / tr), p = sum(ok), trace = tr, n_coef = nrow(G), at = z)
}
