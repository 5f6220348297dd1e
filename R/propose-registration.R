# The registration's error in propose_terms(): random shift and blur
# directions at the knots of the warps, their sizes estimated from the bias.

# The registration's error as directions of the registered mean: an error
# delta(t) of the warp, linear between its knots, moves the registered mean by
# -delta y' to first order and by delta^2 y'' / 2 to second (the blur that the
# spread of such errors leaves in the mean of the replicates). One shift
# (hat_k y') and one blur (hat_k y'') direction for each knot of the warps,
# the sites together when one warp moves them all (y the model at the
# posterior mean inputs). NULL when the field was not registered.
registration_directions <- function(fit) {
  w <- fit_get(fit, "field")$warps
  sites <- fit_sites(fit)
  field_sites <- intersect(sites, names(fit_get(fit, "field")$curves))
  if (is.null(w) || !length(field_sites)) return(NULL)
  tb <- fit_get(fit, "basis")$t
  knots <- sort(unique(c(range(tb), w$t_after[w$replicate == w$replicate[1]])))
  knots <- knots[knots >= tb[1] & knots <= tb[length(tb)]]
  knots <- knots[c(TRUE, diff(knots) > 2 * (tb[2] - tb[1]))]
  hats <- vapply(seq_along(knots), function(k) {
    stats::approx(knots, as.numeric(seq_along(knots) == k), xout = tb, rule = 2)$y
  }, numeric(length(tb)))
  y1 <- output_channels(fit)[["d/dt output"]]
  y2 <- lapply(y1, grid_slope, t = tb)
  shared <- !is.na(attr(w, "landmark_site") %||% NA_character_)
  groups <- if (shared) list(field_sites) else as.list(field_sites)
  n_all <- sum(vapply(fit_get(fit, "wb"), ncol, 1L))
  cols <- list()
  kind <- character()
  for (g in groups) {
    for (d in list(list(y1, "shift"), list(y2, "blur"))) {
      M <- vapply(seq_along(knots), function(k) {
        unlist(lapply(sites, function(s) {
          drop(crossprod(fit_get(fit, "basis")$Psi,
                         if (s %in% g) hats[, k] * d[[1]][[s]] else 0 * tb))
        }))
      }, numeric(n_all))
      cols <- c(cols, list(M))
      kind <- c(kind, rep(d[[2]], ncol(M)))
    }
  }
  R <- do.call(cbind, cols)
  keep <- colSums(R^2) > 0
  list(R = R[, keep, drop = FALSE], kind = kind[keep], knots = length(knots))
}

# The size of the registration's error, from the data: the variances of the
# shift and of the blur directions (lam, one per column of R, the columns
# scaled to unit norm in the metric of the weights w) that maximise the
# restricted likelihood of the posterior mean residual y, y ~ N(F gamma,
# phi (D + R diag(lam) R')), D = diag(1 / w), gamma flat, phi free.
registration_scale <- function(y, w, F, R, kind) {
  sw <- sqrt(w)
  Rs <- sweep(R, 2L, sqrt(colSums(R^2 * w)), `/`)
  Ft <- F * sw
  Rt <- Rs * sw
  yt <- y * sw
  n <- length(y)
  qf <- qr(Ft)
  p <- qf$rank
  RR <- crossprod(Rt)
  FR <- crossprod(Ft, Rt)
  FF <- crossprod(Ft)
  Ry <- drop(crossprod(Rt, yt))
  Fy <- drop(crossprod(Ft, yt))
  yy <- sum(yt^2)
  kinds <- unique(kind)
  lam_of <- function(par) exp(par[match(kind, kinds)])
  reml <- function(par) {
    lam <- lam_of(par)
    M <- diag(1 / lam, length(lam)) + RR
    cm <- chol(M)
    # whitened quadratic forms by Woodbury: V^-1 = I - Rt M^-1 Rt'
    MRy <- backsolve(cm, forwardsolve(t(cm), Ry))
    MRF <- backsolve(cm, forwardsolve(t(cm), t(FR)))
    yVy <- yy - sum(Ry * MRy)
    FVy <- Fy - drop(FR %*% MRy)
    FVF <- FF - FR %*% MRF
    ef <- eigen(FVF, symmetric = TRUE, only.values = TRUE)$values
    ef <- ef[ef > 1e-10 * max(ef)]
    q <- yVy - sum(FVy * qr.solve(FVF, FVy, tol = 1e-10))
    logdet <- sum(log(lam)) + 2 * sum(log(diag(cm)))
    -0.5 * logdet - 0.5 * sum(log(ef)) - 0.5 * (n - p) * log(max(q, 1e-300))
  }
  opt <- stats::optim(rep(log(1e-2), length(kinds)), function(par) -reml(par), method = "L-BFGS-B",
                      lower = rep(log(1e-8), length(kinds)), upper = rep(log(1e4), length(kinds)))
  list(R = Rs, lam = lam_of(opt$par), by_kind = stats::setNames(exp(opt$par), kinds))
}
