# A small problem: K runs of p inputs, curves on 64 points, and a wv_basis
# built by hand (scaling coefficient and the first detail levels).
hand_basis <- function(t, index) {
  b <- basis_from_index(t, index)
  b$sites <- "site1"
  b
}

small_problem <- function(K = 20, p = 3, n_coef = 8) {
  t <- seq(0, 1, length.out = 64)
  design <- vapply(seq_len(p), function(j) (sample.int(K) - stats::runif(K)) / K, numeric(K))
  colnames(design) <- paste0("x", seq_len(p))
  curves <- t(apply(design, 1, function(z) {
    sin(2 * pi * t * (1 + 0.5 * z[1])) + z[2]^2 * t + 0.3 * cos(3 * z[3]) * exp(-10 * (t - 0.5)^2)
  }))
  runs <- model_runs(as.data.frame(design), curves, t, site = "site1")
  list(runs = runs, basis = hand_basis(t, seq_len(n_coef)))
}

test_that("the analytic gradient matches finite differences", {
  withr::local_seed(1)
  K <- 25
  p <- 3
  X <- matrix(stats::runif(K * p), K, p)
  y <- sin(3 * X[, 1]) + X[, 2]^2 + 0.2 * X[, 3]
  for (r in 1:4) {
    th <- c(stats::runif(p, -2, 2), stats::runif(p, 0.05, 0.95))
    g <- gasp_loglik_cpp(X, y, th, 0)$gradient
    fd <- vapply(seq_along(th), function(j) {
      h <- 1e-6
      a <- th
      b <- th
      a[j] <- a[j] + h
      b[j] <- b[j] - h
      (gasp_loglik_cpp(X, y, a, 0)$loglik - gasp_loglik_cpp(X, y, b, 0)$loglik) / (2 * h)
    }, numeric(1))
    expect_equal(g, fd, tolerance = 1e-5)
  }
})

test_that("the gradient is right at alpha on its bounds (the exact 0 and 1 shortcuts)", {
  withr::local_seed(11)
  K <- 20
  p <- 2
  X <- matrix(stats::runif(K * p), K, p)
  y <- sin(3 * X[, 1]) + X[, 2]
  th <- c(-0.5, 0.3, 0, 1)
  # the shortcut values are the limits of the general formula
  inner <- c(-0.5, 0.3, 1e-9, 1 - 1e-9)
  expect_equal(gasp_loglik_cpp(X, y, th, 0)$loglik, gasp_loglik_cpp(X, y, inner, 0)$loglik, tolerance = 1e-8)
  g <- gasp_loglik_cpp(X, y, th, 0)$gradient
  h <- 1e-6
  fd <- vapply(seq_along(th), function(j) {
    a <- th
    a[j] <- a[j] + if (j == 4) -h else h  # one-sided, into the box
    (gasp_loglik_cpp(X, y, a, 0)$loglik - gasp_loglik_cpp(X, y, th, 0)$loglik) / (a[j] - th[j])
  }, numeric(1))
  expect_equal(g, fd, tolerance = 1e-4)
})

test_that("the profile log-likelihood equals DiceKriging's at the same parameters", {
  withr::local_seed(2)
  K <- 20
  p <- 2
  X <- matrix(stats::runif(K * p), K, p)
  y <- cos(4 * X[, 1]) * X[, 2]
  beta <- c(0.7, 2.5)
  alpha <- c(0.3, 0.8)
  ll <- gasp_loglik_cpp(X, y, c(log(beta), alpha), 0)
  pw <- 2 - alpha
  theta <- beta^(-1 / pw)
  m <- DiceKriging::km(~1, design = data.frame(X), response = y, covtype = "powexp",
                       coef.cov = c(theta, pw), control = list(trace = FALSE))
  expect_equal(ll$loglik, DiceKriging::logLikFun(c(theta, pw), m), tolerance = 1e-8)
})

