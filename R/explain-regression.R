# The regression behind explain_bias(): Bayes factors of subsets of
# candidates under Zellner's g-prior, tempered for residuals that are alike
# within time segments, with amplitudes optionally constrained to be
# non-negative (orthant probabilities of the multivariate t by GHK).

# Tempering power for one draw: eta = k / tr(J^-1 I), capped at 1, with J the
# information the weighted regression of y on the k linearly independent
# columns of X claims for their coefficients and I its cluster-robust
# (sandwich) estimate from the residuals, clusters given by `cluster`.
tempering_power <- function(X, y, w, cluster) {
  q <- qr(X * sqrt(w))
  k <- q$rank
  n <- length(y)
  if (k == 0L || n - k < 1L) return(1)
  Xk <- X[, q$pivot[seq_len(k)], drop = FALSE]
  G <- crossprod(Xk * w, Xk)
  a <- solve(G, crossprod(Xk * w, y))
  e <- drop(y - Xk %*% a)
  phi <- sum(w * e^2) / n
  if (!(phi > 0)) return(1)
  U <- rowsum(Xk * (w * e), cluster)
  # J = G / phi, I = U'U / phi^2, so tr(J^-1 I) = tr(G^-1 U'U) / phi
  ratio <- sum(diag(solve(G, crossprod(U)))) / phi / k
  if (!is.finite(ratio) || ratio <= 1) 1 else 1 / ratio
}

# The regression of bias draws Y (H x n) on candidates X (n x m) with weights
# Wt (H x n), subsets of up to max_size candidates, Zellner g = n. With
# `cluster` (one label per coefficient), the likelihood of each draw is
# tempered by tempering_power(): n and g become eta * n. With `positive` (one
# logical per candidate), the joint prior of subsets and amplitudes is
# conditioned on the flagged amplitudes being non-negative: the marginal
# likelihood of a subset is multiplied by the posterior probability of that
# orthant, and its amplitudes are drawn from the truncated posterior.
bias_regression <- function(Y, X, Wt, max_size = 3L, level = 0.9, cluster = NULL, positive = NULL,
                            group = NULL) {
  n_all <- ncol(Y)
  m <- ncol(X)
  H <- nrow(Y)
  positive <- if (is.null(positive)) rep(FALSE, m) else positive
  group <- if (is.null(group)) colnames(X) else group
  # one lattice for each number (from 2) of constrained amplitudes in a subset
  # (none is needed for one)
  lattice <- lapply(seq_len(min(max_size, sum(positive))),
                    function(d) if (d > 1L) orthant_lattice(d - 1L))
  sp <- regression_subsets(group, max_size)
  subsets <- sp$subsets
  n_sub <- length(subsets) + 1L
  logml <- matrix(-Inf, H, n_sub)
  share <- of_bias <- matrix(0, H, m)
  eta <- rep(1, H)
  for (h in seq_len(H)) {
    if (!is.null(cluster)) eta[h] <- tempering_power(X, Y[h, ], Wt[h, ], cluster)
    d <- draw_subset_evidence(Y[h, ], X, Wt[h, ], eta[h], subsets, sp$log_prior, positive, lattice)
    logml[h, ] <- d$logml
    share[h, ] <- d$share
    of_bias[h, ] <- d$of_bias
  }
  lp <- sweep(logml, 2, sp$log_prior, `+`)
  lp <- lp - apply(lp, 1, max)
  post <- exp(lp)
  post <- post / rowSums(post)
  sub_prob <- colMeans(post)
  incl <- vapply(seq_len(m), function(k) {
    sum(sub_prob[-1][vapply(subsets, function(S) k %in% S, logical(1))])
  }, numeric(1))
  amp_draws <- averaged_amplitudes(Y, X, Wt, eta, post, subsets, positive)
  out <- effect_table(amp_draws, incl, colMeans(share), group, colnames(X), level,
                      colMeans(of_bias))
  sub_names <- c("(none)", vapply(subsets, function(S) paste(colnames(X)[S], collapse = " + "), ""))
  top <- order(-sub_prob)[seq_len(min(10L, n_sub))]
  c(out, list(subsets = data.frame(subset = sub_names[top], probability = sub_prob[top],
                                   stringsAsFactors = FALSE),
              eta = eta))
}

