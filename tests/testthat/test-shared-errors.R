# One input, one tau2 group, sigma2 known (as in test-calibrate.R's grid
# problem): three replicates at u1 = 0.3.
shared_grid_problem <- function() {
  pb <- small_problem(two_inputs = FALSE, level = 4L)
  n <- length(pb$basis$index)
  R <- 3
  pr <- gasp_bank_predict_cpp(pb$emulators$banks$site1, matrix(0.3, 1))
  W <- matrix(drop(pr$mean) + stats::rnorm(n, 0, 0.3), R, n, byrow = TRUE) + matrix(stats::rnorm(R * n, 0, 0.6), R, n)
  list(pb = pb, field = field_from_coef(pb$basis, W), sigma2 = 0.36, R = R, W = W, wbar = colMeans(W))
}

test_that("with the inputs' weight and tau2 fixed, the sampler reproduces the grid posterior of the likelihood raised to it, and not when the weight is dropped", {
  withr::local_seed(11)
  gp <- shared_grid_problem()
  u <- seq(0.0005, 0.9995, by = 0.001)
  P <- gasp_bank_predict_cpp(gp$pb$emulators$banks$site1, matrix(u, ncol = 1))
  t2 <- 0.09
  post_cdf <- function(w) {
    lp <- w * vapply(seq_along(u), function(a) {
      sum(stats::dnorm(gp$wbar, P$mean[a, ], sqrt(P$var[a, ] + gp$sigma2 / gp$R + t2), log = TRUE))
    }, numeric(1))
    d <- exp(lp - max(lp))
    stats::approxfun(u, cumsum(d) / sum(d), yleft = 0, yright = 1)
  }
  spec <- calibration_spec(gp$pb$emulators, gp$field, gp$pb$iu, sigma2 = gp$sigma2)
  spec$input_weight <- 0.2
  tau <- resolve_fix_tau2(t2, spec$groups)
  run <- function(debug_break) {
    sm <- sampler_control(n_draws = 1500, n_inner = 30, burnin = 5000, n_search = 200, quiet = TRUE)
    run_chains(spec, sm, 1, 5, tau, debug_break = debug_break)[[1]]$inputs[, 1]
  }
  ok <- run(0L)
  expect_gt(suppressWarnings(stats::ks.test(ok, post_cdf(0.2))$p.value), 0.01)
  expect_lt(suppressWarnings(stats::ks.test(ok, post_cdf(1))$p.value), 0.01)
  broken <- run(7L)
  expect_lt(suppressWarnings(stats::ks.test(broken, post_cdf(0.2))$p.value), 0.01)
  expect_gt(suppressWarnings(stats::ks.test(broken, post_cdf(1))$p.value), 0.01)
})

test_that("the weight is p / tr(H^-1 J) of the errors' covariance, computed densely", {
  withr::local_seed(12)
  gp <- shared_grid_problem()
  spec <- calibration_spec(gp$pb$emulators, gp$field, gp$pb$iu, sigma2 = gp$sigma2)
  z <- 0.35
  tau2 <- 0.05
  sigma2 <- list(site1 = rep(gp$sigma2, length(gp$wbar)))
  got <- composite_weight(spec, gp$field, z, tau2, sigma2)
  bank <- gp$pb$emulators$banks$site1
  h <- 1e-4
  P <- gasp_bank_predict_cpp(bank, matrix(c(z, z + h, z - h), ncol = 1))
  G <- (P$mean[2, ] - P$mean[3, ]) / (2 * h)
  v <- P$var[1, ]
  d <- v + gp$sigma2 / gp$R + tau2
  E <- bank_loo_errors(bank)
  C <- crossprod(E) / nrow(E)
  C <- C / sqrt(outer(diag(C), diag(C)))
  S <- stats::cov(gp$W) / gp$R
  Sigma <- diag(sqrt(v)) %*% C %*% diag(sqrt(v)) + diag(tau2, length(v)) + S
  H <- sum(G^2 / d)
  J <- drop(t(G / d) %*% Sigma %*% (G / d))
  expect_equal(got$weight, min(1, H / J), tolerance = 1e-6)
  expect_equal(got$trace, J / H, tolerance = 1e-6)
  expect_identical(got$p, 1L)
})

