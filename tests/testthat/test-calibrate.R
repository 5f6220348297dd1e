# Runs an SBC study: truth (u, w^M, w^b) from the model, field data from the
# truth, ranks of the truth among thinned posterior draws. One input u1 with a
# uniform prior, weak data, tau2 and sigma2 known. The report's sampler starts
# at 0.5 and drops 11 saved draws; the adaptive one adapts during `burnin`
# cycles (not saved).
sbc_pvalues <- function(reps, debug_break = 0L, step = 0.5, n_draws = 60L, n_inner = 20L,
                        sd_eps = 3, R = 2, tau2 = 0.05, proposal = "report", burnin = 300L,
                        p_global = 0.1, p_indep = 0.5) {
  s <- sbc_setup(R, sd_eps^2)
  n <- s$n
  spec <- s$spec
  G <- s$G
  bank <- s$bank
  adaptive <- proposal == "adaptive"
  burn <- if (adaptive) 1L else 12L
  L <- n_draws - burn + 1L
  ranks <- matrix(NA_integer_, reps, 3, dimnames = list(NULL, c("u1", "wb1", "wM2")))
  for (r in seq_len(reps)) {
    z <- stats::runif(1)
    pr <- gasp_bank_predict_cpp(bank, matrix(z, 1))
    wM <- stats::rnorm(n, pr$mean, sqrt(pr$var))
    wb <- stats::rnorm(n, 0, sqrt(tau2))
    spec$sites$site1$wbar <- wM + wb + stats::rnorm(n, 0, sd_eps / sqrt(R))
    out <- calibrate_chain_cpp(spec$sites, spec$priors, list(
      n_groups = G, z_init = 0.5, tau2_init = rep(tau2, G), fix_tau2 = TRUE, n_draws = n_draws,
      n_inner = n_inner, step = step, seed = r, chain = 1L, debug_break = debug_break,
      adaptive = adaptive, burnin = if (adaptive) burnin else 0L, p_global = p_global, p_indep = p_indep,
      n_search = 20L))
    keep <- burn:n_draws
    ranks[r, ] <- c(sum(out$inputs[keep, 1] < z), sum(out$wb[[1]][keep, 1] < wb[1]),
                    sum(out$wM[[1]][keep, 2] < wM[2]))
  }
  # L = 49 kept draws give ranks 0..49: 50 values in 10 bins of 5.
  sbc_rank_pvalues(ranks, L)
}

test_that("simulation-based calibration: ranks are uniform, and not when the Hastings ratio is broken", {
  skip_unless_slow()
  withr::local_seed(20240611)
  p_ok <- sbc_pvalues(6000)
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  withr::local_seed(20240611)
  p_broken <- sbc_pvalues(6000, debug_break = 1L)
  expect_lt(p_broken[["u1"]], 0.01)
})

test_that("simulation-based calibration of the adaptive sampler", {
  skip_unless_slow()
  withr::local_seed(20240612)
  p_ok <- sbc_pvalues(4000, n_draws = 49L, n_inner = 10L, proposal = "adaptive")
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  # its independence moves without the proposal-density ratio
  withr::local_seed(20240612)
  p_broken <- sbc_pvalues(10000, debug_break = 1L, n_draws = 49L, n_inner = 10L, proposal = "adaptive",
                          p_global = 0.5)
  expect_lt(p_broken[["u1"]], 0.01)
  # the report's mixture step as the global move (no independence moves)
  # without the mixture-density ratio; at its default rate (0.1) the error is
  # too small to see in a few thousand replications, so it is made frequent
  withr::local_seed(20240612)
  p_broken <- sbc_pvalues(10000, debug_break = 1L, n_draws = 49L, n_inner = 10L, proposal = "adaptive",
                          p_global = 0.5, p_indep = 0)
  expect_lt(p_broken[["u1"]], 0.01)
})

# The same studies at a smaller size, for the default tier: they detect a
# gross error of the sampler, the full-size ones (slow tier) a broken
# Hastings ratio too.
test_that("simulation-based calibration at a small size: ranks are uniform for both samplers", {
  withr::local_seed(20240613)
  p_report <- sbc_pvalues(1500)
  expect_true(all(p_report > 0.01), label = paste(signif(p_report, 3), collapse = ", "))
  withr::local_seed(20240614)
  p_adaptive <- sbc_pvalues(1000, n_draws = 49L, n_inner = 10L, proposal = "adaptive")
  expect_true(all(p_adaptive > 0.01), label = paste(signif(p_adaptive, 3), collapse = ", "))
})

