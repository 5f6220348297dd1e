
# Lower Cholesky factor of a covariance, or a classed error when it is not
# symmetric positive definite. The check runs on the correlation matrix, so
# that covariances of inputs of order 1e-7 are judged as those of order 1.
joint_chol <- function(cov, call = rlang::caller_env()) {
  sym <- max(abs(cov - t(cov))) <= 1e-10 * max(abs(cov))
  if (!sym) {
    wv_abort(c("{.arg cov} must be symmetric.",
               "x" = "Its largest asymmetry is {signif(max(abs(cov - t(cov))), 3)}."),
             class = c("prior", "numeric"), call = call)
  }
  dg <- diag(cov)
  if (any(dg <= 0)) {
    wv_abort("{.arg cov} must be positive definite; its diagonal has entries of zero or less.",
             class = c("prior", "numeric"), call = call)
  }
  s <- sqrt(dg)
  corr <- cov / outer(s, s)
  ev <- eigen((corr + t(corr)) / 2, symmetric = TRUE, only.values = TRUE)$values
  if (min(ev) <= 1e-10 * max(ev)) {
    wv_abort(c("{.arg cov} must be positive definite.",
               "x" = "The smallest eigenvalue of its correlation matrix is {signif(min(ev), 3)}."),
             class = c("prior", "numeric"), call = call)
  }
  L <- t(chol((corr + t(corr)) / 2))
  L * s
}

validate_joint_blocks <- function(x, blocks, call = rlang::caller_env()) {
  if (!length(blocks)) {
    if (any(x$prior == "joint")) {
      wv_abort("Inputs {.val {x$name[x$prior == 'joint']}} have a joint prior the I/U map does not hold.",
               class = c("prior", "input"), call = call)
    }
    return(invisible(x))
  }
  covered <- unlist(lapply(blocks, `[[`, "names"))
  if (!setequal(covered, x$name[x$prior == "joint"]) || anyDuplicated(covered)) {
    wv_abort("The joint priors of the I/U map do not match its inputs with prior {.val joint}.",
             class = c("prior", "input"), call = call)
  }
  for (b in blocks) {
    mass <- joint_box_mass(x, b)
    if (mass < min_prior_mass) {
      wv_abort(c(
        "The joint prior of {.val {b$names}} puts almost no mass in their ranges.",
        "x" = "Before truncation it gives the box [lower, upper] probability {signif(mass, 2)} (estimated).",
        "i" = "Check that {.arg mean} lies inside the ranges and on the inputs' scales (log for {.code scale = \"log\"})."
      ), class = c("prior", "numeric"), call = call)
    }
  }
  invisible(x)
}

# Probability of the box under the untruncated Gaussian of block b, estimated
# from 20000 draws with a fixed stream (R's generator left as it was).
joint_box_mass <- function(iu, b, n = 20000L) {
  k <- match(b$names, iu$name)
  lg <- b$scale == "log"
  lo <- iu$lower[k]
  hi <- iu$upper[k]
  lo[lg] <- log(lo[lg])
  hi[lg] <- log(hi[lg])
  L <- joint_chol(b$cov)
  Y <- with_rng_seed(1L, matrix(stats::rnorm(n * length(k)), n)) %*% t(L)
  Y <- sweep(Y, 2L, b$mean, "+")
  inside <- rowSums(sweep(Y, 2L, lo, ">=") & sweep(Y, 2L, hi, "<=")) == length(k)
  mean(inside)
}

# --- densities and draws ---------------------------------------------------

# Log prior density of the inputs (rows of X, columns named as inputs of iu)
# in their own units, up to the truncation constants: the target the sampler
# uses. -Inf outside the box.
iu_log_prior <- function(iu, X) {
  iu <- iu_upgrade(iu)
  X <- as.matrix(X)
  k <- match(colnames(X), iu$name)
  lp <- numeric(nrow(X))
  for (j in seq_along(k)) {
    kk <- k[j]
    x <- X[, j]
    out <- x < iu$lower[kk] | x > iu$upper[kk]
    term <- switch(iu$prior[kk],
                   normal = -0.5 * ((x - iu$prior_mean[kk]) / iu$prior_sd[kk])^2,
                   lognormal = -0.5 * ((log(pmax(x, 0)) - log(iu$prior_mean[kk])) /
                                       iu$prior_sd[kk])^2 - log(x),
                   0)
    lp <- lp + ifelse(out, -Inf, term)
  }
  for (b in attr(iu, "joint")) {
    Y <- X[, b$names, drop = FALSE]
    lg <- b$scale == "log"
    Y[, lg] <- log(Y[, lg])
    R <- sweep(Y, 2L, b$mean)
    Q <- rowSums((R %*% solve(b$cov)) * R)
    lp <- lp - 0.5 * Q - rowSums(log(X[, b$names[lg], drop = FALSE]))
  }
  lp
}

