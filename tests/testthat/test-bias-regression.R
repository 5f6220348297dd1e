# Synthetic bias draws: n coefficients in 3 levels, the bias is 2 x candidate 1
# plus level-scaled noise, with posterior jitter across draws.
synthetic_bias <- function(H = 60, n = 120, amp = 2, noise = 0.3) {
  lev <- rep(1:3, each = n / 3)
  tau2 <- c(4, 1, 0.25)[lev]
  X <- matrix(rnorm(n * 4), n, 4, dimnames = list(NULL, c("true", "decoy1", "decoy2", "decoy3")))
  X[, "true"] <- X[, "true"] * sqrt(tau2)
  base <- amp * X[, "true"] + rnorm(n, sd = noise * sqrt(tau2))
  Y <- t(replicate(H, base + rnorm(n, sd = 0.1 * sqrt(tau2))))
  W <- matrix(1 / tau2, H, n, byrow = TRUE)
  list(Y = Y, X = X, W = W)
}

test_that("the regression finds the candidate that makes the bias", {
  withr::local_seed(11)
  d <- synthetic_bias()
  res <- bias_regression(d$Y, d$X, d$W, max_size = 2)
  tab <- res$table
  expect_equal(tab$candidate[1], "true")
  expect_gt(tab$inclusion_prob[1], 0.9)
  expect_true(all(tab$inclusion_prob[-1] < 0.5))
  expect_equal(tab$amplitude[1], 2, tolerance = 0.05)
  expect_true(tab$amplitude_lower[1] <= 2 && tab$amplitude_upper[1] >= 1.9)
  expect_gt(tab$share_explained[1], 0.8)
  expect_equal(sum(res$subsets$probability) <= 1 + 1e-12, TRUE)
})

test_that("share_explained is measured against what the candidates could explain", {
  withr::local_seed(11)
  d <- synthetic_bias()
  # a large component of the bias that no candidate resembles (an offset of
  # the first coefficient, as a record-wide level would carry)
  d$Y[, 1] <- d$Y[, 1] + 60
  tab <- bias_regression(d$Y, d$X, d$W, max_size = 2)$table
  expect_equal(tab$candidate[1], "true")
  # of the whole bias the true candidate explains little; of what the
  # candidates together explain, almost all
  expect_lt(tab$share_of_bias[1], 0.5)
  expect_gt(tab$share_explained[1], 0.9)
  expect_true(all(tab$share_explained >= tab$share_of_bias - 1e-12))
  expect_true(all(tab$share_explained <= 1))
})

test_that("with no bias signal no candidate reaches one half", {
  withr::local_seed(12)
  d <- synthetic_bias(amp = 0, noise = 1)
  tab <- bias_regression(d$Y, d$X, d$W, max_size = 3)$table
  expect_true(all(tab$inclusion_prob < 0.5))
})

test_that("identical candidates share their inclusion instead of failing", {
  withr::local_seed(13)
  d <- synthetic_bias()
  X <- cbind(d$X, twin = d$X[, "true"])
  tab <- bias_regression(d$Y, X, d$W, max_size = 2)$table
  p <- stats::setNames(tab$inclusion_prob, tab$candidate)
  expect_equal(unname(p["true"]), unname(p["twin"]), tolerance = 1e-8)
  expect_gt(p["true"] + p["twin"], 0.9)
})

test_that("versions of one effect share its prior and are reported as one effect", {
  withr::local_seed(15)
  d <- synthetic_bias()
  plain <- withr::with_seed(1, bias_regression(d$Y, d$X, d$W, max_size = 2))
  # each candidate its own effect: the same as no grouping
  own <- withr::with_seed(1, bias_regression(d$Y, d$X, d$W, max_size = 2, group = colnames(d$X)))
  expect_equal(own$table, plain$table)
  expect_null(own$versions)
  # a twin given as a second version of the true effect changes nothing: the
  # two versions split the effect's prior mass and have the same likelihood
  X <- cbind(d$X, twin = d$X[, "true"])
  grouped <- bias_regression(d$Y, X, d$W, max_size = 2, group = c(colnames(d$X), "true"))
  p0 <- stats::setNames(plain$table$inclusion_prob, plain$table$candidate)
  p1 <- stats::setNames(grouped$table$inclusion_prob, grouped$table$candidate)
  expect_setequal(names(p1), colnames(d$X))
  expect_equal(p1[names(p0)], p0, tolerance = 1e-10)
  v <- grouped$versions
  expect_equal(sum(v$inclusion_prob[v$effect == "true"]), p1[["true"]], tolerance = 1e-12)
  expect_equal(v$inclusion_prob[v$candidate == "twin"], v$inclusion_prob[v$candidate == "true"], tolerance = 1e-8)
  # a wrong version next to the right one: the effect keeps its inclusion,
  # the right version leads, and no subset holds two versions
  X <- cbind(d$X, wrong = rnorm(nrow(d$X)))
  grouped <- bias_regression(d$Y, X, d$W, max_size = 2, group = c(colnames(d$X), "true"))
  tab <- grouped$table
  expect_equal(tab$candidate[1], "true")
  expect_gt(tab$inclusion_prob[1], 0.9)
  expect_equal(tab$amplitude[1], 2, tolerance = 0.05)
  expect_equal(grouped$lead[["true"]], "true")
  expect_equal(grouped$versions$candidate[1], "true")
  expect_false(any(grepl("true.*wrong|wrong.*true", grouped$subsets$subset)))
})