grid_marginals <- function(gp, temper = 1) {
  bank <- gp$pb$emulators$banks$site1
  u <- seq(0.0005, 0.9995, by = 0.001)
  lt <- seq(-12, 6, by = 0.01)
  P <- gasp_bank_predict_cpp(bank, matrix(u, ncol = 1))
  e <- gp$sigma2 / gp$R
  logp <- outer(seq_along(u), seq_along(lt), Vectorize(function(a, b) {
    t2 <- exp(lt[b])
    temper * sum(stats::dnorm(gp$wbar, P$mean[a, ], sqrt(P$var[a, ] + e + t2), log = TRUE)) -
      log(t2 + gp$sigma2 / gp$R) + lt[b]
  }))
  d <- exp(logp - max(logp))
  list(u = u, fu = rowSums(d) / sum(d), lt = lt, flt = colSums(d) / sum(d))
}

grid_check <- function(proposal, n_draws, n_inner) {
  withr::local_seed(11)
  gp <- grid_problem()
  gm <- grid_marginals(gp)
  cdf_u <- stats::approxfun(gm$u, cumsum(gm$fu), yleft = 0, yright = 1)
  cdf_lt <- stats::approxfun(gm$lt, cumsum(gm$flt), yleft = 0, yright = 1)
  fit <- calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 1, seed = 5,
                   bias = bias_control(sigma2 = gp$sigma2, input_likelihood = "independent"),
                   sampler = sampler_control(n_draws = n_draws, n_inner = n_inner, proposal = proposal, quiet = TRUE))
  X <- as.matrix(fit$draws)
  expect_gt(stats::ks.test(X[, "u1"], cdf_u)$p.value, 0.01)
  expect_gt(stats::ks.test(log(X[, "tau2[site1:4]"]), cdf_lt)$p.value, 0.01)
  # the posterior is informative: not the uniform prior
  expect_lt(stats::ks.test(X[, "u1"], "punif")$p.value, 0.01)

  spec <- calibration_spec(gp$pb$emulators, gp$field, gp$pb$iu, sigma2 = gp$sigma2)
  tau <- resolve_fix_tau2(NULL, spec$groups)
  sm <- sampler_control(n_draws = n_draws, n_inner = n_inner, proposal = proposal, burnin = fit$settings$burnin,
                        quiet = TRUE)
  broken <- run_chains(spec, sm, 1, 5, tau, debug_break = 2L)[[1]]
  expect_lt(stats::ks.test(log(broken$tau2[, 1]), cdf_lt)$p.value, 0.01)
}

test_that("the sampler reproduces a posterior computed on a grid, and not with a broken tau2 ratio", {
  grid_check("report", 1500, 30)
})

test_that("the adaptive sampler reproduces the grid posterior, and not with a broken tau2 ratio", {
  grid_check("adaptive", 1500, 30)
})

test_that("a tempered calibration reproduces the grid posterior of the likelihood raised to temper", {
  withr::local_seed(11)
  gp <- grid_problem()
  gm <- grid_marginals(gp, temper = 0.25)
  g1 <- grid_marginals(gp)
  cdf <- function(x, f) stats::approxfun(x, cumsum(f), yleft = 0, yright = 1)
  fit <- calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 1, seed = 5,
                   bias = bias_control(sigma2 = gp$sigma2, temper = 0.25, input_likelihood = "independent"),
                   sampler = sampler_control(n_draws = 1500, n_inner = 30, quiet = TRUE))
  expect_identical(fit$settings$temper, 0.25)
  expect_true(any(grepl("Tempered posterior", capture.output(print(fit)))))
  X <- as.matrix(fit$draws)
  expect_gt(suppressWarnings(stats::ks.test(X[, "u1"], cdf(gm$u, gm$fu))$p.value), 0.01)
  expect_gt(stats::ks.test(log(X[, "tau2[site1:4]"]), cdf(gm$lt, gm$flt))$p.value, 0.01)
  # not the method's posterior, which is narrower
  expect_lt(suppressWarnings(stats::ks.test(X[, "u1"], cdf(g1$u, g1$fu))$p.value), 0.01)
  # temper = 1 is the method's posterior, draw for draw
  a <- calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 1, seed = 2,
                 bias = bias_control(sigma2 = gp$sigma2, input_likelihood = "independent"),
                 sampler = sampler_control(n_draws = 50, n_inner = 5, quiet = TRUE))
  b <- calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 1, seed = 2,
                 bias = bias_control(sigma2 = gp$sigma2, temper = 1, input_likelihood = "independent"),
                 sampler = sampler_control(n_draws = 50, n_inner = 5, quiet = TRUE))
  expect_identical(as.matrix(a$draws), as.matrix(b$draws))
  for (bad in list(0, -0.5, 1.5, NA_real_, "0.5", c(0.5, 0.6))) {
    expect_error(calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 1, bias = bias_control(temper = bad),
                           sampler = sampler_control(n_draws = 5, n_inner = 2, quiet = TRUE)), class = "wavevalid_error_input")
  }
})

