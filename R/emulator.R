#' GASP emulators of the wavelet coefficients
#'
#' Fits one Gaussian process (GASP) emulator to every retained wavelet
#' coefficient of the model runs at every site (report section 3.3 and 4):
#' constant mean `mu`, variance `1 / lambda` and correlation
#' `exp(-sum_p beta_p |z_p - z'_p|^(2 - alpha_p))` on the inputs scaled to the
#' unit cube by the design's column minima and ranges, with `beta >= 0` and
#' `alpha` in \[0, 1\]. The hyperparameters maximise the likelihood with `mu` and
#' `lambda` profiled out.
#'
#' The `"gasp"` engine maximises each coefficient's profile log-likelihood with its analytic
#' gradient in C++ (a projected limited-memory BFGS over `log(beta)` and
#' `alpha`, preconditioned for the near-collinearity of `log(beta)` and
#' `alpha`). Each coefficient's fit first screens the likelihood, without
#' gradient, at cheap starting points: the fitted parameters of the previous
#' four coefficients of the same level (fits run level by level), isotropic
#' Gaussian points on a grid of `log(beta)` and, for the first coefficient of
#' a chunk (which has no previous fit), a fixed Latin hypercube; the
#' optimiser then starts from the best `starts` of them. The pairwise
#' distances of the design are computed once per chunk of coefficients. The `"dicekriging"` engine
#' calls [DiceKriging::km()] with the power-exponential covariance
#' `exp(-sum (|h| / theta)^p)`, `p` in \[1, 2\], and converts with
#' `beta = theta^-p`, `alpha = 2 - p`. Both engines then compute `mu`,
#' `lambda`, the weights and Cholesky factors with the same code.
#'
#' The `"gasp_level"` engine shares the correlation parameters within a
#' resolution level: per site and level, one `beta` and `alpha` per input for
#' all the level's coefficients (each keeping its own `mu` and `lambda`),
#' maximising the sum of the coefficients' profile log-likelihoods plus the log
#' of the jointly robust prior of Gu (2019) on the inverse ranges
#' `rho_p = beta_p^(1 / (2 - alpha_p))` (`a = 0.2`, `b = K^(-1/p) (a + p)` on
#' the unit cube, added once per level), with `alpha` in \[0.1, 1\] (exponent
#' `2 - alpha` at most 1.9: the Gaussian correlation's smoothness makes
#' predictions overconfident between the design points). One Cholesky factor
#' per level serves every coefficient, so the fit is fast. Pooling the
#' coefficients keeps inputs from being switched off one coefficient at a
#' time; the predictive variance is that of the Student-t predictive with
#' `K - 1` degrees of freedom, `S2 / (K - 3)` with `S2 = (y - mu)' R^-1 (y - mu)`,
#' so `lambda` is `(K - 3) / S2` rather than the plug-in `K / S2`. Its
#' `params$loglik` is each coefficient's profile log-likelihood at the shared
#' parameters. This goes beyond the method's report, whose emulators are the
#' `"gasp"` engine's.
#'
#' `"gasp_level"` is the default because its uncertainty holds away from the
#' design points. On the package's suspension test bed, at runs drawn away
#' from the design, its mean squared studentised errors stayed near 1 at
#' every level and its 90% intervals near their level, close to RobustGaSP's
#' `ppgasp()` fitted per level, while the per-coefficient fit's errors were
#' well beyond its predictive variances (`studies/README.md` in the
#' package's source repository). The sampler shares the correlation vector
#' of coefficients that share their parameters, so calibrating on these
#' emulators is several times faster.
#'
#' A nugget is added to the correlation matrix only when it is numerically
#' singular (1e-8, 1e-6, ...); it is reported in `params$nugget`, with a
#' warning. A coefficient that is constant across the runs gets a flat
#' emulator (`beta = 0`, a tiny variance and a unit nugget), with a warning.
#'
#' Fits run through [future.apply::future_lapply()] in chunks of coefficients,
#' so the [future::plan()] decides where; the result does not depend on it.
#'
#' @param runs A `wv_runs` object ([model_runs()]).
#' @param basis A `wv_basis` object ([wavelet_basis()]) on the grid of `runs`.
#' @param engine `"gasp_level"` (default; correlation parameters shared
#'   within a resolution level, Student-t predictive variance), `"gasp"` (one
#'   fit per coefficient, as in the method's report) or `"dicekriging"`.
#' @param starts Number of local optimisations per coefficient, from the best
#'   screened starting points (`"gasp"` engine; the `"gasp_level"` engine runs
#'   at least 4 per level); more is slower and more
#'   thorough.
#' @param log_beta_range Box for `log(beta)` on the unit-cube scale (`"gasp"`
#'   engine).
#' @param chunk_size Coefficients (of one level) fitted per future; warm
#'   starts pass between coefficients of a chunk, so the result depends on
#'   `chunk_size` but not on the plan.
#' @param seed Seed for the random starting points of `"dicekriging"`; `NULL`
#'   draws one from R's RNG. The `"gasp"` engine is deterministic.
#' @param ... Further arguments to [DiceKriging::km()] (`"dicekriging"`
#'   engine), e.g. `lower`, `upper`, `optim.method`.
#' @return A `wv_emulators` object: a list with `params` (data frame, one row
#'   per site and coefficient: `site`, `index`, `level`, `mu`, `lambda`,
#'   `nugget`, `loglik`, `converged`, then `beta_<input>` and `alpha_<input>`),
#'   `inputs`, `design` (K x p matrix), `banks` (named list by site of the
#'   predictor's matrices, see Details), `basis`, `engine`, `t` and
#'   `loo_check` (by level, pooled over sites: the number `n` of leave-one-out
#'   studentised residuals ([loo_residuals()]), their `mean_square` and the
#'   share `cover90` inside +-1.645).
#'
#'   Each bank holds `X` (scaled design), `beta`, `alpha` (n x p), `mu`,
#'   `lambda`, `nugget` (n), `weights` (K x n, `R^-1 (y - mu)`), `chol`
#'   (K x K x m lower Cholesky factors of `R`, each distinct factor once:
#'   the coefficients of a level share theirs with engine `"gasp_level"`),
#'   `chol_of` (n, the factor of each coefficient), `y` (K x n
#'   coefficients), `lower`, `width` (p).
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' design <- data.frame(a = seq(0, 1, length.out = 8), b = c(3, 7, 1, 5, 8, 2, 6, 4) / 8)
#' curves <- t(apply(design, 1, function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t))
#' runs <- model_runs(design, curves, t)
#' basis <- wavelet_basis(runs)
#' em <- fit_emulators(runs, basis)
#' em
#' predict(em, data.frame(a = 0.5, b = 0.5))$mean[, 1:4]
fit_emulators <- function(runs, basis, engine = c("gasp_level", "gasp", "dicekriging"), starts = 1,
                          log_beta_range = c(-8, 6), chunk_size = 16, seed = NULL, ...) {
  check_class(runs, "wv_runs")
  check_class(basis, "wv_basis")
  engine <- check_choice(engine)
  check_number(starts, min = 1, max = 100, integer = TRUE)
  check_number(chunk_size, min = 1, integer = TRUE)
  if (!is.numeric(log_beta_range) || length(log_beta_range) != 2L ||
      any(!is.finite(log_beta_range)) ||
      log_beta_range[1] >= log_beta_range[2]) {
    wv_abort("{.arg log_beta_range} must be two increasing finite numbers, e.g. {.code c(-8, 6)}.")
  }
  seed <- resolve_seed(seed)
  prep <- emulator_inputs(runs, basis)
  W <- prep$W
  sites <- names(W)

  flat <- lapply(W, function(m) {
    scale <- max(abs(m))
    apply(m, 2L, function(v) diff(range(v)) <= 1e-10 * scale)
  })
  # chunks of coefficients of one level: within a chunk each fit starts also
  # from the fitted parameters of the previous coefficients (same level)
  level <- basis$level %||% rep(0L, length(basis$index))
  tasks <- list()
  for (s in sites) {
    cols <- which(!flat[[s]])
    for (lv in unique(level[cols])) {
      cl <- cols[level[cols] == lv]
      # the gasp_level engine fits a level's coefficients together
      chunks <- if (engine == "gasp_level") list(cl) else split(cl,
                                                                ceiling(seq_along(cl) / chunk_size))
      for (ch in chunks) {
        tasks[[length(tasks) + 1L]] <- list(site = s, cols = ch, id = length(tasks) + 1L,
                                            group = rep(as.integer(lv), length(ch)))
      }
    }
  }
  n_fit <- sum(vapply(tasks, function(x) length(x$cols), integer(1)))
  worker <- emulator_worker(engine, prep$X, W, starts, log_beta_range, seed, list(...))
  results <- run_futures(tasks, worker,
                         paste("Fitting", n_fit, "emulators", paste0("(", engine, ")")),
                         quiet = isTRUE(getOption("wavevalid.quiet", FALSE)),
                         steps = vapply(tasks, function(x) length(x$cols), integer(1)),
                         future_seed = TRUE)

  banks <- list()
  params <- list()
  n_nugget <- 0L
  for (s in sites) {
    n <- ncol(W[[s]])
    p <- ncol(prep$X)
    beta <- matrix(0, n, p)
    alpha <- matrix(0, n, p)
    nugget <- rep(1, n)
    converged <- rep(NA, n)
    for (r in results[vapply(tasks, function(x) x$site == s, logical(1))]) {
      beta[r$cols, ] <- r$beta
      alpha[r$cols, ] <- r$alpha
      nugget[r$cols] <- r$nugget
      converged[r$cols] <- r$converged
    }
    bank <- emulator_bank(prep$X, W[[s]], beta, alpha, nugget, flat[[s]], prep$lower, prep$width)
    if (engine == "gasp_level") bank <- level_predictive_variance(bank, flat[[s]],
                                                                  level_settings()$predictive)
    n_nugget <- n_nugget + sum(bank$nugget[!flat[[s]]] > 0)
    banks[[s]] <- bank
    params[[s]] <- emulator_params(s, basis, bank, converged, colnames(prep$X))
  }
  n_flat <- sum(vapply(flat, sum, integer(1)))
  if (n_flat > 0L) {
    wv_warn(c(
      "{n_flat} coefficient{?s} {?is/are} constant across the runs and got a flat emulator (beta = 0).",
      "i" = "Their predictions are the constant with a negligible variance."
    ), class = "flat_coefficient")
  }
  if (n_nugget > 0L) {
    wv_warn(c(
      "{n_nugget} coefficient{?s} needed a nugget to keep the correlation matrix positive definite.",
      "i" = "See {.code params$nugget}; the emulators then smooth slightly instead of interpolating."
    ), class = "nugget")
  }
  params <- do.call(rbind, params)
  rownames(params) <- NULL
  if (engine == "dicekriging" && any(!params$converged, na.rm = TRUE)) {
    wv_warn(c(
      "DiceKriging::km() failed on {sum(!params$converged, na.rm = TRUE)} coefficient{?s}.",
      "i" = "The {.val gasp} engine fitted {?it/them} instead (rows with {.code converged = FALSE})."
    ), class = "engine_fallback")
  }
  em <- validate_wv_emulators(new_wv_emulators(params, colnames(prep$X), prep$design, banks, basis,
                                               engine,
                                               runs$t, seed))
  em$loo_check <- loo_check(em)
  em
}