# The subsets of candidates (by position) of up to max_size effects, versions
# of one effect never together, and the log prior of "(none)" and each subset:
# equal mass on each size 0..max_size, shared equally among the subsets of
# effects within a size, and an effect's share equally among its versions.
regression_subsets <- function(group, max_size) {
  n_group <- length(unique(group))
  subsets <- unlist(lapply(seq_len(min(max_size, n_group)), function(k) {
    utils::combn(length(group), k, simplify = FALSE)
  }), recursive = FALSE)
  subsets <- subsets[!vapply(subsets, function(S) anyDuplicated(group[S]) > 0L, logical(1))]
  sizes <- vapply(subsets, length, 1L)
  log_w <- -log(as.vector(table(group)[group]))
  log_w <- vapply(subsets, function(S) sum(log_w[S]), numeric(1))
  size_mass <- vapply(seq_len(min(max_size, n_group)), function(k) log(sum(exp(log_w[sizes == k]))),
                      numeric(1))
  list(subsets = subsets, log_prior = c(0, log_w - size_mass[sizes]) - log(length(size_mass) + 1))
}

# One draw's log marginal likelihood of "(none)" (0) and of each subset
# (tempered by eta, orthant-adjusted for the constrained amplitudes), and the
# share each candidate alone explains (in the regression's weighted metric)
# of the bias energy that the most probable subset of candidates explains
# (`share`) and of the whole bias energy (`of_bias`).
draw_subset_evidence <- function(y, X, w, eta, subsets, log_prior, positive, lattice) {
  n_all <- length(y)
  logml <- c(0, rep(-Inf, length(subsets)))
  share <- numeric(ncol(X))
  n <- g <- eta * n_all
  XtW <- t(X * w)
  G <- XtW %*% X
  b <- drop(XtW %*% y)
  yy <- sum(w * y^2)
  if (yy <= 0) return(list(logml = logml, share = share, of_bias = share))
  # energies in the regression's metric (each coefficient weighted by its
  # inverse variance): what each candidate alone explains, with its sign
  # constraint, and below what each subset explains
  alone <- ifelse(positive & b < 0, 0, b^2 / diag(G))
  alone[!is.finite(alone)] <- 0
  explained <- rep(0, length(subsets))
  shrink <- g / (1 + g)
  orthant <- vector("list", length(subsets))
  for (j in seq_along(subsets)) {
    S <- subsets[[j]]
    GS <- G[S, S, drop = FALSE]
    ch <- tryCatch(chol(GS), error = function(e) NULL)
    if (is.null(ch) || min(diag(ch))^2 < 1e-10 * max(diag(GS))) next
    coef <- backsolve(ch, forwardsolve(t(ch), b[S]))
    explained[j] <- max(0, sum(b[S] * coef))
    r2 <- min(sum(b[S] * coef) / yy, 1 - 1e-12)
    logml[j + 1L] <- -length(S) / 2 * log1p(g) - n / 2 * log1p(-shrink * r2)
    pS <- which(positive[S])
    if (length(pS)) {
      orthant[[j]] <- list(mu = shrink * coef[pS],
                           V = chol2inv(ch)[pS, pS, drop = FALSE] * shrink / eta,
                           phi = yy * (1 - shrink * r2) / n_all)
    }
  }
  logml[-1L] <- orthant_adjusted(logml[-1L], log_prior[-1L], log_prior[1L], orthant, n, lattice)
  # the part of the bias the candidates could explain: the energy the most
  # probable subset of candidates (not "(none)") explains by its weighted
  # least-squares fit
  best <- which.max(logml[-1L] + log_prior[-1L])
  explainable <- if (length(best) && is.finite(logml[best + 1L])) explained[best] else 0
  share <- if (explainable > 0) pmin(1, alone / explainable) else share
  list(logml = logml, share = share, of_bias = pmin(1, alone / yy))
}