test_that("pooled levels share one tau2: the sampler reproduces the grid posterior of a shared variance", {
  withr::local_seed(11)
  gp <- grid_problem()
  # the same data, its coefficients now spread over two levels
  gp$pb$basis$level <- rep(c(2L, 3L), length.out = length(gp$pb$basis$index))
  gp$pb$emulators$basis <- gp$pb$basis
  gm <- grid_marginals(gp)
  cdf_lt <- stats::approxfun(gm$lt, cumsum(gm$flt), yleft = 0, yright = 1)
  fit <- calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 1, seed = 5,
                   bias = bias_control(sigma2 = gp$sigma2, pool_levels = 2:3, input_likelihood = "independent"),
                   sampler = sampler_control(n_draws = 1500, n_inner = 30, quiet = TRUE))
  expect_identical(fit$groups$name, "site1:2-3")
  expect_identical(unique(fit$bias_group$site1), "site1:2-3")
  X <- as.matrix(fit$draws)
  expect_gt(stats::ks.test(log(X[, "tau2[site1:2-3]"]), cdf_lt)$p.value, 0.01)
  # one variance per level is another posterior: level 2 alone does not follow it
  own <- calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 1, seed = 5,
                   bias = bias_control(sigma2 = gp$sigma2, pool_levels = NULL, input_likelihood = "independent"),
                   sampler = sampler_control(n_draws = 1500, n_inner = 30, quiet = TRUE))
  expect_identical(own$groups$name, c("site1:2", "site1:3"))
  expect_lt(stats::ks.test(log(as.matrix(own$draws)[, "tau2[site1:2]"]), cdf_lt)$p.value, 0.01)
})

test_that("pool_levels refuses what is not two or more levels of the basis", {
  ex <- example_problem()
  for (bad in list(1, c(0, -1), c(0.5, 1), "0:3", c(0, 99))) {
    expect_error(calibrate(ex$emulators, ex$field, ex$iu, bias = bias_control(pool_levels = bad),
                           sampler = sampler_control(quiet = TRUE)),
                 class = "wavevalid_error_input")
  }
})

# A field on small_problem()'s 8 coefficients (levels 0, 1, 2, 2, 3, 3, 3, 3):
# the model at u1 = 0.35, x1 = 0.6 plus noise, and `fine` added to the level-3
# coefficients of every replicate.
cut_problem <- function(fine = 0) {
  pb <- small_problem()
  withr::with_seed(4, {
    W <- t(replicate(5, pb$f(c(0.35, 0.6)) + stats::rnorm(8, sd = 0.05)))
  })
  W[, pb$basis$level == 3] <- W[, pb$basis$level == 3] + fine
  list(pb = pb, field = field_from_coef(pb$basis, W))
}

test_that("inform_levels naming every level is the method's posterior, draw for draw", {
  cp <- cut_problem()
  for (proposal in c("adaptive", "report")) {
    all <- calibrate(cp$pb$emulators, cp$field, cp$pb$iu, chains = 1, seed = 3,
                     sampler = sampler_control(n_draws = 50, n_inner = 5, proposal = proposal, quiet = TRUE))
    same <- calibrate(cp$pb$emulators, cp$field, cp$pb$iu, chains = 1, seed = 3,
                      bias = bias_control(inform_levels = 0:3),
                      sampler = sampler_control(n_draws = 50, n_inner = 5, proposal = proposal, quiet = TRUE))
    expect_identical(as.matrix(same$draws), as.matrix(all$draws))
    expect_identical(same$wb, all$wb)
  }
})