# Marginal prior density of input k at values v (in the input's own units).
# For an input under a joint prior it is a kernel estimate from prior draws.
iu_prior_density <- function(iu, k, v) {
  iu <- iu_upgrade(iu)
  lo <- iu$lower[k]
  hi <- iu$upper[k]
  inside <- v >= lo & v <= hi
  prior <- iu$prior[k]
  if (prior == "uniform") return(ifelse(inside, 1 / (hi - lo), 0))
  if (prior == "none") return(ifelse(v == iu$nominal[k], Inf, 0))
  if (prior == "joint") {
    x <- with_rng_seed(1L, iu_prior_draws(iu, 4000L)[, k])
    d <- stats::density(x, from = lo, to = hi, n = 512)
    return(ifelse(inside, stats::approx(d$x, d$y, v, rule = 2)$y, 0))
  }
  mass <- univariate_prior_mass(iu, k, lo, hi)
  dens <- if (prior == "lognormal") {
    stats::dlnorm(pmax(v, lo), log(iu$prior_mean[k]), iu$prior_sd[k])
  } else {
    stats::dnorm(v, iu$prior_mean[k], iu$prior_sd[k])
  }
  ifelse(inside, dens / mass, 0)
}

# Prior probability of [a, b] for input k.
iu_prior_mass <- function(iu, k, a, b) {
  iu <- iu_upgrade(iu)
  a <- max(a, iu$lower[k])
  b <- min(b, iu$upper[k])
  if (b <= a) return(0)
  switch(iu$prior[k],
         uniform = (b - a) / (iu$upper[k] - iu$lower[k]),
         none = as.numeric(a <= iu$nominal[k] && iu$nominal[k] <= b),
         joint = {
           x <- with_rng_seed(1L, iu_prior_draws(iu, 4000L)[, k])
           mean(x >= a & x <= b)
         },
         univariate_prior_mass(iu, k, a, b) /
         univariate_prior_mass(iu, k, iu$lower[k], iu$upper[k]))
}

# Draws from the prior of every input (n x p matrix in the inputs' own units),
# with nominals of the inputs with manufacturing variation optionally
# replaced (a new vehicle under other nominals). A condition is known: its
# nominal value, the base experiment's, in every draw.
iu_prior_draws <- function(iu, n, nominal = NULL) {
  iu <- iu_upgrade(iu)
  nom <- iu$nominal
  if (!is.null(nominal)) nom[match(names(nominal), iu$name)] <- nominal
  out <- vapply(seq_len(nrow(iu)), function(k) {
    lo <- iu$lower[k] - iu$nominal[k] + nom[k]
    hi <- iu$upper[k] - iu$nominal[k] + nom[k]
    if (iu$type[k] == "condition") return(rep(iu$nominal[k], n))
    if (iu$type[k] == "calibration") {
      if (iu$prior[k] == "joint") return(rep(NA_real_, n))
      if (iu$prior[k] == "uniform") return(stats::runif(n, iu$lower[k], iu$upper[k]))
      lg <- iu$prior[k] == "lognormal"
      m <- if (lg) log(iu$prior_mean[k]) else iu$prior_mean[k]
      a <- if (lg) log(iu$lower[k]) else iu$lower[k]
      b <- if (lg) log(iu$upper[k]) else iu$upper[k]
      y <- stats::qnorm(stats::runif(n, stats::pnorm(a, m, iu$prior_sd[k]),
                                     stats::pnorm(b, m, iu$prior_sd[k])),
                        m, iu$prior_sd[k])
      return(pmin(pmax(if (lg) exp(y) else y, iu$lower[k]), iu$upper[k]))
    }
    p <- stats::runif(n, stats::pnorm(lo, nom[k], iu$prior_sd[k]),
                      stats::pnorm(hi, nom[k], iu$prior_sd[k]))
    stats::qnorm(p, nom[k], iu$prior_sd[k])
  }, numeric(n))
  if (n == 1L) out <- matrix(out, nrow = 1L)
  colnames(out) <- iu$name
  for (b in attr(iu, "joint")) out[, b$names] <- joint_draws(iu, b, n)
  out
}

# n draws of block b by rejection from the untruncated Gaussian.
joint_draws <- function(iu, b, n) {
  k <- match(b$names, iu$name)
  lo <- iu$lower[k]
  hi <- iu$upper[k]
  L <- joint_chol(b$cov)
  lg <- b$scale == "log"
  out <- matrix(NA_real_, 0, length(k))
  tries <- 0
  while (nrow(out) < n) {
    m <- max(100L, 2L * (n - nrow(out)))
    Y <- sweep(matrix(stats::rnorm(m * length(k)), m) %*% t(L), 2L, b$mean, "+")
    Y[, lg] <- exp(Y[, lg])
    ok <- rowSums(sweep(Y, 2L, lo, ">=") & sweep(Y, 2L, hi, "<=")) == length(k)
    out <- rbind(out, Y[ok, , drop = FALSE])
    tries <- tries + m
    if (tries > 1e8) {
      wv_abort("The joint prior of {.val {b$names}} puts almost no mass in their ranges.",
               class = c("prior", "numeric"))
    }
  }
  out[seq_len(n), , drop = FALSE]
}