test_that("the Bayes factor matches the closed form of the g-prior", {
  withr::local_seed(14)
  n <- 50
  x <- rnorm(n)
  y <- 0.5 * x + rnorm(n)
  res <- bias_regression(matrix(y, 1), matrix(x, ncol = 1, dimnames = list(NULL, "x")), matrix(1, 1, n),
                         max_size = 1)
  r2 <- sum(x * y)^2 / sum(x^2) / sum(y^2)
  g <- n
  bf <- exp(-0.5 * log1p(g) - n / 2 * log1p(-g / (1 + g) * r2))
  # equal prior on size 0 and 1
  expect_equal(res$table$inclusion_prob, bf / (1 + bf), tolerance = 1e-10)
})

# Residuals made of one value per cluster of `size` coefficients (plus a
# little independent noise) and candidates of the same shape: each cluster is
# one piece of evidence, not `size`.
clustered_bias <- function(n_cl = 60, size = 4, m = 3, H = 5) {
  cl <- rep(seq_len(n_cl), each = size)
  y <- stats::rnorm(n_cl)[cl] + stats::rnorm(n_cl * size, sd = 0.3)
  X <- vapply(seq_len(m), function(k) stats::rnorm(n_cl)[cl], numeric(n_cl * size))
  colnames(X) <- paste0("decoy", seq_len(m))
  list(Y = t(replicate(H, y + stats::rnorm(length(y), sd = 0.05))), X = X, W = matrix(1, H, length(y)),
       cluster = cl)
}

test_that("tempering keeps the rate of false inclusions when residuals are alike within clusters", {
  withr::local_seed(21)
  top <- t(replicate(60, {
    d <- clustered_bias()
    c(plain = max(bias_regression(d$Y, d$X, d$W)$table$inclusion_prob),
      tempered = max(bias_regression(d$Y, d$X, d$W, cluster = d$cluster)$table$inclusion_prob))
  }))
  # no candidate is in the bias: counting each coefficient as independent
  # evidence makes one reach 0.5 often, the tempered regression seldom
  expect_gt(mean(top[, "plain"] >= 0.5), 0.3)
  expect_lt(mean(top[, "tempered"] >= 0.5), 0.15)
})

test_that("tempering leaves independent residuals alone and still finds a real effect", {
  withr::local_seed(22)
  res <- replicate(60, {
    d <- clustered_bias(n_cl = 240, size = 1)
    out <- bias_regression(d$Y, d$X, d$W, cluster = rep(1:60, each = 4))
    c(top = max(out$table$inclusion_prob), eta = stats::median(out$eta))
  })
  expect_gt(stats::median(res["eta", ]), 0.8)
  expect_lt(mean(res["top", ] >= 0.5), 0.1)
  withr::local_seed(23)
  found <- replicate(30, {
    d <- clustered_bias()
    d$Y <- d$Y + 0.5 * d$X[, 1][col(d$Y)]
    tab <- bias_regression(d$Y, d$X, d$W, cluster = d$cluster)$table
    tab$inclusion_prob[tab$candidate == "decoy1"]
  })
  expect_gt(stats::median(found), 0.9)
})

test_that("duplicating every coefficient leaves the tempered result unchanged", {
  withr::local_seed(24)
  d <- clustered_bias()
  d$Y <- d$Y + 0.2 * d$X[, 2][col(d$Y)]
  dup <- rep(seq_along(d$cluster), each = 2)
  one <- withr::with_seed(1, bias_regression(d$Y, d$X, d$W, cluster = d$cluster))
  two <- withr::with_seed(1, bias_regression(d$Y[, dup], d$X[dup, ], d$W[, dup], cluster = d$cluster[dup]))
  expect_true(all(one$eta < 1))
  expect_equal(two$eta, one$eta / 2, tolerance = 1e-10)
  expect_equal(two$table, one$table, tolerance = 1e-8)
  # without tempering the same data twice counts as twice the evidence
  plain <- bias_regression(d$Y[, dup], d$X[dup, ], d$W[, dup])$table
  p_one <- bias_regression(d$Y, d$X, d$W)$table
  expect_gt(max(plain$inclusion_prob[plain$candidate != "decoy2"]),
            max(p_one$inclusion_prob[p_one$candidate != "decoy2"]))
})

