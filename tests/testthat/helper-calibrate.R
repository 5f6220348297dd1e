# Hand-built inputs for the calibration tests: a wavelet basis, GASP banks
# with known hyperparameters, emulator objects and field data.

# GASP bank for fixed beta, alpha (n x p, or length p recycled over
# coefficients): mu and lambda by profile maximum likelihood, weights
# R^-1 (y - mu), lower Cholesky factors of R (nugget on the diagonal).
make_bank <- function(X_raw, Y, beta, alpha, nugget = 1e-8) {
  X_raw <- as.matrix(X_raw)
  Y <- as.matrix(Y)
  K <- nrow(X_raw)
  p <- ncol(X_raw)
  n <- ncol(Y)
  lower <- apply(X_raw, 2, min)
  width <- apply(X_raw, 2, max) - lower
  X <- t((t(X_raw) - lower) / width)
  if (is.null(dim(beta))) beta <- matrix(beta, n, p, byrow = TRUE)
  if (is.null(dim(alpha))) alpha <- matrix(alpha, n, p, byrow = TRUE)
  mu <- lambda <- numeric(n)
  weights <- matrix(0, K, n)
  chol <- array(0, c(K, K, n))
  for (i in seq_len(n)) {
    Rm <- matrix(0, K, K)
    for (a in seq_len(K)) for (b in seq_len(K)) {
      Rm[a, b] <- exp(-sum(beta[i, ] * abs(X[a, ] - X[b, ])^(2 - alpha[i, ])))
    }
    diag(Rm) <- diag(Rm) + nugget
    Ri <- solve(Rm)
    mu[i] <- sum(Ri %*% Y[, i]) / sum(Ri)
    e <- Y[, i] - mu[i]
    weights[, i] <- Ri %*% e
    lambda[i] <- K / drop(t(e) %*% Ri %*% e)
    chol[, , i] <- t(chol(Rm))
  }
  list(X = X, beta = beta, alpha = alpha, mu = mu, lambda = lambda, nugget = rep(nugget, n),
       weights = weights, chol = chol, y = Y, lower = lower, width = width)
}

# Basis of wavethresh coefficients `index` on a grid of n_t points.
make_basis <- function(n_t, index = seq_len(n_t), level = NULL) {
  b <- basis_from_index(seq(0, 1, length.out = n_t + 1)[-(n_t + 1)], index)
  if (!is.null(level)) b$level <- as.integer(rep_len(level, length(index)))
  b
}

# wv_emulators from banks (named by site) built with make_bank().
make_emulators <- function(banks, basis, design) {
  inputs <- colnames(design)
  params <- do.call(rbind, lapply(names(banks), function(s) {
    b <- banks[[s]]
    d <- data.frame(site = s, index = basis$index, level = basis$level, mu = b$mu, lambda = b$lambda,
                    nugget = b$nugget, loglik = NA_real_)
    for (q in seq_along(inputs)) {
      d[[paste0("beta_", inputs[q])]] <- b$beta[, q]
      d[[paste0("alpha_", inputs[q])]] <- b$alpha[, q]
    }
    d
  }))
  structure(list(params = params, inputs = inputs, design = design, banks = banks, basis = basis,
                 engine = "gasp", t = basis$t), class = "wv_emulators")
}

# A one-site problem: inputs u1 (calibration, [0, 1]) and, if two_inputs,
# x1 (variation, nominal 0.5, [0, 1]); coefficient i of the model is a smooth
# function of the inputs.
small_problem <- function(n_t = 16, index = 1:8, level = NULL, two_inputs = TRUE, K = 14, beta = 3) {
  basis <- make_basis(n_t, index, level)
  n <- length(index)
  design <- if (two_inputs) {
    cbind(u1 = (seq_len(K) - 0.5) / K, x1 = ((seq_len(K) * 5) %% K + 0.5) / K)
  } else {
    cbind(u1 = seq(0, 1, length.out = K))
  }
  f <- function(z) {
    u <- z[1]
    x <- if (length(z) > 1) z[2] else 0.5
    vapply(seq_len(n), function(i) sin(1.5 * i * u + 0.7 * i) + 0.8 * cos(i * x) * (i %% 2), numeric(1))
  }
  Y <- t(apply(design, 1, f))
  bank <- make_bank(design, Y, beta = rep(beta, ncol(design)), alpha = rep(0, ncol(design)))
  iu <- if (two_inputs) {
    iu_map(c("u1", "x1"), c("calibration", "variation"), c(0, 0), c(1, 1), nominal = c(0.5, 0.5))
  } else {
    iu_map("u1", "calibration", 0, 1)
  }
  list(basis = basis, emulators = make_emulators(list(site1 = bank), basis, design), iu = iu, f = f)
}