test_that("with inform_levels, the levels left out do not move the inputs but keep their own bias", {
  base <- cut_problem()
  off <- cut_problem(fine = 2)
  # the shift sits in the level-3 coefficients of the field mean only
  d <- calibration_spec(off$pb$emulators, off$field, off$pb$iu)$wbar$site1 -
    calibration_spec(base$pb$emulators, base$field, base$pb$iu)$wbar$site1
  expect_equal(unname(d), ifelse(base$pb$basis$level == 3, 2, 0), tolerance = 1e-10)
  for (proposal in c("adaptive", "report")) {
    run <- function(cp, inform_levels) {
      calibrate(cp$pb$emulators, cp$field, cp$pb$iu, chains = 1, seed = 7,
                bias = bias_control(pool_levels = NULL, inform_levels = inform_levels),
                sampler = sampler_control(n_draws = 200, n_inner = 10, proposal = proposal, quiet = TRUE))
    }
    a <- run(base, 0:2)
    b <- run(off, 0:2)
    # the coarse coefficients of the shifted field differ from the others by rounding only
    expect_equal(as.matrix(b$draws)[, b$inputs], as.matrix(a$draws)[, a$inputs], tolerance = 1e-10)
    expect_identical(b$settings$inform_levels, 0:2)
    expect_output(print(b), "Inputs informed by wavelet levels 0, 1, 2 only")
    # the bias of the level-3 coefficients takes up the shift
    fine <- base$pb$basis$level == 3
    expect_true(all(abs(colMeans(b$wb$site1)[fine] - colMeans(a$wb$site1)[fine] - 2) < 0.3))
    # without the cut, the same shift moves the inputs
    moved <- as.matrix(run(off, NULL)$draws)[, a$inputs] - as.matrix(run(base, NULL)$draws)[, a$inputs]
    expect_gt(max(abs(moved)), 0.01)
  }
})

test_that("the inputs' posterior with inform_levels is the posterior from those levels alone", {
  cp <- cut_problem(fine = 2)
  cut <- calibrate(cp$pb$emulators, cp$field, cp$pb$iu, chains = 1, seed = 5,
                   bias = bias_control(pool_levels = NULL, inform_levels = 0:2, input_likelihood = "independent"),
                   sampler = sampler_control(n_draws = 1500, n_inner = 20, quiet = TRUE))
  # the same problem on its first four coefficients (levels 0 to 2) only
  coarse <- small_problem(index = 1:4)
  W <- cp$field$curves$site1 %*% cp$pb$basis$Psi
  alone <- calibrate(coarse$emulators, field_from_coef(coarse$basis, W[, 1:4]), coarse$iu, chains = 1,
                     seed = 6, bias = bias_control(pool_levels = NULL, input_likelihood = "independent"),
                     sampler = sampler_control(n_draws = 1500, n_inner = 20, quiet = TRUE))
  plain <- cut_problem()
  full <- calibrate(plain$pb$emulators, plain$field, plain$pb$iu, chains = 1, seed = 5,
                    bias = bias_control(pool_levels = NULL, input_likelihood = "independent"),
                    sampler = sampler_control(n_draws = 1500, n_inner = 20, quiet = TRUE))
  for (p in c("u1", "x1")) {
    expect_gt(suppressWarnings(stats::ks.test(as.matrix(cut$draws)[, p], as.matrix(alone$draws)[, p]))$p.value, 0.01)
  }
  # where the level-3 coefficients inform the inputs (the method's posterior), it is another one
  expect_lt(min(vapply(c("u1", "x1"), function(p) {
    suppressWarnings(stats::ks.test(as.matrix(full$draws)[, p], as.matrix(alone$draws)[, p]))$p.value
  }, numeric(1))), 0.01)
})

test_that("inform_levels refuses levels the basis lacks, a split pool, and leaving nothing", {
  ex <- example_problem()
  for (bad in list("0:3", c(0.5, 1), 99, NA_real_, numeric(0))) {
    expect_error(calibrate(ex$emulators, ex$field, ex$iu, bias = bias_control(inform_levels = bad),
                           sampler = sampler_control(quiet = TRUE)),
                 class = "wavevalid_error_input")
  }
  expect_error(calibrate(ex$emulators, ex$field, ex$iu,
                         bias = bias_control(pool_levels = 0:3, inform_levels = 0:2),
                         sampler = sampler_control(quiet = TRUE)),
               class = "wavevalid_error_input", regexp = "share one bias variance")
})