test_that("print and summary say how much the evidence was tempered", {
  withr::local_seed(25)
  d <- clustered_bias()
  res <- bias_regression(d$Y, d$X, d$W, cluster = d$cluster)
  out <- structure(res$table, subsets = res$subsets, eta = res$eta, class = c("wv_explain", "data.frame"))
  eta <- sprintf("%.2f", stats::median(res$eta))
  expect_output(print(out), paste0("Evidence tempered by eta = ", eta), fixed = TRUE)
  expect_output(print(summary(out)), paste0("Evidence tempered by eta = ", eta), fixed = TRUE)
  attr(out, "eta") <- rep(1, length(res$eta))
  expect_false(any(grepl("tempered", utils::capture.output(print(out)))))
  # an eta that rounds to 1.00 is not reported as a discount
  attr(out, "eta") <- rep(0.996, length(res$eta))
  expect_false(any(grepl("tempered", utils::capture.output(print(out), print(summary(out))))))
})

test_that("with a non-negative amplitude the Bayes factor is the g-prior's integrated over the half line", {
  withr::local_seed(15)
  n <- 40
  x <- stats::rnorm(n)
  X <- matrix(x, ncol = 1, dimnames = list(NULL, "x"))
  for (beta in c(0.4, 0.1, -0.15)) {
    y <- beta * x + stats::rnorm(n)
    G <- sum(x^2)
    g <- n
    yy <- sum(y^2)
    # log p(y, a) - log p(y | no candidate), phi integrated out under 1 / phi
    lj <- function(a) {
      0.5 * log(G / g) + lgamma((n + 1) / 2) - lgamma(n / 2) - 0.5 * log(pi) + n / 2 * log(yy) -
        (n + 1) / 2 * log(colSums((y - outer(x, a))^2) + a^2 * G / g)
    }
    bf_free <- stats::integrate(function(a) exp(lj(a)), -Inf, Inf, rel.tol = 1e-8)$value
    r2 <- sum(x * y)^2 / G / yy
    expect_equal(bf_free, exp(-0.5 * log1p(g) - n / 2 * log1p(-g / (1 + g) * r2)), tolerance = 1e-6)
    # the joint prior of subset and amplitude conditioned on a >= 0: the
    # subset's marginal likelihood is the integral over the half line
    bf_pos <- stats::integrate(function(a) exp(lj(a)), 0, Inf, rel.tol = 1e-8)$value
    res <- withr::with_seed(1, bias_regression(matrix(y, 1), X, matrix(1, 1, n), max_size = 1, positive = TRUE))
    p <- res$table$inclusion_prob
    expect_equal(p / (1 - p), bf_pos, tolerance = 0.01)
    expect_gte(res$table$amplitude_lower, 0)
  }
})