test_that("calibrate() weighs the inputs' likelihood for shared errors by default, says so, and keeps the method's by name", {
  withr::local_seed(13)
  gp <- shared_grid_problem()
  run <- function(lik) {
    calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 1, seed = 3,
              bias = bias_control(sigma2 = gp$sigma2, input_likelihood = lik),
              sampler = sampler_control(n_draws = 300, n_inner = 10, quiet = TRUE))
  }
  ind <- run("independent")
  adj <- run("adjusted")
  expect_null(ind$shared_errors)
  w <- adj$shared_errors$weight
  expect_identical(adj$settings$input_likelihood, "adjusted")
  expect_true(any(grepl("taken as independent", capture.output(print(ind)))))
  expect_true(any(grepl(sprintf("raised to %s", format(signif(w, 3))), capture.output(print(adj)), fixed = TRUE)))
  expect_true(any(grepl("sd_ratio", capture.output(print(adj)))))
  # the default is the adjusted likelihood, draw for draw
  def <- calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 1, seed = 3,
                   bias = bias_control(sigma2 = gp$sigma2),
                   sampler = sampler_control(n_draws = 300, n_inner = 10, quiet = TRUE))
  expect_identical(as.matrix(def$draws), as.matrix(adj$draws))
  expect_error(run("pca"), class = "wavevalid_error_input")
})

test_that("errors the coefficients share bring the weight well below 1 and widen the inputs' posterior at every seed", {
  for (s in 1:3) {
    withr::local_seed(100 + s)
    sp <- shift_problem()
    ind <- shift_draws(sp, "independent", seed = s)
    adj <- shift_draws(sp, "adjusted", seed = s)
    # a shift of the whole record is one error repeated by the 8 coefficients: the weight is near 1 / 3
    expect_lt(adj$weight, 0.5)
    # the posterior sd grows by about 1 / sqrt(weight) (1.4 at weight 0.5)
    expect_gt(stats::sd(adj$u1) / stats::sd(ind$u1), 1.3, label = sprintf("seed %d sd ratio", s))
  }
})

test_that("with errors the coefficients share, the adjusted inputs' 95% intervals cover the truth near the nominal rate, the independent ones clearly less", {
  skip_unless_slow()
  # theory: the independent likelihood's sd is too small by about sqrt(w) ~ 0.55, its 95% interval covers
  # 2 pnorm(1.96 * 0.55) - 1 ~ 0.72; the adjusted one near 0.95 less what 8 replicates' covariance costs
  cover <- vapply(1:60, function(r) {
    withr::local_seed(1000 + r)
    u <- stats::runif(1, 0.2, 0.8)
    sp <- shift_problem(u)
    inside <- function(d) {
      q <- stats::quantile(d, c(0.025, 0.975))
      u >= q[[1]] && u <= q[[2]]
    }
    c(independent = inside(shift_draws(sp, "independent", r, 400)$u1),
      adjusted = inside(shift_draws(sp, "adjusted", r, 400)$u1))
  }, logical(2))
  rate <- rowMeans(cover)
  # at these seeds 55 and 37 of the 60 intervals cover (0.92 and 0.62); each bound is two binomial
  # sd from its rate, on its own side of the gap, so that no one coverage passes both
  expect_gte(rate[["adjusted"]], 0.85)
  expect_lte(rate[["independent"]], 0.75)
})