test_that("the adaptive sampler mixes on a narrow posterior where the report's does not", {
  withr::local_seed(7)
  pb <- narrow_problem()
  truth <- pb$truth
  field <- pb$field
  fit <- calibrate(pb$emulators, field, pb$iu, chains = 2, seed = 3, bias = bias_control(pool_levels = NULL),
                   sampler = sampler_control(n_draws = 300, n_inner = 10, quiet = TRUE))
  expect_true(all(fit$rhat < 1.1), label = paste(signif(fit$rhat, 3), collapse = ", "))
  X <- as.matrix(fit$draws)[, c("u1", "x1")]
  q <- apply(X, 2, stats::quantile, c(0.005, 0.995))
  expect_true(all(q[1, ] <= truth & truth <= q[2, ]), label = paste(signif(q, 3), collapse = ", "))
  # the posterior is narrow: 99% intervals shorter than 5% of the ranges
  expect_true(all(q[2, ] - q[1, ] < 0.05))
  expect_gt(min(fit$acceptance$inputs), 0.1)
  rep_fit <- suppressWarnings(
    calibrate(pb$emulators, field, pb$iu, chains = 2, seed = 3, bias = bias_control(pool_levels = NULL),
              sampler = sampler_control(n_draws = 300, n_inner = 10, proposal = "report", quiet = TRUE)),
    classes = "wavevalid_warning_mixing")
  expect_lt(max(rep_fit$acceptance$inputs), min(fit$acceptance$inputs) / 5)
})

test_that("w^b and w^M draws follow eq. 16-17 at fixed inputs", {
  withr::local_seed(3)
  gp <- grid_problem()
  iu1 <- iu_map("u1", "calibration", 0.3, 0.3000001)
  fit <- calibrate(gp$pb$emulators, gp$field, iu1, chains = 1, seed = 2,
                   bias = bias_control(sigma2 = gp$sigma2, fix_tau2 = 0.2),
                   sampler = sampler_control(n_draws = 4000, n_inner = 1, quiet = TRUE))
  pr <- gasp_bank_predict_cpp(gp$pb$emulators$banks$site1, matrix(0.3, 1))
  S <- drop(pr$var) + gp$sigma2 / gp$R
  mb <- 0.2 / (S + 0.2) * (gp$wbar - drop(pr$mean))
  vb <- 0.2 * S / (S + 0.2)
  expect_equal(unname(colMeans(fit$wb$site1)), mb, tolerance = 4 * sqrt(max(vb) / 4000) / max(abs(mb)))
  expect_equal(unname(apply(fit$wb$site1, 2, stats::var)), vb, tolerance = 0.1)
  # w^M: mean V/S (wbar - w^b) + (sigma2/R)/S m; with V ~ 0 it is m
  expect_equal(unname(colMeans(fit$wM$site1)), drop(pr$mean), tolerance = 1e-3)
})

test_that("same seed gives identical draws, sequentially and on two workers", {
  # short chains: the mixing warning is expected and beside the point here
  calibrate <- function(...) suppressWarnings(wavevalid::calibrate(...), classes = "wavevalid_warning_mixing")
  ex <- example_problem()
  f1 <- calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 9,
                  sampler = sampler_control(n_draws = 50, n_inner = 5, quiet = TRUE))
  f2 <- calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 9,
                  sampler = sampler_control(n_draws = 50, n_inner = 5, quiet = TRUE))
  f3 <- calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 10,
                  sampler = sampler_control(n_draws = 50, n_inner = 5, quiet = TRUE))
  expect_identical(as.matrix(f1$draws), as.matrix(f2$draws))
  expect_identical(f1$wb, f2$wb)
  expect_false(identical(as.matrix(f1$draws), as.matrix(f3$draws)))
  expect_false(identical(f1$draws[[1]][, "u1"], f1$draws[[2]][, "u1"]))
  # the emulator predictions shared among threads give the same chains (two
  # threads even when the machine has no second core free)
  withr::local_options(wavevalid.free_cores = 2L)
  f5 <- calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 9,
                  sampler = sampler_control(n_draws = 50, n_inner = 5, quiet = TRUE, threads = 2))
  expect_identical(as.matrix(f1$draws), as.matrix(f5$draws))
  expect_identical(f1$wM, f5$wM)
  withr::local_seed(1)
  g1 <- calibrate(ex$emulators, ex$field, ex$iu, chains = 1,
                  sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE))
  withr::local_seed(1)
  g2 <- calibrate(ex$emulators, ex$field, ex$iu, chains = 1,
                  sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE))
  expect_identical(g1$seed, g2$seed)
  expect_identical(as.matrix(g1$draws), as.matrix(g2$draws))

  skip_on_cran()
  skip_if_not_installed("future")
  skip_if(length(find.package("wavevalid", lib.loc = .libPaths(), quiet = TRUE)) == 0L)
  skip_if(isNamespaceLoaded("pkgload") && pkgload::is_dev_package("wavevalid"))
  future::plan(future::multisession, workers = 2)
  on.exit(future::plan(future::sequential), add = TRUE)
  f4 <- calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 9,
                  sampler = sampler_control(n_draws = 50, n_inner = 5, quiet = TRUE))
  expect_identical(as.matrix(f1$draws), as.matrix(f4$draws))
})

