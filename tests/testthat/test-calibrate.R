# Runs an SBC study: truth (u, w^M, w^b) from the model, field data from the
# truth, ranks of the truth among thinned posterior draws. One input u1 with a
# uniform prior, weak data, tau2 and sigma2 known.
sbc_pvalues <- function(reps, debug_break = 0L, step = 0.5, n_draws = 60L, n_inner = 20L,
                        sd_eps = 3, R = 2, tau2 = 0.05) {
  pb <- small_problem(two_inputs = FALSE)
  n <- length(pb$basis$index)
  spec <- wavevalid:::calibration_spec(pb$emulators, field_from_coef(pb$basis, matrix(0, R, n)), pb$iu,
                                       sigma2 = sd_eps^2)
  G <- nrow(spec$groups)
  bank <- pb$emulators$banks$site1
  burn <- 11L
  L <- n_draws - burn + 1L
  ranks <- matrix(NA_integer_, reps, 3, dimnames = list(NULL, c("u1", "wb1", "wM2")))
  for (r in seq_len(reps)) {
    z <- stats::runif(1)
    pr <- wavevalid:::gasp_bank_predict_cpp(bank, matrix(z, 1))
    wM <- stats::rnorm(n, pr$mean, sqrt(pr$var))
    wb <- stats::rnorm(n, 0, sqrt(tau2))
    spec$sites$site1$wbar <- wM + wb + stats::rnorm(n, 0, sd_eps / sqrt(R))
    out <- wavevalid:::calibrate_chain_cpp(spec$sites, spec$priors, G, 0.5, rep(tau2, G), TRUE,
                                           n_draws, n_inner, step, r, 1L, debug_break, NULL)
    keep <- burn:n_draws
    ranks[r, ] <- c(sum(out$inputs[keep, 1] < z), sum(out$wb[[1]][keep, 1] < wb[1]),
                    sum(out$wM[[1]][keep, 2] < wM[2]))
  }
  # L draws give ranks 0..L; L + 1 = 50 values in 10 bins of 5.
  apply(ranks, 2, function(x) stats::chisq.test(tabulate(x %/% ((L + 1) / 10) + 1, 10))$p.value)
}

test_that("simulation-based calibration: ranks are uniform, and not when the Hastings ratio is broken", {
  skip_on_cran()
  withr::local_seed(20240611)
  p_ok <- sbc_pvalues(6000)
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  withr::local_seed(20240611)
  p_broken <- sbc_pvalues(6000, debug_break = 1L)
  expect_lt(p_broken[["u1"]], 0.01)
})