new_wv_emulators <- function(params, inputs, design, banks, basis, engine, t, seed = NULL) {
  structure(list(params = params, inputs = inputs, design = design, banks = banks, basis = basis,
                 engine = engine, t = t, seed = seed), class = "wv_emulators")
}

validate_wv_emulators <- function(x, call = rlang::caller_env()) {
  p <- length(x$inputs)
  if (!is.matrix(x$design) || ncol(x$design) != p) {
    wv_abort("{.field design} must be a matrix with one column per input.", class = "state",
             call = call)
  }
  for (s in names(x$banks)) {
    b <- x$banks[[s]]
    n <- length(b$mu)
    k <- nrow(b$X)
    m <- if (is.null(b$chol_of)) n else dim(b$chol)[3]
    if (!identical(dim(b$chol), c(k, k, m)) || !identical(dim(b$weights), c(k, n)) ||
        (!is.null(b$chol_of) &&
         (length(b$chol_of) != n || anyNA(b$chol_of) || any(b$chol_of < 1L | b$chol_of > m))) ||
        !identical(dim(b$beta), c(n, p)) || !identical(dim(b$alpha), c(n, p))) {
      wv_abort("The bank of site {.val {s}} has inconsistent dimensions.", class = "state",
               call = call)
    }
  }
  need <- c("site", "index", "level", "mu", "lambda", "nugget", "loglik",
            paste0("beta_", x$inputs), paste0("alpha_", x$inputs))
  miss <- setdiff(need, names(x$params))
  if (length(miss)) {
    wv_abort("{.field params} lacks column{?s} {.val {miss}}.", class = "state", call = call)
  }
  x
}