# Field replicates (R x T) whose coefficients are W (R x n).
field_from_coef <- function(basis, W, site = "site1") {
  new_wv_field(basis$t, stats::setNames(list(W %*% t(basis$Psi)), site))
}

# small_problem() with 24 coefficients and 30 runs, and seven field replicates
# at u1 = 0.35, x1 = 0.6 with little noise: a narrow posterior. Draws from
# R's RNG (set the seed first).
narrow_problem <- function() {
  pb <- small_problem(n_t = 32, index = 1:24, K = 30, beta = 1)
  pb$truth <- c(0.35, 0.6)
  n <- length(pb$basis$index)
  W <- matrix(pb$f(pb$truth), 7, n, byrow = TRUE) + matrix(stats::rnorm(7 * n, 0, 0.01), 7, n)
  pb$field <- field_from_coef(pb$basis, W)
  pb
}

# The pieces every simulation-based calibration study shares: the small
# problem (one input unless `two_inputs`), its calibration spec for `iu`
# (default the problem's own) with R replicates and field variances `sigma2`,
# the number of coefficients n, of bias groups G and the site's emulator bank.
sbc_setup <- function(R, sigma2, iu = NULL, two_inputs = FALSE) {
  pb <- small_problem(two_inputs = two_inputs)
  n <- length(pb$basis$index)
  spec <- calibration_spec(pb$emulators, field_from_coef(pb$basis, matrix(0, R, n)),
                           if (is.null(iu)) pb$iu else iu,
                           sigma2 = sigma2)
  list(pb = pb, n = n, spec = spec, G = nrow(spec$groups), bank = pb$emulators$banks$site1)
}

# Chi-squared p-values of the uniformity of SBC ranks (one column per
# quantity), the ranks 0..n_kept of the truth among n_kept draws in 10 bins.
sbc_rank_pvalues <- function(ranks, n_kept) {
  apply(ranks, 2, function(x) stats::chisq.test(tabulate(x %/% ((n_kept + 1) / 10) + 1, 10))$p.value)
}

# small_problem() with one input and one bias level, and R field replicates
# whose errors the coefficients share: replicate r is the model at
# u_true + d_r, d_r ~ N(0, s_u^2) (a random shift of the whole record, as a
# registration error or a test's own jitter), plus white noise. The replicates'
# mean carries the shift's mean, an error of sd s_u / sqrt(R) in u that every
# coefficient repeats. Draws from R's RNG (set the seed first).
shift_problem <- function(u_true = 0.4, R = 8, s_u = 0.04, noise = 0.02) {
  pb <- small_problem(two_inputs = FALSE, level = 4L)
  n <- length(pb$basis$index)
  W <- t(vapply(u_true + stats::rnorm(R, 0, s_u), pb$f, numeric(n))) + matrix(stats::rnorm(R * n, 0, noise), R, n)
  list(pb = pb, field = field_from_coef(pb$basis, W), u = u_true)
}

# The draws of u1 of calibrate() on a shift_problem() with the inputs'
# likelihood `lik`.
shift_draws <- function(sp, lik, seed, n_draws = 300) {
  fit <- suppressWarnings(calibrate(sp$pb$emulators, sp$field, sp$pb$iu, chains = 1, seed = seed,
                                    bias = bias_control(input_likelihood = lik),
                                    sampler = sampler_control(n_draws = n_draws, n_inner = 10, quiet = TRUE)))
  list(u1 = as.matrix(fit$draws)[, "u1"], weight = fit$shared_errors$weight %||% 1)
}

# One input, one tau2 group, sigma2 known: the posterior of (u1, tau2) is
# computable on a grid.
grid_problem <- function() {
  pb <- small_problem(two_inputs = FALSE, level = 4L)
  n <- length(pb$basis$index)
  R <- 3
  sd_eps <- 0.6
  bank <- pb$emulators$banks$site1
  pr <- gasp_bank_predict_cpp(bank, matrix(0.3, 1))
  W <- matrix(drop(pr$mean) + stats::rnorm(n, 0, 0.3), R, n, byrow = TRUE) +
    matrix(stats::rnorm(R * n, 0, sd_eps), R, n)
  list(pb = pb, field = field_from_coef(pb$basis, W), sigma2 = sd_eps^2, R = R, wbar = colMeans(W))
}
