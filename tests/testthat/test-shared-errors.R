# One input, one tau2 group, sigma2 known (as in test-calibrate.R's grid
# problem): three replicates at u1 = 0.3.
shared_grid_problem <- function() {
  pb <- small_problem(two_inputs = FALSE, level = 4L)
  n <- length(pb$basis$index)
  R <- 3
  pr <- wavevalid:::gasp_bank_predict_cpp(pb$emulators$banks$site1, matrix(0.3, 1))
  W <- matrix(drop(pr$mean) + stats::rnorm(n, 0, 0.3), R, n, byrow = TRUE) + matrix(stats::rnorm(R * n, 0, 0.6), R, n)
  list(pb = pb, field = field_from_coef(pb$basis, W), sigma2 = 0.36, R = R, W = W, wbar = colMeans(W))
}

test_that("with the inputs' weight and tau2 fixed, the sampler reproduces the grid posterior of the likelihood raised to it, and not when the weight is dropped", {
  withr::local_seed(11)
  gp <- shared_grid_problem()
  u <- seq(0.0005, 0.9995, by = 0.001)
  P <- wavevalid:::gasp_bank_predict_cpp(gp$pb$emulators$banks$site1, matrix(u, ncol = 1))
  t2 <- 0.09
  post_cdf <- function(w) {
    lp <- w * vapply(seq_along(u), function(a) {
      sum(stats::dnorm(gp$wbar, P$mean[a, ], sqrt(P$var[a, ] + gp$sigma2 / gp$R + t2), log = TRUE))
    }, numeric(1))
    d <- exp(lp - max(lp))
    stats::approxfun(u, cumsum(d) / sum(d), yleft = 0, yright = 1)
  }
  spec <- wavevalid:::calibration_spec(gp$pb$emulators, gp$field, gp$pb$iu, sigma2 = gp$sigma2)
  spec$input_weight <- 0.2
  tau <- wavevalid:::resolve_fix_tau2(t2, spec$groups)
  run <- function(debug_break) {
    sm <- sampler_control(n_draws = 1500, n_inner = 30, burnin = 5000, n_search = 200, quiet = TRUE)
    wavevalid:::run_chains(spec, sm, 1, 5, tau, debug_break = debug_break)[[1]]$inputs[, 1]
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
  spec <- wavevalid:::calibration_spec(gp$pb$emulators, gp$field, gp$pb$iu, sigma2 = gp$sigma2)
  z <- 0.35
  tau2 <- 0.05
  sigma2 <- list(site1 = rep(gp$sigma2, length(gp$wbar)))
  got <- wavevalid:::composite_weight(spec, gp$field, z, tau2, sigma2)
  bank <- gp$pb$emulators$banks$site1
  h <- 1e-4
  P <- wavevalid:::gasp_bank_predict_cpp(bank, matrix(c(z, z + h, z - h), ncol = 1))
  G <- (P$mean[2, ] - P$mean[3, ]) / (2 * h)
  v <- P$var[1, ]
  d <- v + gp$sigma2 / gp$R + tau2
  E <- wavevalid:::bank_loo_errors(bank)
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
  expect_gte(rate[["adjusted"]], 0.8)
  expect_lt(rate[["independent"]], 0.8)
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
  field <- wavevalid:::new_wv_field(pb$basis$t, lapply(W, function(w) w %*% t(pb$basis$Psi)))
  spec <- wavevalid:::calibration_spec(emu, field, pb$iu, sigma2 = list(site1 = 0.01^2, site2 = 0.01^2))
  z <- 0.33
  tau2 <- 1e-4
  expect_identical(nrow(spec$groups), 2L)
  sigma2 <- list(site1 = rep(0.01^2, n), site2 = rep(0.01^2, n))
  got <- wavevalid:::composite_weight(spec, field, z, c(tau2, tau2), sigma2)
  # dense: the studentised leave-one-out errors of both sites (same runs) give one correlation matrix
  h <- 1e-4
  parts <- lapply(names(banks), function(s) {
    P <- wavevalid:::gasp_bank_predict_cpp(banks[[s]], matrix(c(z, z + h, z - h), ncol = 1))
    list(G = (P$mean[2, ] - P$mean[3, ]) / (2 * h), v = P$var[1, ], E = wavevalid:::bank_loo_errors(banks[[s]]),
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