test_that("the fit maximises the likelihood within the box", {
  withr::local_seed(3)
  K <- 25
  X <- matrix(stats::runif(K * 2), K, 2)
  y <- sin(5 * X[, 1]) + 0.5 * X[, 2]
  f <- gasp_fit_cpp(X, cbind(y), 1L, list(n_local = 4L))
  th <- c(log(f$beta), f$alpha)
  expect_equal(f$loglik, gasp_loglik_cpp(X, y, th, f$nugget)$loglik)
  for (r in 1:20) {
    other <- c(stats::runif(2, -3, 4), stats::runif(2))
    expect_gte(f$loglik, gasp_loglik_cpp(X, y, other, f$nugget)$loglik - 1e-6)
  }
})

test_that("the optimiser settings, warm starts and control checks behave", {
  withr::local_seed(12)
  K <- 30
  X <- matrix(stats::runif(K * 3), K, 3)
  Y <- sapply(1:6, function(i) {
    sin((2 + i / 3) * X[, 1]) + 0.5 * X[, 2]^2 + 0.1 * i * X[, 3] + 0.3 * abs(X[, 2] - 0.5) +
      0.2 * sin(9 * X[, 3])
  })
  one <- gasp_fit_cpp(X, Y, rep(1L, 6), list())
  alone <- gasp_fit_cpp(X, Y, 1:6, list())  # no warm starts
  plain <- gasp_fit_cpp(X, Y, rep(1L, 6), list(precondition = 0L))
  many <- gasp_fit_cpp(X, Y, rep(1L, 6), list(n_local = 4L))
  # more local searches from the same screened points never lose, beyond the
  # optimiser's stopping rule (a change of the objective below ftol = 1e-8
  # times |loglik|): the later coefficients' warm starts differ between the two
  expect_true(all(many$loglik >= one$loglik - 1e-8 * abs(one$loglik)))
  for (f in list(one, alone, plain)) {
    expect_true(all(f$converged))
    expect_true(all(f$nugget == 0))
  }
  # the reported log-likelihood is that of the reported parameters
  for (i in 1:6) {
    th <- c(log(one$beta[i, ]), one$alpha[i, ])
    expect_equal(one$loglik[i], gasp_loglik_cpp(X, Y[, i], th, one$nugget[i])$loglik)
  }
  # and the fit is deterministic
  expect_identical(gasp_fit_cpp(X, Y, rep(1L, 6), list()), one)
  expect_error(gasp_fit_cpp(X, Y, rep(1L, 6), list(n_local = 0L)), "control")
  expect_error(gasp_fit_cpp(X, Y, 1L, list()), "group")
})

test_that("the predictor interpolates the design runs", {
  withr::local_seed(4)
  pr <- small_problem()
  em <- fit_emulators(pr$runs, pr$basis)
  expect_s3_class(em, "wv_emulators")
  expect_true(all(em$params$nugget == 0))
  out <- predict(em, pr$runs$design, site = "site1")
  y <- pr$runs$curves$site1 %*% pr$basis$Psi
  expect_equal(unname(out$mean), unname(y), tolerance = 1e-6)
  expect_lt(max(out$var), 1e-8 * max(1 / em$params$lambda))
  # away from the design, the variance is positive and below 1 / lambda
  far <- predict(em, data.frame(x1 = 0.51, x2 = 0.49, x3 = 0.5), site = "site1")
  expect_true(all(far$var > 0 & far$var <= 1 / em$params$lambda + 1e-12))
  expect_equal(names(em$params)[1:7], c("site", "index", "level", "mu", "lambda", "nugget", "loglik"))
  expect_true(all(c(paste0("beta_", em$inputs), paste0("alpha_", em$inputs)) %in% names(em$params)))
})