test_that("the weight counts the emulators' errors of two sites that share a design as correlated across the sites", {
  withr::local_seed(14)
  pb <- small_problem(two_inputs = FALSE, level = 4L, K = 7)
  n <- length(pb$basis$index)
  design <- pb$emulators$design
  # site2's model: nearly site1's, so its emulators err where site1's do
  f2 <- function(u) 0.8 * pb$f(u) + 0.1 * u
  banks <- list(site1 = pb$emulators$banks$site1,
                site2 = make_bank(design, t(vapply(design[, 1], f2, numeric(n))), beta = 3, alpha = 0))
  emu <- make_emulators(banks, pb$basis, design)
  R <- 3
  W <- list(site1 = matrix(pb$f(0.3), R, n, byrow = TRUE) + matrix(stats::rnorm(R * n, 0, 0.01), R, n),
            site2 = matrix(f2(0.3), R, n, byrow = TRUE) + matrix(stats::rnorm(R * n, 0, 0.01), R, n))
  field <- new_wv_field(pb$basis$t, lapply(W, function(w) w %*% t(pb$basis$Psi)))
  spec <- calibration_spec(emu, field, pb$iu, sigma2 = list(site1 = 0.01^2, site2 = 0.01^2))
  z <- 0.33
  tau2 <- 1e-4
  expect_identical(nrow(spec$groups), 2L)
  sigma2 <- list(site1 = rep(0.01^2, n), site2 = rep(0.01^2, n))
  got <- composite_weight(spec, field, z, c(tau2, tau2), sigma2)
  # dense: the studentised leave-one-out errors of both sites (same runs) give one correlation matrix
  h <- 1e-4
  parts <- lapply(names(banks), function(s) {
    P <- gasp_bank_predict_cpp(banks[[s]], matrix(c(z, z + h, z - h), ncol = 1))
    list(G = (P$mean[2, ] - P$mean[3, ]) / (2 * h), v = P$var[1, ], E = bank_loo_errors(banks[[s]]),
         S = stats::cov(W[[s]]) / R)
  })
  G <- unlist(lapply(parts, `[[`, "G"))
  v <- unlist(lapply(parts, `[[`, "v"))
  d <- v + 0.01^2 / R + tau2
  dense_weight <- function(E) {
    C <- crossprod(E) / nrow(E)
    C <- C / sqrt(outer(diag(C), diag(C)))
    C[!is.finite(C)] <- 0
    S <- matrix(0, 2 * n, 2 * n)
    S[1:n, 1:n] <- parts[[1]]$S
    S[n + 1:n, n + 1:n] <- parts[[2]]$S
    Sigma <- diag(sqrt(v)) %*% C %*% diag(sqrt(v)) + diag(tau2, 2 * n) + S
    sum(G^2 / d) / drop(t(G / d) %*% Sigma %*% (G / d))
  }
  E <- cbind(parts[[1]]$E, parts[[2]]$E)
  expect_equal(got$weight, min(1, dense_weight(E)), tolerance = 1e-6)
  # the sites' errors taken as independent would count the same error twice as evidence: a larger weight
  E_apart <- rbind(cbind(parts[[1]]$E, 0 * parts[[2]]$E), cbind(0 * parts[[1]]$E, parts[[2]]$E))
  expect_lt(got$weight, min(1, dense_weight(E_apart)) - 0.05)
})