# Coefficients of the runs on the basis: named list by site of K x n matrices.
emulator_coefficients <- function(runs, basis) {
  sites <- names(runs$curves)
  if (!is.null(basis$sites)) sites <- intersect(sites, basis$sites)
  out <- lapply(sites, function(s) {
    W <- basis_coef(basis, runs$curves[[s]])
    colnames(W) <- basis$index
    W
  })
  stats::setNames(out, sites)
}

# Checks the design and coefficients before any fitting; returns the raw and
# scaled design, the scaling and the coefficients by site.
emulator_inputs <- function(runs, basis, call = rlang::caller_env()) {
  n_t <- length(runs$t)
  if (!is.matrix(basis$Psi) || nrow(basis$Psi) != n_t ||
      (!is.null(basis$t) &&
       (length(basis$t) != n_t || max(abs(basis$t - runs$t)) > 1e-8 * max(1, abs(runs$t))))) {
    wv_abort(c(
      "{.arg basis} is not on the grid of {.arg runs}.",
      "x" = "The runs have {n_t} time points; the basis has {NROW(basis$Psi)}{if (!is.null(basis$t) && length(basis$t) == n_t) ' on different times' else ''}.",
      "i" = "Build the basis with {.code wavelet_basis(runs)} on the same runs."
    ), call = call)
  }
  if (is.null(basis$sites)) basis$sites <- names(runs$curves)
  sites <- intersect(names(runs$curves), basis$sites)
  if (!length(sites)) {
    wv_abort("No site of {.arg runs} ({.val {names(runs$curves)}}) is in the basis ({.val {basis$sites}}).",
             call = call)
  }
  design <- as.matrix(runs$design)
  storage.mode(design) <- "double"
  k <- nrow(design)
  p <- ncol(design)
  if (any(!is.finite(design))) {
    wv_abort("The design must be finite; it has {sum(!is.finite(design))} NA or infinite value{?s}.", call = call)
  }
  if (k < p + 2L) {
    wv_abort(c(
      "Too few runs to fit the emulators: {k} run{?s} for {p} input{?s}.",
      "i" = "A GASP with {p} inputs needs at least {p + 2} runs (about 10 per input is usual)."
    ), call = call)
  }
  check_distinct_runs(design, call = call)
  lower <- apply(design, 2L, min)
  width <- apply(design, 2L, max) - lower
  if (any(width <= 0)) {
    wv_abort("Input{?s} {.val {colnames(design)[width <= 0]}} {?does/do} not vary in the design; drop {?it/them} from the runs.",
             call = call)
  }
  W <- emulator_coefficients(runs, basis)[sites]
  for (s in sites) {
    bad <- which(!is.finite(W[[s]]), arr.ind = TRUE)
    if (nrow(bad)) {
      bad_runs <- unique(bad[, 1])
      wv_abort(c(
        "The wavelet coefficients of site {.val {s}} have {nrow(bad)} non-finite value{?s}.",
        "x" = "{cli::qty(length(bad_runs))}Run{?s} {bad_runs} {?has/have} NA or infinite output.",
        "i" = "Remove failed runs (model_runs() drops them) before fitting."
      ), call = call)
    }
  }
  X <- sweep(sweep(design, 2L, lower, "-"), 2L, width, "/")
  list(design = design, X = X, lower = lower, width = width, W = W)
}