# --- statements --------------------------------------------------------------

# One label per input stating its prior.
prior_labels <- function(iu, range = TRUE) {
  iu <- iu_upgrade(iu)
  f <- function(v) format(signif(v, 4), trim = TRUE)
  on <- function(k) sprintf(if (range) " on [%s, %s]" else " [%s, %s]", f(iu$lower[k]),
                            f(iu$upper[k]))
  blocks <- attr(iu, "joint")
  vapply(seq_len(nrow(iu)), function(k) {
    lab <- switch(iu$prior[k],
      uniform = "uniform",
      none = "none (a condition, known), design",
      normal = sprintf("normal(%s, sd %s)", f(iu$prior_mean[k]), f(iu$prior_sd[k])),
      lognormal = sprintf("log-normal(median %s, sd of log %s)", f(iu$prior_mean[k]),
                          f(iu$prior_sd[k])),
      joint = {
        j <- which(vapply(blocks, function(b) iu$name[k] %in% b$names, logical(1)))
        b <- blocks[[j]]
        q <- match(iu$name[k], b$names)
        sprintf("joint Gaussian %d: %s mean %s, sd %s", j,
                if (b$scale[q] == "log") "log x" else "x",
                f(b$mean[q]), f(sqrt(b$cov[q, q])))
      })
    paste0(lab, on(k))
  }, character(1))
}

# Lines describing the joint Gaussian priors (correlations).
joint_prior_text <- function(iu) {
  blocks <- attr(iu, "joint")
  unlist(lapply(seq_along(blocks), function(j) {
    b <- blocks[[j]]
    s <- sqrt(diag(b$cov))
    corr <- b$cov / outer(s, s)
    lab <- ifelse(b$scale == "log", paste0("log(", b$names, ")"), b$names)
    head <- sprintf("Joint Gaussian %d on %s, truncated to the ranges; correlations:", j,
                    paste(lab, collapse = ", "))
    rows <- vapply(seq_along(lab), function(q) {
      paste0("  ", formatC(lab[q], width = -max(nchar(lab))), " ",
             paste(formatC(corr[q, ], format = "f", digits = 2, width = 6), collapse = " "))
    }, character(1))
    c(head, rows)
  }))
}

# The priors as the sampler reads them: per input kind (0 uniform, 1 normal,
# 2 log-normal, 3 under a joint Gaussian), mean and sd (of log x for
# log-normal), and the joint blocks (0-based input positions, log flags, mean,
# lower Cholesky factor of the covariance). `prior_iu` is the I/U map of the
# sampler's inputs, in their order, variation shifted to x_nom.
sampler_priors <- function(prior_iu) {
  var <- prior_iu$type == "variation"
  kind <- match(prior_iu$prior, c("uniform", "normal", "lognormal", "joint")) - 1L
  mean <- rep(0, nrow(prior_iu))
  mean[kind == 1L] <- prior_iu$prior_mean[kind == 1L]
  mean[kind == 2L] <- log(prior_iu$prior_mean[kind == 2L])
  sd <- ifelse(kind %in% 1:2, prior_iu$prior_sd, 1)
  joint <- lapply(attr(prior_iu, "joint"), function(b) {
    list(index = match(b$names, prior_iu$name) - 1L, log = b$scale == "log", mean = b$mean,
         chol = joint_chol(b$cov))
  })
  list(lower = prior_iu$lower, upper = prior_iu$upper, normal = var, mean = mean, sd = sd,
       kind = as.integer(kind), joint = joint)
}

# An I/U map made before priors of calibration inputs existed: uniform ones.
iu_upgrade <- function(x) {
  if (!is.null(x$prior)) return(x)
  x$prior <- ifelse(x$type == "variation", "normal", "uniform")
  x$prior_mean <- ifelse(x$type == "variation", x$nominal, NA_real_)
  x
}

# Probability of [a, b] under the untruncated normal or log-normal prior of input k.
univariate_prior_mass <- function(x, k, a, b) {
  if (x$prior[k] == "lognormal") {
    m <- log(x$prior_mean[k])
    return(stats::pnorm(log(b), m, x$prior_sd[k]) - stats::pnorm(log(max(a, 0)), m, x$prior_sd[k]))
  }
  stats::pnorm(b, x$prior_mean[k], x$prior_sd[k]) - stats::pnorm(a, x$prior_mean[k], x$prior_sd[k])
}