test_that("the eq. 26 update equals the bank rebuilt on the augmented design", {
  withr::local_seed(5)
  pr <- small_problem()
  em <- fit_emulators(pr$runs, pr$basis)
  z <- c(x1 = 0.33, x2 = 0.71, x3 = 0.12)
  w <- predict(em, z, site = "site1")$mean[1, ] + stats::rnorm(8, sd = 0.01)
  aug <- augment_emulators(em, z, w)
  b <- em$banks$site1
  Xa <- rbind(b$X, (z - b$lower) / b$width)
  Ya <- rbind(b$y, w)
  ref <- gasp_finalize_cpp(Xa, Ya, b$beta, b$alpha, b$nugget)
  rebuilt <- b
  rebuilt$X <- Xa
  rebuilt$weights <- Ya - matrix(b$mu, nrow(Ya), ncol(Ya), byrow = TRUE)
  for (i in seq_along(b$mu)) {
    L <- bank_factor(ref, i)
    rebuilt$weights[, i] <- backsolve(t(L), forwardsolve(L, Ya[, i] - b$mu[i]))
  }
  rebuilt$chol <- ref$chol
  rebuilt$chol_of <- ref$chol_of
  factors <- function(x) sapply(seq_along(b$mu), function(i) bank_factor(x, i))
  expect_equal(factors(aug$banks$site1), factors(ref), tolerance = 1e-10)
  expect_equal(unname(aug$banks$site1$weights), unname(rebuilt$weights), tolerance = 1e-8)
  Znew <- matrix(stats::runif(15), 5, 3, dimnames = list(NULL, c("x1", "x2", "x3")))
  p1 <- gasp_bank_predict_cpp(aug$banks$site1, Znew)
  p2 <- gasp_bank_predict_cpp(rebuilt, Znew)
  expect_equal(p1$mean, p2$mean, tolerance = 1e-8)
  expect_equal(p1$var, p2$var, tolerance = 1e-8)
  # the augmented predictor interpolates the new point
  pz <- predict(aug, z, site = "site1")
  expect_equal(unname(pz$mean[1, ]), unname(w), tolerance = 1e-6)
  # a point short of an input is refused, naming the argument it came in
  err <- expect_error(augment_emulators(em, z[1:2], w), class = "wavevalid_error_input")
  expect_match(conditionMessage(err), "`z`")
})

test_that("the two engines agree on predictions of a smooth function", {
  withr::local_seed(6)
  pr <- small_problem(K = 25, n_coef = 4)
  g <- fit_emulators(pr$runs, pr$basis, engine = "gasp")
  d <- fit_emulators(pr$runs, pr$basis, engine = "dicekriging", seed = 1)
  expect_identical(d$engine, "dicekriging")
  Z <- matrix(stats::runif(60, 0.1, 0.9), 20, 3, dimnames = list(NULL, c("x1", "x2", "x3")))
  pg <- predict(g, Z, site = "site1")$mean
  pd <- predict(d, Z, site = "site1")$mean
  y <- pr$runs$curves$site1 %*% pr$basis$Psi
  span <- apply(y, 2, function(v) diff(range(v)))
  expect_true(all(sweep(abs(pg - pd), 2, span, "/") < 0.05))
  # the gasp engine's likelihood is at least DiceKriging's
  expect_true(all(g$params$loglik >= d$params$loglik - 0.1))
})

test_that("closed-form LOO residuals equal brute-force leave-one-out", {
  withr::local_seed(7)
  pr <- small_problem(K = 15, n_coef = 3)
  em <- fit_emulators(pr$runs, pr$basis)
  loo <- loo_residuals(em)
  b <- em$banks$site1
  for (i in seq_along(b$mu)) {
    R <- tcrossprod(bank_factor(b, i))
    for (k in c(1, 7, 15)) {
      Rk <- R[-k, -k]
      r <- R[k, -k]
      m <- b$mu[i] + sum(r * solve(Rk, b$y[-k, i] - b$mu[i]))
      v <- (R[k, k] - sum(r * solve(Rk, r))) / b$lambda[i]
      row <- loo[loo$index == em$params$index[i] & loo$run == k, ]
      expect_equal(row$predicted, unname(m), tolerance = 1e-7)
      expect_equal(row$sd, sqrt(v), tolerance = 1e-7)
      expect_equal(row$residual, unname((b$y[k, i] - m) / sqrt(v)), tolerance = 1e-6)
    }
  }
})