# The function a future evaluates on one chunk of coefficients.
emulator_worker <- function(engine, X, W, starts, log_beta_range, seed, km_args) {
  # every argument forced: no promise carries fit_emulators()' frame (the
  # runs, the basis) to the workers
  force(X)
  force(W)
  force(starts)
  force(log_beta_range)
  force(seed)
  force(km_args)
  level_set <- if (engine == "gasp_level") level_settings()
  function(task) {
    Y <- W[[task$site]][, task$cols, drop = FALSE]
    if (engine == "gasp") {
      # warm starts from the last four fits of the level; the space-filling
      # points only for the first coefficient of a chunk, which has none
      f <- gasp_fit_cpp(X, Y, task$group, gasp_control(starts, log_beta_range), n_warm = 4L,
                        warm_only = TRUE)
      f$cols <- task$cols
      return(f)
    }
    if (engine == "gasp_level") return(gasp_level_fit(X, Y, starts, log_beta_range, task$cols,
                                                      level_set))
    dicekriging_fit(X, Y, km_args, seed + task$id, task$cols)
  }
}

# Settings of the gasp engine's optimiser (fields of GaspSettings in gasp_optim.h).
gasp_control <- function(starts, log_beta_range) {
  list(n_local = as.integer(starts), lb_lo = log_beta_range[1], lb_hi = log_beta_range[2],
       maxit = 200L, n_screen = 8L, memory = 30L, ftol = 1e-8, pgtol = 1e-5, precondition = 1L,
       iso_half = 0L)
}