# Model-averaged amplitude draws (H x m): one subset drawn per draw from its
# posterior probabilities `post`, then its amplitudes from their (truncated)
# posterior; 0 for the candidates it leaves out.
averaged_amplitudes <- function(Y, X, Wt, eta, post, subsets, positive) {
  H <- nrow(Y)
  m <- ncol(X)
  n_all <- ncol(Y)
  pick <- apply(post, 1, function(p) sample.int(ncol(post), 1L, prob = p))
  amp_draws <- t(vapply(seq_len(H), function(h) {
    a <- numeric(m)
    if (pick[h] == 1L) return(a)
    S <- subsets[[pick[h] - 1L]]
    w <- Wt[h, ]
    XS <- X[, S, drop = FALSE]
    G <- crossprod(XS * w, XS)
    b <- drop(crossprod(XS * w, Y[h, ]))
    coef <- solve(G, b)
    g <- eta[h] * n_all
    shrink <- g / (1 + g)
    phi <- (sum(w * Y[h, ]^2) - shrink * sum(b * coef)) / n_all
    cov <- shrink * phi / eta[h] * solve(G)
    a[S] <- draw_truncated(shrink * coef, chol(cov), positive[S])
    a
  }, numeric(m)))
  if (m == 1L) amp_draws <- matrix(amp_draws, ncol = 1L)
  amp_draws
}

# The table of effects: one row per effect, whose versions are disjoint
# events; a draw's amplitude is that of the version it includes, and the share
# explained is that of the most probable version. Also each version's row and
# the leading version of each effect.
effect_table <- function(amp_draws, incl, share_mean, group, names, level, of_bias = share_mean) {
  H <- nrow(amp_draws)
  alpha <- (1 - level) / 2
  versions <- data.frame(candidate = names, effect = group, inclusion_prob = incl,
                         amplitude = colMeans(amp_draws), share_explained = share_mean,
                         share_of_bias = of_bias,
                         stringsAsFactors = FALSE)
  eff <- unique(group)
  amp_draws <- vapply(eff, function(e) rowSums(amp_draws[, group == e, drop = FALSE]), numeric(H))
  if (H == 1L) amp_draws <- matrix(amp_draws, nrow = 1L)
  lead <- vapply(eff, function(e) {
    k <- which(group == e)
    k[which.max(incl[k] + 1e-9 * share_mean[k])]
  }, 1L)
  table <- data.frame(
    candidate = eff,
    inclusion_prob = vapply(eff, function(e) min(1, sum(incl[group == e])), numeric(1)),
    amplitude = colMeans(amp_draws),
    amplitude_lower = apply(amp_draws, 2, stats::quantile, probs = alpha, names = FALSE),
    amplitude_upper = apply(amp_draws, 2, stats::quantile, probs = 1 - alpha, names = FALSE),
    share_explained = share_mean[lead],
    share_of_bias = of_bias[lead],
    stringsAsFactors = FALSE
  )
  table <- table[order(-table$inclusion_prob, -table$share_explained), , drop = FALSE]
  rownames(table) <- NULL
  list(table = table, lead = stats::setNames(names[lead], eff),
       versions = if (length(eff) < length(names))
         versions[order(-versions$inclusion_prob), , drop = FALSE])
}

# A fixed lattice of N quasi-random points in d dimensions for the orthant
# probabilities of d + 1 constrained amplitudes (N grows with d to keep them
# within about half a per cent): the midpoints (i - 0.5) / N in the
# first dimension (the only one used with two constrained amplitudes), and in
# the others the Kronecker sequence frac(0.5 + i * alpha), alpha_j = 1 / phi^j
# with phi the positive root of x^d = x + 1 (low discrepancy in any
# dimension).
orthant_lattice <- function(d, N = min(128L * 4L^(d - 1L), 8192L)) {
  i <- seq_len(N)
  v <- matrix((i - 0.5) / N, N, max(d, 1L))
  if (d > 1L) {
    phi <- stats::uniroot(function(x) x^d - x - 1, c(1, 2), tol = 1e-12)$root
    v[, -1] <- (0.5 + outer(i, 1 / phi^seq_len(d - 1L))) %% 1
  }
  list(v = v)
}