test_that("the fit does not depend on the future plan", {
  skip_on_cran()
  skip_if_not_installed("future")
  withr::local_seed(8)
  pr <- small_problem(K = 15, n_coef = 6)
  withr::local_options(wavevalid.quiet = TRUE)
  seq_fit <- fit_emulators(pr$runs, pr$basis, chunk_size = 2)
  old <- future::plan(future::multisession, workers = 2)
  withr::defer(future::plan(old))
  par_fit <- fit_emulators(pr$runs, pr$basis, chunk_size = 2)
  expect_identical(par_fit$params, seq_fit$params)
  expect_identical(par_fit$banks, seq_fit$banks)
})

test_that("bad inputs give classed errors or warnings", {
  withr::local_seed(9)
  withr::local_options(wavevalid.quiet = TRUE)
  pr <- small_problem(K = 12, n_coef = 4)
  # duplicated design rows
  dup <- pr$runs
  dup$design[5, ] <- dup$design[2, ]
  expect_error(fit_emulators(dup, pr$basis), class = "wavevalid_error_input")
  expect_error(fit_emulators(dup, pr$basis), "2 and 5")
  # too few runs for the dimension
  few <- pr$runs
  few$design <- few$design[1:4, ]
  few$curves$site1 <- few$curves$site1[1:4, ]
  expect_error(fit_emulators(few, pr$basis), class = "wavevalid_error_input")
  # non-finite values
  nf <- pr$runs
  nf$curves$site1[3, 10] <- NA
  expect_error(fit_emulators(nf, pr$basis), class = "wavevalid_error_input")
  # grid mismatch
  other <- hand_basis(seq(0, 1, length.out = 128), 1:4)
  expect_error(fit_emulators(pr$runs, other), class = "wavevalid_error_input")
  expect_error(fit_emulators(pr$runs, list()), class = "wavevalid_error_input")
  # a constant coefficient gets a flat emulator with a warning
  flat <- pr$runs
  flat$curves$site1 <- flat$curves$site1 - (flat$curves$site1 %*% pr$basis$Psi[, 2]) %*% t(pr$basis$Psi[, 2])
  expect_warning(em <- fit_emulators(flat, pr$basis), class = "wavevalid_warning_flat_coefficient")
  expect_equal(unname(unlist(em$params[2, paste0("beta_", em$inputs)])), c(0, 0, 0))
  out <- predict(em, data.frame(x1 = 0.3, x2 = 0.3, x3 = 0.3), site = "site1")
  expect_equal(unname(out$mean[1, 2]), em$params$mu[2])
  expect_lt(out$var[1, 2], 1e-12)
  expect_error(predict(em, data.frame(x1 = 1)), class = "wavevalid_error_input")
})

test_that("print, summary and plots work", {
  withr::local_seed(10)
  withr::local_options(wavevalid.quiet = TRUE)
  pr <- small_problem(K = 12, n_coef = 4)
  em <- fit_emulators(pr$runs, pr$basis)
  expect_invisible(print(em))
  s <- summary(em)
  expect_s3_class(s, "summary_wv_emulators")
  expect_equal(sum(s$by_level$n), 4)
  # the parameters: a point per coefficient and input, at its beta (log scale) and alpha
  pp <- plot_drawn(autoplot(em))
  expect_identical(pp$geoms, "GeomPoint")
  expect_identical(pp$panels, length(em$inputs))
  expect_identical(nrow(pp$data[[1]]), nrow(em$params) * length(em$inputs))
  beta <- unlist(lapply(em$inputs, function(v) em$params[[paste0("beta_", v)]]))
  expect_equal(sort(pp$data[[1]]$x), sort(log10(pmax(beta, 1e-6))))
  expect_identical(pp$labels$title, "GASP correlation parameters by input")
  # the leave-one-out residuals: the +-2 lines and a point per finite residual
  loo <- loo_residuals(em)
  pl <- plot_drawn(autoplot(em, type = "loo"))
  expect_identical(pl$geoms, c("GeomHline", "GeomPoint"))
  expect_equal(sort(pl$data[[1]]$yintercept), c(-2, 2))
  expect_identical(nrow(pl$data[[2]]), sum(is.finite(loo$residual)))
  expect_equal(sort(pl$data[[2]]$y), sort(loo$residual[is.finite(loo$residual)]))
  expect_identical(pl$labels$title, "Leave-one-out residuals of the emulators")
  # the summaries by level, summed from the banks, are those of the long table
  r <- loo$residual[is.finite(loo$residual)]
  lv <- loo$level[is.finite(loo$residual)]
  lc <- loo_check(em)
  expect_equal(lc$mean_square, as.vector(tapply(r^2, lv, mean)))
  expect_equal(lc$cover90, as.vector(tapply(abs(r) <= stats::qnorm(0.95), lv, mean)))
  expect_equal(s$by_level$loo_rms, sqrt(as.vector(tapply(r^2, lv, mean))))
})

