# Priors of calibration inputs: normal, log-normal and joint Gaussian.

flyer_iu <- function() {
  fl <- as.matrix(utils::read.table(test_path("fixtures", "flyer-ranges.txt")))
  prior <- list(mean = scan(test_path("fixtures", "flyer-prior-mean.txt"), quiet = TRUE),
                cov = as.matrix(utils::read.table(test_path("fixtures", "flyer-prior-cov.txt"))))
  nm <- c("eos", "theta0", "kappa", "gamma", "y0", "yinf", "s0", "sinf", "pmin", "vs")
  iu <- iu_map(nm, "calibration", fl[, 1], fl[, 2])
  # GPMSA gives -log(gamma): flip the sign of its mean and of its row and column off the diagonal
  m <- prior$mean
  C <- unname(prior$cov)
  m[3] <- -m[3]
  C[3, -3] <- -C[3, -3]
  C[-3, 3] <- -C[-3, 3]
  iu_prior_joint(iu, nm[2:8], m, C, scale = c("identity", "identity", "log", rep("identity", 4)))
}

test_that("explicit uniform priors are the I/U map of before, and its draws are those of before", {
  a <- iu_map(c("u1", "x1"), c("calibration", "variation"), lower = c(0, 0), upper = c(1, 1),
              nominal = c(0.5, 0.5))
  b <- iu_map(c("u1", "x1"), c("calibration", "variation"), lower = c(0, 0), upper = c(1, 1),
              nominal = c(0.5, 0.5), prior = "uniform")
  expect_identical(a, b)
  expect_identical(a$prior, c("uniform", "normal"))
  ex <- example_problem(1)
  ex$iu <- b
  # draws of the package before priors of calibration inputs existed, same seed and settings
  # (one bias variance per level, its prior then)
  old <- readRDS(test_path("fixtures", "uniform-prior-draws.rds"))
  for (p in c("adaptive", "report")) {
    fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 7,
                                      bias = bias_control(pool_levels = NULL),
                                      sampler = sampler_control(n_draws = 30, n_inner = 10, proposal = p, burnin = 300, n_search = 20, quiet = TRUE)))
    expect_identical(as.matrix(fit$draws), old[[p]]$draws)
    expect_identical(fit$wb$site1[, 1:3], old[[p]]$wb)
  }
})

test_that("priors of calibration inputs: defaults, print and classed errors", {
  iu <- iu_map(c("a", "b", "c", "x"), c("calibration", "calibration", "calibration", "variation"),
               lower = c(0, 0.01, 0, 0), upper = c(1, 1, 2, 1), prior = c("normal", "lognormal", "uniform", "normal"))
  expect_equal(iu$prior_mean, c(0.5, 0.505, NA, 0.5))
  expect_equal(iu$prior_sd, c(1 / 6, log(100) / 6, NA, 1 / 6))
  expect_snapshot(print(iu))
  # one value of prior applies to the calibration inputs
  one <- iu_map(c("a", "x"), c("calibration", "variation"), c(0, 0), c(1, 1), prior = "normal", prior_sd = c(0.2, NA))
  expect_identical(one$prior, c("normal", "normal"))
  expect_equal(one$prior_sd, c(0.2, 1 / 6))
  expect_error(iu_map(c("a", "x"), c("calibration", "variation"), c(0, 0), c(1, 1), prior = c("normal", "uniform")),
               class = "wavevalid_error_input")
  expect_error(iu_map("a", "calibration", 0, 1, prior = "cauchy"), class = "wavevalid_error_input")
  expect_error(iu_map("a", "calibration", 0, 1, prior = "lognormal"), class = "wavevalid_error_input")
  expect_error(iu_map("a", "calibration", 1, 2, prior = "lognormal", prior_mean = -1), class = "wavevalid_error_prior")
  expect_error(iu_map("a", "calibration", 0, 1, prior = "normal", prior_sd = 0), class = "wavevalid_error_prior")
  expect_error(iu_map("a", "calibration", 0, 1, prior = "normal", prior_mean = 5, prior_sd = 0.1),
               class = "wavevalid_error_prior")
  expect_snapshot(iu_map("a", "calibration", 0, 1, prior = "normal", prior_mean = 5, prior_sd = 0.1), error = TRUE)
  # iu_add takes priors too and keeps the old inputs' ones
  added <- iu_add(iu, "s", lower = 1, upper = 10, prior = "lognormal", prior_mean = 2, prior_sd = 0.5)
  expect_identical(added[1:4, ]$prior_sd, iu$prior_sd)
  expect_identical(added$prior[5], "lognormal")
})

