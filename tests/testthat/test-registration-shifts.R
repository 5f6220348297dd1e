# The registration's error as shifts along the curves' time-shift directions:
# a Gibbs step on the shifts a (prior N(0, diag(var))) that move the field
# means by U a.

# One chain of the C++ sampler on sbc_setup()'s problem with field means
# `wbar`, optional shift columns U (n x K) and variances `var`, or a known
# `extra` variance per coefficient.
shift_chain <- function(s, wbar, U = NULL, var = NULL, extra = NULL, seed = 1, n_draws = 2000L, tau2 = 0.05,
                        debug_break = 0L) {
  spec <- s$spec
  spec$sites$site1$wbar <- wbar
  spec$sites$site1$reg_U <- U
  if (!is.null(extra)) spec$sites$site1$extra <- extra
  calibrate_chain_cpp(spec$sites, spec$priors, list(
    n_groups = s$G, z_init = 0.5, tau2_init = rep(tau2, s$G), fix_tau2 = TRUE, n_draws = n_draws,
    n_inner = 5L, step = 0.5, seed = seed, chain = 1L, adaptive = TRUE, burnin = 300L, n_search = 20L,
    reg_shift_var = var, debug_break = debug_break))
}

test_that("a shift acting on one coefficient gives the posterior of a known variance added to it", {
  s <- sbc_setup(R = 2, sigma2 = 0.5)
  withr::local_seed(3)
  wbar <- s$pb$f(0.3) + stats::rnorm(s$n, 0, 0.3)
  # shifts on coefficients 2 and 5 alone, with columns 1.5 and -0.8 and
  # variances 0.4 and 0.9: a covariance diag(1.5^2 0.4, 0.8^2 0.9) there
  U <- matrix(0, s$n, 2)
  U[2, 1] <- 1.5
  U[5, 2] <- -0.8
  extra <- numeric(s$n)
  extra[c(2, 5)] <- c(1.5^2 * 0.4, 0.8^2 * 0.9)
  a <- shift_chain(s, wbar, U = U, var = c(0.4, 0.9), seed = 1, n_draws = 6000L)
  b <- shift_chain(s, wbar, extra = extra, seed = 2, n_draws = 6000L)
  expect_equal(dim(a$reg_shift), c(6000L, 2L))
  expect_equal(ncol(b$reg_shift), 0L)
  # the input's posterior quantiles agree within their Monte Carlo error
  q <- c(0.1, 0.5, 0.9)
  expect_lt(max(abs(stats::quantile(a$inputs[, 1], q) - stats::quantile(b$inputs[, 1], q))), 0.03)
  # the bias of coefficient 2: with the shift it is drawn given the shift, so
  # its marginal is the bias's given the known variance less the shift's part
  # plus nothing: the bias and the shift share what the data say of their sum
  sum_a <- a$wb[[1]][, 2] + 1.5 * a$reg_shift[, 1]
  expect_lt(abs(mean(sum_a) - (wbar[2] - mean(a$wM[[1]][, 2]))), 0.1)
  # a shift on no coefficient leaves its prior
  U0 <- cbind(U, 0)
  c0 <- shift_chain(s, wbar, U = U0, var = c(0.4, 0.9, 0.25), seed = 3, n_draws = 4000L)
  expect_lt(abs(stats::sd(c0$reg_shift[, 3]) - 0.5), 0.03)
  expect_lt(abs(mean(c0$reg_shift[, 3])), 0.03)
})

test_that("simulation-based calibration with registration shifts: the input, a bias and a shift", {
  s <- sbc_setup(R = 2, sigma2 = 9)
  n <- s$n
  tau2 <- 0.05
  withr::local_seed(20261129)
  U <- cbind(sin(seq_len(n)), cos(0.5 * seq_len(n))) * 2
  v <- c(0.3, 0.6)
  reps <- 600L
  L <- 49L
  # `told`: the shifts' variances the sampler is given (v: right)
  sbc <- function(told) {
    ranks <- matrix(NA_integer_, reps, 3, dimnames = list(NULL, c("u1", "wb1", "a1")))
    for (r in seq_len(reps)) {
      z <- stats::runif(1)
      pr <- gasp_bank_predict_cpp(s$bank, matrix(z, 1))
      wM <- stats::rnorm(n, pr$mean, sqrt(pr$var))
      wb <- stats::rnorm(n, 0, sqrt(tau2))
      a <- stats::rnorm(2, 0, sqrt(v))
      wbar <- wM + wb + drop(U %*% a) + stats::rnorm(n, 0, 3 / sqrt(2))
      out <- shift_chain(s, wbar, U = U, var = told, seed = r, n_draws = L, tau2 = tau2)
      ranks[r, ] <- c(sum(out$inputs[, 1] < z), sum(out$wb[[1]][, 1] < wb[1]), sum(out$reg_shift[, 1] < a[1]))
    }
    sbc_rank_pvalues(ranks, L)
  }
  p <- sbc(v)
  expect_true(all(p > 0.01), label = paste(signif(p, 3), collapse = ", "))
  # told a quarter of the shifts' variance, the shifts' ranks are not uniform
  expect_lt(sbc(v / 4)[["a1"]], 0.01)
})

test_that("the inputs' steps take the shifts integrated out: a shift that moves the data as the input does costs no mixing", {
  s <- sbc_setup(R = 2, sigma2 = 0.02)
  withr::local_seed(7)
  wbar <- s$pb$f(0.4) + stats::rnorm(s$n, 0, 0.1)
  # the shift's column is the model's change per unit of u1 at 0.4: shift and
  # input move the field means the same way, the shift's prior (sd 0.1 of u1)
  # against the data's narrow constraint on their sum
  h <- 1e-4
  U <- matrix((s$pb$f(0.4 + h) - s$pb$f(0.4 - h)) / (2 * h), ncol = 1)
  a <- shift_chain(s, wbar, U = U, var = 0.01, seed = 1, n_draws = 3000L)
  b <- shift_chain(s, wbar, U = U, var = 0.01, seed = 1, n_draws = 3000L, debug_break = 8L)
  ess <- function(x) coda::effectiveSize(x)[[1]]
  # the same posterior (both chains are valid), far more effective draws when
  # the inputs' steps integrate the shift out
  expect_lt(abs(stats::median(a$inputs[, 1]) - stats::median(b$inputs[, 1])), 0.03)
  expect_gt(ess(a$inputs[, 1]), 3 * ess(b$inputs[, 1]))
})

test_that("the sampler refuses shifts it cannot take", {
  s <- sbc_setup(R = 2, sigma2 = 0.5)
  wbar <- s$pb$f(0.3)
  expect_error(shift_chain(s, wbar, U = matrix(1, s$n, 2), var = 1, n_draws = 5L), "wrong size")
  expect_error(shift_chain(s, wbar, U = matrix(1, s$n, 1), var = 0, n_draws = 5L), "positive")
})