# The stationary distribution, on a grid of (u1, log tau2), of the default
# chain's cycle for one input and one tau2 group, sigma2 known: a tau2 step
# (log-uniform, factor e^0.7, the full likelihood) then an input step (with
# probability 0.9 the random walk of covariance `rw_var`, else the mixture
# step of half-width `half`), the likelihood raised to w in the input step
# alone. Each step's kernel is discretised on the cells (proposal mass by
# overlap, Metropolis-Hastings acceptance at the cells' centres); the
# distribution is found by power iteration. Returns the log-likelihood grid
# and the margins' cdfs of the stationary distribution, of the posterior with
# the likelihood raised to w in both steps and of the unweighted posterior.
weighted_chain_stationary <- function(bank, wbar, s2, R, w, rw_var, half) {
  h <- 0.01
  u <- seq(h / 2, 1 - h / 2, by = h)
  dl <- 0.1
  lt <- seq(log(1e-5), log(20), by = dl)
  Nu <- length(u)
  Nt <- length(lt)
  P <- gasp_bank_predict_cpp(bank, matrix(u, ncol = 1))
  L <- matrix(0, Nu, Nt)
  for (i in seq_along(wbar)) {
    tot <- outer(P$var[, i] + s2 / R, exp(lt), `+`)
    L <- L - 0.5 * (log(tot) + (wbar[i] - P$mean[, i])^2 / tot)
  }
  # tau2's prior 1 / (tau2 + sigma2 / R), with log tau2's Jacobian
  lpt <- -log(exp(lt) + s2 / R) + lt
  diff_mat <- function(x, y) outer(x, y, function(a, b) b - a)
  qt <- matrix(pmax(0, pmin(diff_mat(lt, lt) + dl / 2, 0.7) - pmax(diff_mat(lt, lt) - dl / 2, -0.7)) / 1.4, Nt, Nt)
  stochastic <- function(A) {
    diag(A) <- 0
    diag(A) <- 1 - rowSums(A)
    A
  }
  Kt <- array(0, c(Nt, Nt, Nu))
  for (a in seq_len(Nu)) {
    tg <- L[a, ] + lpt
    Kt[, , a] <- stochastic(qt * pmin(1, exp(diff_mat(tg, tg))))
  }
  du <- diff_mat(u, u)
  sdw <- sqrt(rw_var)
  qrw <- stats::pnorm((du + h / 2) / sdw) - stats::pnorm((du - h / 2) / sdw)
  lo <- pmax(0, u - half)
  hi <- pmin(1, u + half)
  qmix <- 0.5 * h + 0.5 * matrix(pmax(0, pmin(outer(rep(1, Nu), u + h / 2), hi) - pmax(outer(rep(1, Nu), u - h / 2), lo)),
                                 Nu, Nu) / (hi - lo)
  Ku <- array(0, c(Nu, Nu, Nt))
  for (b in seq_len(Nt)) {
    d <- exp(diff_mat(w * L[, b], w * L[, b]))
    Ku[, , b] <- stochastic(0.9 * qrw * pmin(1, d) + 0.1 * qmix * pmin(1, d * t(qmix) / qmix))
  }
  joint_w <- exp(w * L + outer(rep(1, Nu), lpt))
  p <- joint_w / sum(joint_w)
  for (it in 1:3000) {
    old <- p
    for (a in seq_len(Nu)) p[a, ] <- p[a, ] %*% Kt[, , a]
    for (b in seq_len(Nt)) p[, b] <- crossprod(Ku[, , b], p[, b])
    if (it %% 50 == 0 && sum(abs(p - old)) < 1e-9) break
  }
  cdf <- function(x, m, hw) stats::approxfun(x + hw, cumsum(m) / sum(m), yleft = 0, yright = 1)
  margins <- function(q) list(u1 = cdf(u, rowSums(q), h / 2), tau2 = cdf(lt, colSums(q), dl / 2))
  list(stationary = margins(p), joint_w = margins(joint_w), full = margins(exp(L + outer(rep(1, Nu), lpt))))
}

test_that("the default chain (the weight in the inputs' steps alone, tau2 free) samples the stationary distribution of its cycle computed on a grid, and not with the weight dropped", {
  skip_unless_slow()
  withr::local_seed(11)
  gp <- shared_grid_problem()
  spec <- calibration_spec(gp$pb$emulators, gp$field, gp$pb$iu, sigma2 = gp$sigma2)
  spec$input_weight <- 0.3
  tau <- resolve_fix_tau2(NULL, spec$groups)
  sm <- sampler_control(n_draws = 1500, n_inner = 30, burnin = 5000, n_search = 200, quiet = TRUE)
  # every third draw: tau2's effective sample size is about 740 of the 1500
  keep <- seq(1, 1500, by = 3)
  run <- function(debug_break) {
    ch <- run_chains(spec, sm, 1, 5, tau, debug_break = debug_break)[[1]]
    list(u1 = ch$inputs[keep, 1], tau2 = log(ch$tau2[keep, 1]), rw_var = ch$proposal_cov[1, 1])
  }
  ks <- function(d, m) vapply(c("u1", "tau2"), function(q) suppressWarnings(stats::ks.test(d[[q]], m[[q]])$p.value), 1)
  ok <- run(0L)
  g <- weighted_chain_stationary(gp$pb$emulators$banks$site1, gp$wbar, gp$sigma2, gp$R, 0.3, ok$rw_var, sm$step)
  p_ok <- ks(ok, g$stationary)
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  # neither the posterior with the weight in tau2's steps too nor the unweighted one
  expect_lt(min(ks(ok, g$joint_w)), 0.001)
  expect_lt(min(ks(ok, g$full)), 0.001)
  # the weight dropped (taken as 1): the unweighted posterior
  broken <- run(7L)
  expect_lt(min(ks(broken, g$stationary)), 0.001)
  expect_gt(min(ks(broken, g$full)), 0.01)
})