test_that("iu_prior_joint refuses bad covariances, names and scales with classed errors", {
  iu <- iu_map(c("a", "b", "c", "x"), c("calibration", "calibration", "calibration", "variation"),
               lower = c(0, 0, 0.1, 0), upper = c(1, 1, 1, 1))
  C <- matrix(c(0.04, 0.01, 0.01, 0.04), 2)
  expect_error(iu_prior_joint(iu, c("a", "z"), c(0.5, 0.5), C), class = "wavevalid_error_prior")
  expect_error(iu_prior_joint(iu, c("a", "z"), c(0.5, 0.5), C), class = "wavevalid_error_input")
  expect_error(iu_prior_joint(iu, c("a", "x"), c(0.5, 0.5), C), class = "wavevalid_error_input")
  expect_error(iu_prior_joint(iu, c("a", "b"), c(0.5, 0.5, 0.5), C), class = "wavevalid_error_input")
  expect_error(iu_prior_joint(iu, c("a", "b", "c"), c(0.5, 0.5, 0.5), C), class = "wavevalid_error_input")
  expect_error(iu_prior_joint(iu, c("a", "b"), c(0.5, 0.5), matrix(c(0.04, 0.01, 0.02, 0.04), 2)),
               class = "wavevalid_error_numeric")
  expect_error(iu_prior_joint(iu, c("a", "b"), c(0.5, 0.5), matrix(c(0.04, 0.05, 0.05, 0.04), 2)),
               class = "wavevalid_error_numeric")
  expect_error(iu_prior_joint(iu, c("a", "b"), c(0.5, 0.5), C, scale = "log"), class = "wavevalid_error_input")
  expect_error(iu_prior_joint(iu, c("a", "b"), c(0.5, 0.5), C, scale = "logit"), class = "wavevalid_error_input")
  expect_error(iu_prior_joint(iu, c("a", "b"), c(5, 5), C), class = "wavevalid_error_numeric")
  expect_snapshot(iu_prior_joint(iu, c("a", "b"), c(0.5, 0.5), matrix(c(0.04, 0.05, 0.05, 0.04), 2)), error = TRUE)
  j <- iu_prior_joint(iu, c("a", "b"), c(0.5, 0.5), C)
  expect_error(iu_prior_joint(j, c("b", "c"), c(0.5, 0.5), C), class = "wavevalid_error_input")
  # the joint prior survives iu_add(), row subsetting and saving
  j2 <- iu_add(j, "s", lower = 0, upper = 1)
  expect_identical(attr(j2, "joint"), attr(j, "joint"))
  expect_identical(attr(j2[c(2, 1, 5), ], "joint")[[1]]$names, c("a", "b"))
  f <- withr::local_tempfile(fileext = ".rds")
  saveRDS(j2, f)
  expect_identical(readRDS(f), j2)
  expect_snapshot(print(j))
})

test_that("the sampler's log prior is the densities written out, Jacobians included", {
  withr::local_seed(3)
  iu <- iu_map(c("a", "b", "c", "d", "e", "x"), c(rep("calibration", 5), "variation"),
               lower = c(0, 0.01, -3, 1e-7, 0, 2), upper = c(1, 2, 5, 1e-3, 1, 4),
               prior = c("normal", "lognormal", "uniform", "uniform", "uniform", "normal"),
               prior_mean = c(0.3, 0.2, NA, NA, NA, NA), prior_sd = c(0.2, 0.7, NA, NA, NA, 0.5))
  C <- matrix(c(0.3, 0.2, 0.2, 0.5), 2)
  iu <- iu_prior_joint(iu, c("d", "c"), mean = c(log(2e-5), 1), cov = C, scale = c("log", "identity"))
  pri <- sampler_priors(iu)
  Z <- iu_prior_draws(iu, 50)
  direct <- function(z) {
    y <- c(log(z[["d"]]) - log(2e-5), z[["c"]] - 1)
    stats::dnorm(z[["a"]], 0.3, 0.2, log = TRUE) + stats::dlnorm(z[["b"]], log(0.2), 0.7, log = TRUE) -
      0.5 * drop(t(y) %*% solve(C) %*% y) - log(z[["d"]]) + stats::dnorm(z[["x"]], 3, 0.5, log = TRUE)
  }
  want <- apply(Z, 1, direct)
  got <- input_log_prior_cpp(pri, Z)
  r_side <- iu_log_prior(iu, Z)
  # equal up to one constant (the normalising constants)
  expect_equal(got - got[1], want - want[1], tolerance = 1e-10)
  expect_equal(r_side - r_side[1], want - want[1], tolerance = 1e-10)
  # outside the box: -Inf; debug_break 3: the support alone
  Z[1, "a"] <- 1.5
  expect_identical(input_log_prior_cpp(pri, Z[1:2, ])[1], -Inf)
  expect_identical(unique(input_log_prior_cpp(pri, Z[2:5, ], 3L)), 0)
  # prior draws follow the truncated normal and log-normal
  D <- iu_prior_draws(iu, 20000)
  expect_true(all(D[, "d"] >= 1e-7 & D[, "d"] <= 1e-3))
  ks_a <- stats::ks.test(D[, "a"], function(q) (pnorm(q, 0.3, 0.2) - pnorm(0, 0.3, 0.2)) / diff(pnorm(c(0, 1), 0.3, 0.2)))
  expect_gt(ks_a$p.value, 0.01)
  expect_equal(cor(log(D[, "d"]), D[, "c"]), 0.2 / sqrt(0.15), tolerance = 0.05)
  expect_equal(sum(iu_prior_density(iu, 2, seq(0.01, 2, length.out = 4001))) * (1.99 / 4000), 1,
               tolerance = 2e-3)
})