# Settings of the gasp_level engine: the prior on the correlation parameters
# (type 1: jointly robust, 0: none), the likelihood (restricted = 1: mu
# integrated out instead of profiled), the predictive variance ("student" or
# "plugin", see level_predictive_variance()), the screening and local
# optimisations and the box of alpha. The option wavevalid.gasp_level (a
# list of some of these) overrides them, for studies of the choices.
level_settings <- function() {
  utils::modifyList(list(prior = list(type = 1L, a = 0.2, b_mult = 1), restricted = 0L,
                         predictive = "student",
                         n_screen = 32L, n_local = 4L, alpha = c(0.1, 1)),
                    getOption("wavevalid.gasp_level", list()))
}

# One shared (beta, alpha) for the columns of Y (a level's coefficients),
# repeated for each of them.
gasp_level_fit <- function(X, Y, starts, log_beta_range, cols, set = level_settings()) {
  control <- gasp_control(max(starts, set$n_local), log_beta_range)
  control$n_screen <- as.integer(set$n_screen)
  control$iso_half <- 1L
  control$alpha_lo <- set$alpha[1]
  control$alpha_hi <- set$alpha[2]
  f <- gasp_level_fit_cpp(X, Y, control, set$prior, as.integer(set$restricted), list())
  n <- ncol(Y)
  list(beta = matrix(f$beta, n, ncol(X), byrow = TRUE),
       alpha = matrix(f$alpha, n, ncol(X), byrow = TRUE),
       nugget = rep(f$nugget, n), converged = rep(f$converged, n), cols = cols)
}

# The predictive variance of the gasp_level engine. "plugin": 1 / lambda with
# lambda = K / S2 (the profile-likelihood estimate, S2 = (y - mu)' R^-1 (y - mu)).
# "student": the variance of the Student-t predictive with K - 1 degrees of
# freedom and scale S2 / (K - 1), that is S2 / (K - 3): lambda = (K - 3) / S2,
# 1 / lambda larger than the plug-in one by K / (K - 3).
level_predictive_variance <- function(bank, flat, predictive) {
  k <- nrow(bank$X)
  if (identical(predictive, "student") && k > 3L) {
    bank$lambda[!flat] <- bank$lambda[!flat] * (k - 3) / k
  }
  bank
}

dicekriging_fit <- function(X, Y, km_args, seed, cols) {
  old <- if (exists(".Random.seed", envir = globalenv())) get(".Random.seed",
                                                              envir = globalenv()) else NULL
  on.exit(if (!is.null(old)) assign(".Random.seed", old, envir = globalenv()))
  set.seed(seed)
  p <- ncol(X)
  n <- ncol(Y)
  beta <- alpha <- matrix(0, n, p)
  design <- as.data.frame(X)
  args <- utils::modifyList(list(
    formula = ~1, design = design, covtype = "powexp",
    lower = c(rep(1e-10, p), rep(1, p)), upper = c(rep(2, p), rep(2, p)),
    control = list(trace = FALSE)
  ), km_args)
  failed <- rep(FALSE, n)
  for (i in seq_len(n)) {
    args$response <- Y[, i]
    fit <- NULL
    utils::capture.output(fit <- tryCatch(suppressWarnings(do.call(DiceKriging::km, args)),
                                          error = function(e) NULL))
    if (is.null(fit)) {
      failed[i] <- TRUE
      g <- gasp_fit_cpp(X, Y[, i, drop = FALSE], 1L, gasp_control(2L, c(-8, 6)))
      beta[i, ] <- g$beta
      alpha[i, ] <- g$alpha
      next
    }
    cv <- fit@covariance
    beta[i, ] <- cv@range.val^(-cv@shape.val)
    alpha[i, ] <- pmin(pmax(2 - cv@shape.val, 0), 1)
  }
  list(beta = beta, alpha = alpha, nugget = rep(0, n), converged = !failed, cols = cols)
}

