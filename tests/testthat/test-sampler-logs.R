# The sampler takes each log of a coefficient's variance once and reads it
# again where the same number is needed (the bias variances' steps, the
# likelihood after them, a taken proposal). With every log taken afresh
# (debug_break 9) the draws must be the same to the bit, on every path that
# changes a variance: the bias variances' steps, the walk's, the mixture's
# and the independence proposals, the noise drawn at each saved draw or
# learned by its own steps, the registration's shifts, the report's joint
# steps, a chain continued from its state.

logs_chain <- function(s, wbar, s2, debug_break, U = NULL, adaptive = TRUE, n_draws = 60L, resume = NULL,
                       p_indep = 0.2) {
  spec <- s$spec
  spec$sites$site1$wbar <- wbar
  spec$sites$site1$s2 <- s2
  spec$sites$site1$reg_U <- U
  calibrate_chain_cpp(spec$sites, spec$priors, list(
    n_groups = s$G, z_init = 0.5, tau2_init = numeric(0), fix_tau2 = FALSE, n_draws = n_draws, n_inner = 5L, step = 0.3, seed = 7, chain = 1L,
    adaptive = adaptive, burnin = if (adaptive) 200L else 0L, n_search = 10L, p_global = 0.1,
    p_indep = p_indep, reg_shift_var = if (!is.null(U)) rep(0.01, ncol(U)), debug_break = debug_break,
    resume = resume))
}

logs_data <- function(s, R) {
  pr <- gasp_bank_predict_cpp(s$bank, matrix(0.4, 1))
  W <- matrix(pr$mean + stats::rnorm(s$n, 0, 0.1), R, s$n, byrow = TRUE) +
    matrix(stats::rnorm(R * s$n, 0, 0.05), R, s$n)
  list(wbar = colMeans(W), s2 = colSums(sweep(W, 2L, colMeans(W))^2))
}

expect_same_chain <- function(a, b) {
  for (nm in c("inputs", "tau2", "reg_shift", "sigma2", "wb", "wM")) expect_identical(a[[nm]], b[[nm]], label = nm)
}

test_that("the kept logs give the draws of logs taken afresh, on every path", {
  withr::local_seed(91)
  # replicates: the noise drawn at each saved draw
  s <- sbc_setup(3L, NULL)
  d <- logs_data(s, 3L)
  U <- matrix(0, s$n, 2)
  U[c(2, 5, 7), 1] <- c(0.3, -0.2, 0.1)
  U[c(5, 8), 2] <- c(0.4, 0.2)
  for (shifts in list(NULL, U)) {
    expect_same_chain(logs_chain(s, d$wbar, d$s2, 0L, U = shifts), logs_chain(s, d$wbar, d$s2, 9L, U = shifts))
    expect_same_chain(logs_chain(s, d$wbar, d$s2, 0L, U = shifts, adaptive = FALSE),
                      logs_chain(s, d$wbar, d$s2, 9L, U = shifts, adaptive = FALSE))
  }
  # a continued chain
  a <- logs_chain(s, d$wbar, d$s2, 0L, U = U, n_draws = 30L)
  b <- logs_chain(s, d$wbar, d$s2, 9L, U = U, n_draws = 30L)
  expect_same_chain(logs_chain(s, d$wbar, d$s2, 0L, U = U, n_draws = 30L, resume = a$state),
                    logs_chain(s, d$wbar, d$s2, 9L, U = U, n_draws = 30L, resume = b$state))
  # one curve: the noise learned by its own steps
  s1 <- sbc_setup(1L, noise_prior(scale = 0.1))
  d1 <- logs_data(s1, 1L)
  for (shifts in list(NULL, U)) {
    expect_same_chain(logs_chain(s1, d1$wbar, d1$s2, 0L, U = shifts), logs_chain(s1, d1$wbar, d1$s2, 9L, U = shifts))
  }
})