test_that("the flyer-plate Gaussian prior on seven strength parameters, one of them on the log scale", {
  iu <- flyer_iu()
  expect_identical(iu$prior, c("uniform", rep("joint", 7), "uniform", "uniform"))
  expect_snapshot(print(iu))
  withr::local_seed(5)
  D <- iu_prior_draws(iu, 4000)
  # log(gamma) has mean -11.11 and sd 0.52 before truncation; the box cuts little of it
  expect_equal(mean(log(D[, "gamma"])), -11.11, tolerance = 0.01)
  expect_equal(cor(D[, "theta0"], D[, "yinf"]), -0.87, tolerance = 0.05)
  expect_equal(cor(D[, "kappa"], log(D[, "gamma"])), -0.73, tolerance = 0.05)
  pri <- sampler_priors(iu)
  lp <- input_log_prior_cpp(pri, D[1:20, ])
  expect_true(all(is.finite(lp)))
  expect_equal(lp - lp[1], iu_log_prior(iu, D[1:20, ]) - iu_log_prior(iu, D[1, , drop = FALSE]),
               tolerance = 1e-8)
})

test_that("the sampler draws the flyer-plate prior on the inputs' own scales (1e-7 to 300)", {
  iu <- flyer_iu()
  fl <- as.matrix(utils::read.table(test_path("fixtures", "flyer-ranges.txt")))
  D01 <- as.matrix(utils::read.table(test_path("fixtures", "flyer-design.txt")))
  X <- sweep(sweep(D01, 2, fl[, 2] - fl[, 1], "*"), 2, fl[, 1], "+")
  colnames(X) <- iu$name
  Y <- cbind(rowSums(D01), D01[, 3] - D01[, 4], sin(3 * D01[, 2]), D01[, 5]^2)
  basis <- make_basis(16, 1:4)
  em <- make_emulators(list(site1 = make_bank(X, Y, beta = rep(0.5, 10), alpha = rep(0, 10))), basis, X)
  # data that say nothing: the posterior is the prior
  spec <- calibration_spec(em, field_from_coef(basis, matrix(0, 2, 4)), iu, sigma2 = 1e8)
  out <- calibrate_chain_cpp(spec$sites, spec$priors, list(
    n_groups = nrow(spec$groups), z_init = as.numeric(spec$z_init), tau2_init = rep(0.05, nrow(spec$groups)),
    fix_tau2 = TRUE, n_draws = 4000L, n_inner = 5L, step = 0.1, seed = 3, chain = 1L, adaptive = TRUE,
    burnin = 5000L, n_search = 50L))
  M <- out$inputs
  colnames(M) <- spec$inputs
  withr::local_seed(6)
  P <- iu_prior_draws(spec$prior_iu, 20000)
  expect_equal(mean(log(M[, "gamma"])), mean(log(P[, "gamma"])), tolerance = 0.15 / 11)
  expect_equal(sd(log(M[, "gamma"])), sd(log(P[, "gamma"])), tolerance = 0.2)
  expect_equal(mean(M[, "kappa"]), mean(P[, "kappa"]), tolerance = 0.01 / 0.7)
  expect_equal(cor(M[, "theta0"], M[, "yinf"]), cor(P[, "theta0"], P[, "yinf"]), tolerance = 0.1)
  expect_equal(cor(M[, "kappa"], log(M[, "gamma"])), cor(P[, "kappa"], log(P[, "gamma"])), tolerance = 0.15)
  # without the Jacobian 1 / gamma the draws of log(gamma) would sit about sd^2 = 0.27 higher
  expect_lt(abs(mean(log(M[, "gamma"])) - (-11.11)), 0.15)
})