test_that("the orthant probabilities agree with simulation and the Student t", {
  withr::local_seed(16)
  lat <- orthant_lattice(3)
  # a centred normal: closed form in two and three dimensions, simulation in four
  for (R in list(matrix(c(1, 0.6, 0.6, 1), 2),
                 matrix(c(1, -0.3, 0.5, -0.3, 1, 0.2, 0.5, 0.2, 1), 3),
                 stats::cov2cor(crossprod(matrix(stats::rnorm(24), 6, 4))))) {
    d <- nrow(R)
    exact <- if (d == 2) 0.25 + asin(R[1, 2]) / (2 * pi) else if (d == 3) {
      0.125 + (asin(R[1, 2]) + asin(R[1, 3]) + asin(R[2, 3])) / (4 * pi)
    } else {
      z <- matrix(stats::rnorm(4e5 * d), ncol = d) %*% chol(R)
      mean(rowSums(z > 0) == d)
    }
    expect_equal(exp(ghk_log_orthant(numeric(d), R, Inf, lat$v)), exact, tolerance = 0.01)
  }
  # posterior: mu + sqrt(phi) L z with phi = phi_hat n / chi^2_n
  n <- 12
  mu <- c(0.3, -0.1)
  V <- matrix(c(0.2, 0.05, 0.05, 0.1), 2)
  phi_hat <- 1.5
  N <- 4e5
  a <- sweep(matrix(stats::rnorm(2 * N), N, 2) %*% chol(V) * sqrt(phi_hat * n / stats::rchisq(N, n)), 2, mu, `+`)
  p_sim <- mean(a[, 1] >= 0 & a[, 2] >= 0)
  expect_equal(exp(log_orthant_posterior(mu, V, phi_hat, n, lat)), p_sim, tolerance = 0.01)
  # the lattice bias_regression() uses for two amplitudes
  expect_equal(exp(log_orthant_posterior(mu, V, phi_hat, n, orthant_lattice(1))), p_sim,
               tolerance = 0.01)
  # one dimension: the Student t, also far in its tail
  for (mu1 in c(-0.2, 0.5, -8)) {
    expect_equal(exp(log_orthant_posterior(mu1, matrix(0.3), phi_hat, n, lat)),
                 stats::pt(mu1 / sqrt(0.3 * phi_hat), df = n), tolerance = 1e-3)
  }
  # a tiny probability keeps its order of magnitude in several dimensions:
  # against the bivariate normal orthant integrated over phi
  exact <- stats::integrate(function(q) vapply(q, function(qq) {
    s <- sqrt(phi_hat * n / qq)
    stats::integrate(function(z1) {
      stats::dnorm(z1) * stats::pnorm((0.5 / s + V[2, 1] / sqrt(V[1, 1]) * z1) / sqrt(V[2, 2] - V[2, 1]^2 / V[1, 1]))
    }, 8 / s / sqrt(V[1, 1]), Inf)$value
  }, numeric(1)) * stats::dchisq(q, n), 0, Inf, rel.tol = 1e-10)$value
  expect_equal(exp(log_orthant_posterior(c(-8, 0.5), V, phi_hat, n, lat)), exact, tolerance = 0.01)
})

test_that("truncated amplitude draws keep the sign and the mean of the truncated normal", {
  withr::local_seed(17)
  a <- t(replicate(4000, draw_truncated(c(-0.5, 1), diag(c(1, 2)), c(TRUE, FALSE))))
  expect_true(all(a[, 1] >= 0))
  # within four standard errors of the truncated normal's mean
  expect_lt(abs(mean(a[, 1]) - (-0.5 + stats::dnorm(0.5) / stats::pnorm(-0.5))), 4 * stats::sd(a[, 1]) / 20)
  expect_equal(mean(a[, 2]), 1, tolerance = 0.1)
  expect_equal(draw_truncated(c(-50, 1), diag(c(1, 1)), c(TRUE, TRUE))[1], 0)
})

test_that("a non-negative amplitude gives no credit for the opposite of the bias", {
  withr::local_seed(18)
  d <- synthetic_bias()
  X <- d$X
  X[, "true"] <- -X[, "true"]
  colnames(X)[1] <- "flipped"
  free <- bias_regression(d$Y, X, d$W, max_size = 2)$table
  pos <- bias_regression(d$Y, X, d$W, max_size = 2, positive = rep(TRUE, 4))$table
  expect_gt(free$inclusion_prob[free$candidate == "flipped"], 0.9)
  expect_lt(pos$inclusion_prob[pos$candidate == "flipped"], 0.05)
  right <- bias_regression(d$Y, d$X, d$W, max_size = 2, positive = rep(TRUE, 4))$table
  expect_equal(right$candidate[1], "true")
  expect_gt(right$inclusion_prob[1], 0.9)
  expect_true(all(right$amplitude_lower >= 0))
})

test_that("skipping subsets far below the best leaves the posterior unchanged", {
  withr::local_seed(19)
  lat <- orthant_lattice(1)
  k <- 40
  lml <- c(stats::runif(k, -5, 5), stats::runif(k, -200, -60), -Inf)
  lprior <- rep(log(1 / (2 * length(lml))), length(lml))
  orthant <- lapply(seq_along(lml), function(j) {
    if (j %% 3 == 0) return(NULL)
    d <- 1 + j %% 2
    list(mu = stats::rnorm(d), V = diag(d) * 0.5 + 0.1, phi = 1)
  })
  fast <- orthant_adjusted(lml, lprior, log(0.5), orthant, 20, list(NULL, lat))
  full <- lml
  for (j in which(!vapply(orthant, is.null, logical(1)) & is.finite(lml))) {
    full[j] <- full[j] + log_orthant_posterior(orthant[[j]]$mu, orthant[[j]]$V, 1, 20, lat)
  }
  expect_true(any(is.infinite(fast[is.finite(lml)])))
  post <- function(l) {
    p <- exp(c(log(0.5), l + lprior) - max(c(log(0.5), l + lprior)))
    p / sum(p)
  }
  expect_equal(post(fast), post(full), tolerance = 1e-12)
  expect_equal(fast[1:k], full[1:k])
})