test_that("bad input gives classed errors", {
  ex <- example_problem()
  em <- ex$emulators
  f <- ex$field
  bad_grid <- new_wv_field(seq(0, 2, length.out = 32), f$curves)
  expect_error(calibrate(em, bad_grid, ex$iu, sampler = sampler_control(quiet = TRUE)), class = "wavevalid_error_input")
  one <- new_wv_field(f$t, list(site1 = f$curves$site1[1, , drop = FALSE]))
  expect_error(calibrate(em, one, ex$iu, bias = bias_control(sigma2 = c(1e-3, -1)),
                         sampler = sampler_control(quiet = TRUE)), class = "wavevalid_error_input")
  expect_s3_class(calibrate(em, one, ex$iu, chains = 1, seed = 1, bias = bias_control(sigma2 = 1e-3),
                            sampler = sampler_control(n_draws = 5, n_inner = 2, quiet = TRUE)), "wv_fit")
  iu_short <- iu_map("u1", "calibration", 0, 1)
  expect_error(calibrate(em, f, iu_short, sampler = sampler_control(quiet = TRUE)), class = "wavevalid_error_input")
  expect_error(calibrate(em, f, ex$iu, sampler = sampler_control(n_draws = 0, quiet = TRUE)), class = "wavevalid_error_input")
  expect_error(calibrate(em, f, ex$iu, sampler = sampler_control(n_draws = -5, quiet = TRUE)), class = "wavevalid_error_input")
  expect_error(calibrate(em, f, ex$iu, chains = 1.5, sampler = sampler_control(quiet = TRUE)), class = "wavevalid_error_input")
  expect_error(calibrate(em, f, ex$iu, sampler = sampler_control(threads = 0, quiet = TRUE)), class = "wavevalid_error_input")
  # never more threads than free cores
  free <- free_cores()
  expect_true(is.integer(free) && free >= 1L && free <= max(1L, parallel::detectCores(), na.rm = TRUE))
  expect_identical(withr::with_options(list(wavevalid.free_cores = 3), free_cores()), 3L)
  busy <- busy_cores(4L, wait = 0.05)
  expect_true(busy >= 0 && busy <= 4 && busy == round(busy))
  expect_error(calibrate(em, f, ex$iu, bias = bias_control(fix_tau2 = -1),
                         sampler = sampler_control(quiet = TRUE)), class = "wavevalid_error_input")
  expect_error(calibrate(list(), f, ex$iu), class = "wavevalid_error_input")
  other_site <- new_wv_field(f$t, list(rear = f$curves$site1))
  expect_error(calibrate(em, other_site, ex$iu, sampler = sampler_control(quiet = TRUE)), class = "wavevalid_error_input")
})