# Assembles a site's bank from hyperparameters (flat coefficients: beta = 0,
# unit nugget, variance 1e-16 of the data scale).
emulator_bank <- function(X, Y, beta, alpha, nugget, flat, lower, width) {
  k <- nrow(X)
  n <- ncol(Y)
  fit <- which(!flat)
  mu <- lambda <- loglik <- numeric(n)
  weights <- matrix(0, k, n)
  # the distinct Cholesky factors, each stored once, and each coefficient's
  # (coefficients fitted per level share theirs)
  chol <- array(0, c(k, k, 0))
  chol_of <- integer(n)
  if (length(fit)) {
    f <- gasp_finalize_cpp(X, Y[, fit, drop = FALSE], beta[fit, , drop = FALSE],
                           alpha[fit, , drop = FALSE], nugget[fit])
    mu[fit] <- f$mu
    lambda[fit] <- f$lambda
    nugget[fit] <- f$nugget
    loglik[fit] <- f$loglik
    weights[, fit] <- f$weights
    chol <- f$chol
    chol_of[fit] <- f$chol_of
  }
  if (any(flat)) {
    m <- dim(chol)[3]
    chol <- array(c(chol, t(chol(matrix(1, k, k) + diag(k)))), c(k, k, m + 1L))
    for (i in which(flat)) {
      mu[i] <- Y[1, i]
      lambda[i] <- 1 / (1e-8 * max(1, abs(Y[1, i])))^2
      nugget[i] <- 1
      loglik[i] <- NA_real_
      beta[i, ] <- 0
      alpha[i, ] <- 0
      chol_of[i] <- m + 1L
    }
  }
  list(X = X, beta = beta, alpha = alpha, mu = mu, lambda = lambda, nugget = nugget,
       weights = weights, chol = chol, chol_of = chol_of, y = Y, lower = lower, width = width,
       loglik = loglik)
}

# One bank of GASP emulators with fixed beta/alpha (n x p); mu and lambda by
# profile maximum likelihood; design scaled to the unit cube.
bank_fixed_hyper <- function(X_raw, Y, beta, alpha, nugget = 1e-8) {
  X_raw <- as.matrix(X_raw)
  K <- nrow(X_raw)
  p <- ncol(X_raw)
  n <- ncol(Y)
  lower <- apply(X_raw, 2, min)
  width <- apply(X_raw, 2, function(v) diff(range(v)))
  X <- sweep(sweep(X_raw, 2, lower), 2, width, "/")
  beta <- matrix(beta, n, p, byrow = is.null(dim(beta)))
  alpha <- matrix(alpha, n, p, byrow = is.null(dim(alpha)))
  mu <- lambda <- numeric(n)
  weights <- matrix(0, K, n)
  chol <- array(0, c(K, K, n))
  for (i in seq_len(n)) {
    D <- matrix(0, K, K)
    for (q in seq_len(p)) D <- D + beta[i, q] * abs(outer(X[, q], X[, q], "-"))^(2 - alpha[i, q])
    Rm <- exp(-D) + diag(nugget, K)
    L <- t(base::chol(Rm))
    Ri <- function(v) backsolve(t(L), forwardsolve(L, v))
    one <- rep(1, K)
    mu[i] <- sum(Ri(Y[, i])) / sum(Ri(one))
    e <- Y[, i] - mu[i]
    weights[, i] <- Ri(e)
    lambda[i] <- K / sum(e * weights[, i])
    chol[, , i] <- L
  }
  list(X = X, beta = beta, alpha = alpha, mu = mu, lambda = lambda, nugget = rep(nugget, n),
       weights = weights, chol = chol, y = Y, lower = lower, width = width)
}

# Emulators of one site with fixed beta/alpha (bank_fixed_hyper()) for the
# coefficients Y (K x n) of the runs at `design` (K x p, named columns) on
# `basis`: a `wv_emulators` object whose params carry no likelihood.
fixed_hyper_emulators <- function(design, Y, basis, t, beta, alpha, site = "site1") {
  bank <- bank_fixed_hyper(design, Y, beta = beta, alpha = alpha)
  inputs <- colnames(design)
  params <- data.frame(site = site, index = basis$index, level = basis$level, mu = bank$mu,
                       lambda = bank$lambda, nugget = bank$nugget, loglik = NA_real_)
  for (q in seq_along(inputs)) {
    params[[paste0("beta_", inputs[q])]] <- bank$beta[, q]
    params[[paste0("alpha_", inputs[q])]] <- bank$alpha[, q]
  }
  banks <- stats::setNames(list(bank), site)
  validate_wv_emulators(new_wv_emulators(params, inputs, design, banks, basis, "gasp", t))
}