# SBC for priors of calibration inputs: truth from the prior, weak data (the
# posterior is close to the prior, so a sampler that drops the prior term is
# far off), ranks of the truth among the kept draws.
sbc_prior_pvalues <- function(reps, iu, debug_break = 0L, n_draws = 60L, n_inner = 20L, sd_eps = 3, R = 2,
                              tau2 = 0.05, proposal = "report") {
  s <- sbc_setup(R, sd_eps^2, iu = iu, two_inputs = nrow(iu) == 2L)
  n <- s$n
  spec <- s$spec
  G <- s$G
  bank <- s$bank
  adaptive <- proposal == "adaptive"
  burn <- if (adaptive) 1L else 12L
  L <- n_draws - burn + 1L
  p <- length(spec$inputs)
  ranks <- matrix(NA_integer_, reps, p, dimnames = list(NULL, spec$inputs))
  for (r in seq_len(reps)) {
    z <- iu_prior_draws(spec$prior_iu, 1L)[1, ]
    pr <- gasp_bank_predict_cpp(bank, matrix(z, 1))
    wM <- stats::rnorm(n, pr$mean, sqrt(pr$var))
    wb <- stats::rnorm(n, 0, sqrt(tau2))
    spec$sites$site1$wbar <- wM + wb + stats::rnorm(n, 0, sd_eps / sqrt(R))
    out <- calibrate_chain_cpp(spec$sites, spec$priors, list(
      n_groups = G, z_init = as.numeric(spec$z_init), tau2_init = rep(tau2, G), fix_tau2 = TRUE,
      n_draws = n_draws, n_inner = n_inner, step = 0.5, seed = r, chain = 1L, debug_break = debug_break,
      adaptive = adaptive, burnin = if (adaptive) 300L else 0L, n_search = 20L))
    keep <- burn:n_draws
    ranks[r, ] <- colSums(sweep(out$inputs[keep, , drop = FALSE], 2L, z, "<"))
  }
  sbc_rank_pvalues(ranks, L)
}

normal_prior_iu <- function() {
  iu_map("u1", "calibration", 0, 1, prior = "normal", prior_mean = 0.35, prior_sd = 0.12)
}

joint_prior_iu <- function() {
  iu <- iu_map(c("u1", "x1"), "calibration", lower = c(0, 0.05), upper = c(1, 1))
  iu_prior_joint(iu, c("u1", "x1"), mean = c(0.45, log(0.4)),
                 cov = matrix(c(0.15^2, 0.7 * 0.15 * 0.35, 0.7 * 0.15 * 0.35, 0.35^2), 2),
                 scale = c("identity", "log"))
}

test_that("SBC at a small size: ranks are uniform under a normal and a joint prior, not without the prior term", {
  withr::local_seed(44)
  p_ok <- sbc_prior_pvalues(400, normal_prior_iu())
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  withr::local_seed(44)
  p_broken <- sbc_prior_pvalues(400, normal_prior_iu(), debug_break = 3L)
  expect_lt(p_broken[["u1"]], 0.001)
  withr::local_seed(45)
  p_joint <- sbc_prior_pvalues(300, joint_prior_iu(), n_draws = 49L, n_inner = 10L, proposal = "adaptive")
  expect_true(all(p_joint > 0.01), label = paste(signif(p_joint, 3), collapse = ", "))
  withr::local_seed(45)
  p_joint_broken <- sbc_prior_pvalues(300, joint_prior_iu(), debug_break = 3L, n_draws = 49L, n_inner = 10L,
                                      proposal = "adaptive")
  expect_lt(min(p_joint_broken), 0.001)
})

test_that("SBC under a normal and a joint prior, full size", {
  skip_unless_slow()
  withr::local_seed(46)
  p_ok <- sbc_prior_pvalues(3000, normal_prior_iu())
  expect_true(all(p_ok > 0.01), label = paste(signif(p_ok, 3), collapse = ", "))
  withr::local_seed(47)
  p_joint <- sbc_prior_pvalues(2000, joint_prior_iu(), n_draws = 49L, n_inner = 10L, proposal = "adaptive")
  expect_true(all(p_joint > 0.01), label = paste(signif(p_joint, 3), collapse = ", "))
  withr::local_seed(48)
  p_report <- sbc_prior_pvalues(2000, joint_prior_iu())
  expect_true(all(p_report > 0.01), label = paste(signif(p_report, 3), collapse = ", "))
  withr::local_seed(49)
  p_broken <- sbc_prior_pvalues(1000, joint_prior_iu(), debug_break = 3L)
  expect_lt(min(p_broken), 0.001)
})

test_that("a fit states the prior of each input in print and summary", {
  ex <- example_problem(1)
  ex$iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), c(0, 0), c(1, 1), prior = "normal",
                  prior_mean = c(0.4, NA), prior_sd = c(0.2, NA))
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1,
                                    sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 200, n_search = 10, quiet = TRUE)))
  out <- capture.output(print(fit))
  expect_true(any(grepl("u1 +normal\\(0.4, sd 0.2\\) on \\[0, 1\\]", out)))
  expect_true(any(grepl("x1 +normal\\(0.5, sd 0.1667\\)", out)))
  expect_true(any(grepl("normal\\(0.4, sd 0.2\\)", capture.output(print(summary(fit))))))
})