test_that("a fit has the documented layout, mcmc.list and print", {
  ex <- example_problem()
  fit <- calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 3,
                   sampler = sampler_control(n_draws = 100, n_inner = 50, quiet = TRUE))
  ml <- coda::as.mcmc.list(fit)
  expect_s3_class(ml, "mcmc.list")
  expect_equal(colnames(ml[[1]])[1:2], c("u1", "x1"))
  # one bias variance per level, the coarsest levels pooled (bias_control(pool_levels = "coarse"))
  expect_true(all(grepl("^tau2\\[site1:[0-9]+(-[0-9]+)?\\]$", colnames(ml[[1]])[-(1:2)])))
  expect_identical(colnames(ml[[1]])[3], sprintf("tau2[site1:0-%d]", max(fit$settings$pool_levels)))
  expect_equal(dim(fit$wb$site1), c(200L, 16L))
  expect_equal(fit$chain, rep(1:2, each = 100))
  expect_named(fit$rhat, c("u1", "x1"))
  expect_true(all(fit$acceptance$inputs > 0 & fit$acceptance$inputs < 1))
  # variation inputs are reported in their own units around x_nom
  X <- as.matrix(ml)
  expect_true(all(X[, "x1"] >= 0 & X[, "x1"] <= 1))
  # coef(): the posterior means of the inputs over both chains, in their units
  expect_equal(coef(fit), colMeans(X[, c("u1", "x1")]))
  expect_error(coef(fit, "median"), class = "wavevalid_error_input")
  # the chains' time and the slowest input's effective draws per second
  expect_gt(fit$sampling_seconds, 0)
  ess <- fit$ess[fit$inputs]
  speed <- min(ess) / fit$sampling_seconds
  line <- grep("^Sampling took", capture.output(print(fit)), value = TRUE)
  expect_length(line, 1L)
  said <- as.numeric(sub(".*: ([0-9.e+]+) effective draws per second.*", "\\1", line))
  expect_equal(said, speed, tolerance = 0.01)
  expect_match(line, sprintf("(%s, ESS %d)", names(which.min(ess)), round(min(ess))), fixed = TRUE)
  no_time <- function(s) sub("^Sampling took .*", "Sampling took <time>", s)
  expect_snapshot(print(fit), transform = no_time)
  expect_snapshot(print(summary(fit)))
  # the inputs: a histogram of each input's draws (30 bins, all draws) and its prior's density, one panel each
  X <- as.matrix(fit$draws)
  pin <- plot_drawn(autoplot(fit, "inputs"))
  expect_identical(pin$geoms, c("GeomBar", "GeomLine"))
  expect_identical(pin$panels, length(fit$inputs))
  expect_identical(nrow(pin$data[[1]]), 30L * length(fit$inputs))
  expect_equal(sum(pin$data[[1]]$count), length(X[, fit$inputs]))
  expect_identical(nrow(pin$data[[2]]), 201L * length(fit$inputs))
  expect_identical(pin$labels$title, "Posterior draws of each input with its prior")
  # the trace: every saved draw of every chain, one line per chain in each input's panel
  ptr <- plot_drawn(autoplot(fit, "trace"))
  expect_identical(ptr$geoms, "GeomLine")
  expect_identical(ptr$panels, length(fit$inputs))
  expect_identical(nrow(ptr$data[[1]]), length(X[, fit$inputs]))
  expect_identical(length(unique(ptr$data[[1]]$colour)), length(fit$draws))
  expect_identical(ptr$labels$x, "saved draw")
})

test_that("an input piled at its bound is flagged with a classed warning", {
  ex <- example_problem()
  f <- ex$field
  # field beyond the model at x1 = 1 and no room for bias: x1 piles at its upper bound
  t <- f$t
  f$curves$site1 <- f$curves$site1 + 0.3 * sin(2 * pi * matrix(t, 4, 32, byrow = TRUE))
  expect_warning(fit <- calibrate(ex$emulators, f, ex$iu, chains = 1, seed = 4,
                                  bias = bias_control(fix_tau2 = 1e-4),
                                  sampler = sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE)),
                 class = "wavevalid_warning_boundary")
  expect_true("x1" %in% fit$flags$boundary$input)
  # explain_bias warns that candidates simulated at these inputs may mislead
  ex <- explain_bias(fit, list(wave = sin(2 * pi * t)), seed = 1)
  expect_identical(attr(ex, "boundary"), unique(fit$flags$boundary$input))
  expect_output(print(ex), "x1.*piles up at a bound")
})

test_that("validate() runs the whole path", {
  skip_if_not(exists("fit_emulators", envir = asNamespace("wavevalid"), inherits = FALSE))
  skip_if_not(exists("wavelet_basis", envir = asNamespace("wavevalid"), inherits = FALSE))
  skip_on_cran()
  ex <- example_problem()
  runs <- model_runs(as.data.frame(ex$emulators$design),
                     ex$emulators$banks$site1$y %*% t(ex$emulators$basis$Psi), ex$field$t, site = "site1")
  fit <- validate(runs, ex$field, ex$iu, chains = 1, seed = 1,
                  sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE))
  expect_s3_class(fit, "wv_fit")
})