test_that("summary() reports the studentised errors of the emulators at held-out runs", {
  t <- seq(0, 1, length.out = 64)
  f <- function(d) t(apply(d, 1, function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t^2))
  withr::local_seed(3)
  design <- data.frame(a = (sample(20) - runif(20)) / 20, b = (sample(20) - runif(20)) / 20)
  runs <- model_runs(design, f(design), t)
  em <- suppressWarnings(fit_emulators(runs, wavelet_basis(runs)))
  new_design <- data.frame(a = runif(40, 0.1, 0.9), b = runif(40, 0.1, 0.9))
  new_runs <- model_runs(new_design, f(new_design), t)
  s <- summary(em, new_runs = new_runs)
  expect_true(all(c("heldout_rms", "heldout_beyond_3") %in% names(s$by_level)))
  expect_identical(s$n_new, 40L)
  held <- heldout_residuals(em, new_runs)
  rms <- sqrt(mean(held$residual^2, na.rm = TRUE))
  # the errors scale with the predictive sd: dividing the variances by 10
  # multiplies the studentised errors by sqrt(10)
  em_small <- em
  em_small$banks$site1$lambda <- em$banks$site1$lambda * 10
  held_small <- heldout_residuals(em_small, new_runs)
  expect_equal(sqrt(mean(held_small$residual^2, na.rm = TRUE)), sqrt(10) * rms, tolerance = 1e-8)
  # held-out errors agree with predict() and wavelet_coef()
  pr <- predict(em, new_design[1:2, ], site = "site1")
  w <- wavelet_coef(em$basis, new_runs)$site1[1:2, ]
  first <- held[held$run %in% 1:2, ]
  ok <- !is.na(first$residual)
  expect_gt(sum(ok), 10)
  expect_equal(first$residual[ok], as.vector((w - pr$mean) / sqrt(pr$var))[ok])
  msgs <- testthat::capture_messages(utils::capture.output(print(s)))
  expect_match(paste(msgs, collapse = ""), "held-out")
  expect_error(summary(em, new_runs = new_design), class = "wavevalid_error_input")
  expect_error(summary(em, new_runs = model_runs(data.frame(a = 0.5), f(data.frame(a = 0.5, b = 0.5)), t)),
               class = "wavevalid_error_input")
})

test_that("the wide-vector kernels give Eigen's results to the bit", {
  withr::local_seed(3)
  x <- c(seq(-745, 710, length.out = 100001), stats::runif(1e5, -30, 1), 0, -0, 1e-300, -1e-300, 709.437, -709.5)
  for (K in c(66L, 67L, 5L, 1L)) {
    X <- matrix(stats::runif(K * 9), K, 9)
    res <- vexp_identity_cpp(x, X)
    if (!res$in_use) skip("this build keeps Eigen's own expressions")
    expect_identical(unlist(res[c("exp", "inverse", "gram", "dot", "sub")]),
                     c(exp = 0L, inverse = 0L, gram = 0L, dot = 0L, sub = 0L), label = paste("K =", K))
  }
  # and the exp is the exp: within 2 units in the last place where the result is a normal number
  e <- x[x > -708 & x < 709]
  v <- vexp_identity_cpp(e, matrix(0.5, 2, 1))$values
  expect_true(all(abs(v - exp(e)) <= 2 * .Machine$double.eps * exp(e)))
})