# log P(T >= lower) for T multivariate t with `df` degrees of freedom (Inf:
# normal) and scale matrix V, by the GHK simulator over the lattice points v:
# with V = L L', T = L w, and given w_1..w_(k-1), w_k is a t with df + k - 1
# degrees of freedom scaled by sqrt((df + sum w_j^2) / (df + k - 1)); each
# coordinate in turn is bounded given the earlier ones, its probability taken
# exactly and its value drawn from the bounded part. The first coordinate's
# probability is exact, the estimate a smooth function of lower and V, and a
# tiny probability keeps its order of magnitude.
ghk_log_orthant <- function(lower, V, df, v) {
  d <- length(lower)
  if (d == 1L) return(stats::pt(-lower / sqrt(V[1, 1]), df = df, log.p = TRUE))
  # each coordinate's own tail beyond its bound: when they are all negligible
  # the probability is 1 - their sum to within their pairwise products
  tails <- stats::pt(lower / sqrt(diag(V)), df = df)
  if (sum(tails) < 1e-6) return(log1p(-sum(tails)))
  L <- t(chol(V))
  N <- nrow(v)
  W <- matrix(0, N, d)
  ss <- numeric(N)
  lw <- numeric(N)
  for (k in seq_len(d)) {
    nu <- df + k - 1
    r <- if (is.finite(df)) sqrt((df + ss) / nu) else 1
    # the first bound is the same at every point
    b <- if (k == 1L) lower[1L] / L[1L, 1L] else {
      (lower[k] - drop(W[, seq_len(k - 1L), drop = FALSE] %*% L[k, seq_len(k - 1L)])) / L[k, k] / r
    }
    lq <- stats::pt(-b, df = nu, log.p = TRUE)
    lw <- lw + lq
    if (k < d) {
      W[, k] <- -r * stats::qt(log(v[, k]) + lq, df = nu, log.p = TRUE)
      ss <- ss + W[, k]^2
    }
  }
  top <- max(lw)
  top + log(mean(exp(lw - top)))
}

# The log marginal likelihoods `lml` of the subsets (log prior `lprior`; the
# empty subset's log prior `lprior0`, its log marginal likelihood 0) with the
# posterior orthant probability added where `orthant` gives one (`lattice`:
# the lattices by number of amplitudes, as in bias_regression()). The factor
# is at most 1, so the subsets are visited from the most probable down and
# those already 40 log units below the best so far are given -Inf (a share
# below 4e-18 of the posterior) without computing it.
orthant_adjusted <- function(lml, lprior, lprior0, orthant, df, lattice) {
  todo <- which(!vapply(orthant, is.null, logical(1)) & is.finite(lml))
  if (!length(todo)) return(lml)
  lp <- lml + lprior
  best <- max(c(lprior0, lp[setdiff(which(is.finite(lml)), todo)]))
  for (j in todo[order(-lp[todo])]) {
    if (lp[j] < best - 40) {
      lml[j] <- -Inf
      next
    }
    o <- orthant[[j]]
    lml[j] <- lml[j] + log_orthant_posterior(o$mu, o$V, o$phi, df, lattice[[length(o$mu)]])
    best <- max(best, lml[j] + lprior[j])
  }
  lml
}

# log P(a >= 0 | data) for the constrained amplitudes of one subset: a =
# mu + sqrt(phi_hat) T, T multivariate t with `df` degrees of freedom and
# scale matrix V (phi integrated out); `lattice` is unused for one amplitude.
log_orthant_posterior <- function(mu, V, phi_hat, df, lattice) {
  ghk_log_orthant(-mu / sqrt(phi_hat), V, df, lattice$v)
}

# One draw of mu + t(U) z (U upper triangular) with the coordinates flagged by
# `positive` non-negative, by rejection in batches; when the orthant is too
# improbable to hit, the nearest point of it on the flagged coordinates.
draw_truncated <- function(mu, U, positive) {
  k <- length(mu)
  if (!any(positive)) return(mu + drop(t(U) %*% stats::rnorm(k)))
  for (attempt in 1:20) {
    a <- sweep(matrix(stats::rnorm(100L * k), 100L, k) %*% U, 2L, mu, `+`)
    ok <- which(apply(a[, positive, drop = FALSE] >= 0, 1, all))
    if (length(ok)) return(a[ok[1], ])
  }
  out <- mu
  out[positive] <- pmax(out[positive], 0)
  out
}