test_that("registration_variance adds the landmark spread of the runs to the variance of the field mean", {
  ex <- example_problem()
  t <- ex$field$t
  d <- as.data.frame(ex$emulators$design)
  # runs whose dip after the peak moves with u1
  event <- function(u) 1.3 * sin(2 * pi * t) + 0.6 * exp(-((t - 0.6 - 0.04 * (u - 0.5)) / 0.08)^2)
  runs <- model_runs(d, t(vapply(d$u1, event, numeric(length(t)))), t, site = "site1")
  win <- list(c(0.45, 0.95))
  field <- register_curves(ex$field, runs, win, refine = TRUE)
  spread <- attr(field$warps, "landmark_sd")
  expect_named(spread, c("site", "window", "feature", "t_after", "sd"))
  lm <- vapply(seq_len(nrow(d)), function(k) {
    curve_landmarks(runs$curves$site1[k, ], t, win, c("min", "max"), refine = TRUE)$t
  }, numeric(2))
  expect_equal(spread$sd, apply(lm, 1, stats::sd))
  expect_gt(max(spread$sd), 0)
  r <- registration_extra_variance(field, ex$emulators$basis)$site1
  expect_true(all(r >= 0) && any(r > 0))
  # the variance is that of the first-order effect of the landmarks' errors:
  # each landmark's hat times the slope of the field mean, with the landmark's spread
  cols <- registration_landmark_columns(field, "site1")
  expect_equal(cols$sd, spread$sd[spread$sd > 0])
  expect_equal(dim(cols$H$site1), c(length(t), length(cols$sd)))
  G <- crossprod(ex$emulators$basis$Psi, cols$H$site1)
  expect_equal(r, drop(G^2 %*% cols$sd^2))
  # a coefficient whose support lies outside the hat of the moving landmark gets nothing
  after <- sort(unique(warp_knots(field$warps, 1, "site1")$after))
  hat <- range(after[which.min(abs(after - spread$t_after[spread$sd > 0])) + c(-1, 1)])
  Psi <- ex$emulators$basis$Psi
  outside <- colSums(abs(Psi[t > hat[1] & t < hat[2], , drop = FALSE])) == 0
  expect_true(any(outside))
  expect_true(all(r[outside] == 0))
  # the sampler takes r as variance of the field mean: the same chain as with
  # field variances sigma2 + R r (w^b and w^M too)
  W <- field$curves$site1 %*% Psi
  R <- nrow(W)
  s2 <- colSums(sweep(W, 2, colMeans(W))^2) / (R - 1)
  run <- function(...) calibrate(ex$emulators, field, ex$iu, chains = 1, seed = 3, bias = bias_control(...),
                                 sampler = sampler_control(n_draws = 40, n_inner = 10, quiet = TRUE))
  a <- run(sigma2 = s2, registration_variance = TRUE)
  b <- run(sigma2 = s2 + R * r)
  expect_identical(as.matrix(a$draws), as.matrix(b$draws))
  expect_identical(a$wb, b$wb)
  expect_identical(a$wM, b$wM)
  expect_equal(a$registration_var, list(site1 = r))
  expect_false(identical(as.matrix(run(sigma2 = s2)$draws), as.matrix(a$draws)))
  expect_null(run(sigma2 = s2)$registration_var)
  expect_output(print(a), "spread of the reference's landmarks over the model runs added to the variance of the field mean, site1 [0-9]+% of it")
  # without a measure of the registration's error the print says nothing was added for it
  expect_output(print(b), "Registration: nothing added to the variance of the field mean")
  # the tie to model runs is needed
  expect_error(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1,
                         bias = bias_control(registration_variance = TRUE),
                         sampler = sampler_control(n_draws = 5, n_inner = 2, quiet = TRUE)), class = "wavevalid_error_input")
  to_curve <- register_curves(ex$field, list(site1 = colMeans(runs$curves$site1)), win, refine = TRUE)
  expect_null(attr(to_curve$warps, "landmark_sd"))
  expect_error(calibrate(ex$emulators, to_curve, ex$iu, chains = 1, seed = 1,
                         bias = bias_control(registration_variance = TRUE),
                         sampler = sampler_control(n_draws = 5, n_inner = 2, quiet = TRUE)), class = "wavevalid_error_input")
  expect_error(calibrate(ex$emulators, field, ex$iu, chains = 1, seed = 1,
                         bias = bias_control(registration_variance = NA),
                         sampler = sampler_control(n_draws = 5, n_inner = 2, quiet = TRUE)), class = "wavevalid_error_input")
})

test_that("n_search sets the search for each chain's start", {
  withr::local_seed(7)
  pb <- narrow_problem()
  run <- function(n_search) {
    calibrate(pb$emulators, pb$field, pb$iu, chains = 2, seed = 3,
              sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 10, n_search = n_search, quiet = TRUE))
  }
  # no search: the burn-in starts at the nominals
  none <- suppressWarnings(run(0))
  expect_equal(unname(none$start), matrix(0.5, 2, 2))
  expect_identical(none$settings$n_search, 0)
  # a wide search starts next to the narrow posterior around the truth
  wide <- suppressWarnings(run(2000))
  gap <- sqrt(rowSums(sweep(wide$start, 2, pb$truth)^2))
  expect_true(all(gap < 0.05), label = paste(signif(gap, 3), collapse = ", "))
  expect_error(run(-1), class = "wavevalid_error_input")
  expect_error(run(2.5), class = "wavevalid_error_input")
})