test_that("coefficients that share one correlation predict to the bit what one-coefficient banks predict", {
  withr::local_seed(31)
  X <- cbind(a = stats::runif(12), b = stats::runif(12))
  Y <- sin(3 * X[, 1]) + X[, 2]^2 + matrix(stats::rnorm(12 * 6, 0, 0.3), 12, 6)
  # coefficients 1, 2, 4, 6 share one correlation and 3, 5 another (not next to each other), as the
  # emulators fitted per level do
  shared <- c(1, 1, 2, 1, 2, 1)
  beta <- rbind(c(2, 1), c(6, 0.5))[shared, ]
  alpha <- rbind(c(0.2, 0), c(0, 0.5))[shared, ]
  bank <- make_bank(X, Y, beta, alpha, nugget = 1e-6)
  one <- function(i) {
    b <- bank
    for (f in c("beta", "alpha")) b[[f]] <- b[[f]][i, , drop = FALSE]
    for (f in c("mu", "lambda", "nugget")) b[[f]] <- b[[f]][i]
    for (f in c("weights", "y")) b[[f]] <- b[[f]][, i, drop = FALSE]
    b$chol <- b$chol[, , i, drop = FALSE]
    b
  }
  Z <- cbind(stats::runif(40), stats::runif(40))
  all <- gasp_bank_predict_cpp(bank, Z)
  for (i in seq_along(shared)) {
    own <- gasp_bank_predict_cpp(one(i), Z)
    expect_identical(all$mean[, i], own$mean[, 1], label = sprintf("mean of coefficient %d", i))
    expect_identical(all$var[, i], own$var[, 1], label = sprintf("variance of coefficient %d", i))
  }
})

test_that("a level's coefficients store one Cholesky factor, and predict as with one factor each", {
  withr::local_seed(5)
  pr <- small_problem()
  em <- fit_emulators(pr$runs, pr$basis)
  b <- em$banks$site1
  n <- length(b$mu)
  expect_length(b$chol_of, n)
  m <- dim(b$chol)[3]
  # one factor per distinct (beta, alpha, nugget): per level with "gasp_level"
  hyper <- unique(data.frame(b$beta, b$alpha, b$nugget))
  expect_identical(m, nrow(hyper))
  expect_lt(m, n)
  # the same bank with every coefficient's factor stored on its own
  own <- b
  own$chol <- array(vapply(seq_len(n), function(i) bank_factor(b, i), numeric(nrow(b$X)^2)),
                    c(nrow(b$X), nrow(b$X), n))
  own$chol_of <- NULL
  Z <- matrix(stats::runif(30), 10, 3)
  expect_identical(gasp_bank_predict_cpp(b, Z), gasp_bank_predict_cpp(own, Z))
  # each factor is the Cholesky factor of its coefficients' correlation matrix
  i <- which(b$chol_of == b$chol_of[n])[1]
  Rm <- exp(-as.matrix(Reduce(`+`, lapply(seq_len(ncol(b$X)), function(q) {
    b$beta[i, q] * as.matrix(stats::dist(b$X[, q]))^(2 - b$alpha[i, q])
  }))))
  diag(Rm) <- 1 + b$nugget[i]
  expect_equal(tcrossprod(bank_factor(b, i)), Rm, tolerance = 1e-10, ignore_attr = TRUE)
  # a chol_of out of range is refused
  bad <- b
  bad$chol_of[1] <- m + 1L
  expect_error(gasp_bank_predict_cpp(bad, Z), "chol_of")
})
