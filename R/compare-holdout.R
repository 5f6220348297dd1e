# The held-out condition of compare_validations(): each model's prediction of
# it (made here for a wv_field or an experiment(), given by the user
# otherwise), its held-out field data (an experiment's registered once, as
# the first fit registers its own, for both), the draws of its predictions,
# and the paired resampling behind the verdict.

# A list `before`, `after`, each with `field` (the held-out data for that
# model), `pred` (a wv_prediction whose summary has `mean` and `model`) and
# `draws` (by site: `Psi` and centred coefficient draws `model`, `corrected`,
# or `Psi = NULL` and centred curve draws; NULL when the prediction has none).
holdout_predictions <- function(before, after, holdout, level, seed, call = rlang::caller_env()) {
  fits <- list(before = before, after = after)
  if (inherits(holdout, "wv_field")) {
    return(lapply(fits, function(f) {
      pred <- stats::predict(f, type = "field_run", level = level, seed = seed)
      list(field = holdout, pred = pred, draws = fit_draws(f, unique(pred$summary$site)))
    }))
  }
  if (inherits(holdout, "wv_experiment")) {
    # one target: the held-out data registered once, as the first fit that
    # registers its own (before, else after) would, and graded so for both
    judge <- if (!is.null(fit_controls(before)$registration$windows)) before else after
    field <- holdout_registered(judge, holdout, call)
    return(lapply(fits,
                  function(f) experiment_prediction(f, holdout, level, seed, call, field = field)))
  }
  if (is.list(holdout) && inherits(holdout$before, "wv_experiment") &&
      inherits(holdout$after, "wv_experiment")) {
    return(stats::setNames(lapply(c("before", "after"), function(m) {
      experiment_prediction(fits[[m]], holdout[[m]], level, seed, call)
    }), c("before", "after")))
  }
  fld <- if (is.list(holdout)) holdout$field
  if (inherits(fld, "wv_field")) fld <- list(before = fld, after = fld)
  ok <- is.list(holdout) && is.list(fld) && inherits(fld$before, "wv_field") &&
    inherits(fld$after, "wv_field") &&
    inherits(holdout$before, "wv_prediction") && inherits(holdout$after, "wv_prediction")
  if (!ok) {
    wv_abort(c(
      "{.arg holdout} must be an {.fn experiment}, a list of two ({.field before}, {.field after}), a {.cls wv_field} or a list with {.field field}, {.field before} and {.field after}.",
      "i" = "An {.fn experiment} with {.arg change} is predicted by each model at its inputs plus the change.",
      "i" = "With predictions: {.field before} and {.field after} are {.cls wv_prediction}s of each fit for the held-out system, {.field field} a {.cls wv_field} or a list of two."
    ), call = call)
  }
  lapply(c(before = "before", after = "after"), function(m) {
    list(field = fld[[m]], pred = holdout[[m]], draws = prediction_draws(holdout[[m]]))
  })
}

# Centred coefficient draws of a fit's model (plus `dW`, a change of the
# model coefficients draw by draw) and of its bias-corrected prediction.
fit_draws <- function(fit, sites, dW = NULL) {
  # the Gram matrix of the basis: the identity (NULL) for the orthonormal
  # columns of wavelet_basis()'s transforms
  basis <- fit_get(fit, "basis")
  G <- if (is.null(basis$settings)) crossprod(basis$Psi)
  stats::setNames(lapply(sites, function(s) {
    M <- fit_get(fit, "wM")[[s]]
    if (!is.null(dW)) M <- M + dW[[s]]
    W <- M + fit_get(fit, "wb")[[s]]
    list(Psi = basis$Psi, G = G, model = sweep(M, 2L, colMeans(M)),
         corrected = sweep(W, 2L, colMeans(W)))
  }), sites)
}

# Centred coefficient draws of the model and of the bias-corrected
# prediction at a condition (new_condition_setup()).
condition_draws <- function(fit, setup, sites) {
  basis <- fit_get(fit, "basis")
  G <- if (is.null(basis$settings)) crossprod(basis$Psi)
  stats::setNames(lapply(sites, function(s) {
    M <- setup$sites[[s]]$M
    W <- M + setup$sites[[s]]$B
    list(Psi = basis$Psi, G = G, model = sweep(M, 2L, colMeans(M)),
         corrected = sweep(W, 2L, colMeans(W)))
  }), sites)
}

# The curve draws a user's prediction kept (keep_draws = TRUE), centred; the
# model alone has none.
prediction_draws <- function(pred) {
  if (is.null(pred$draws)) return(NULL)
  lapply(pred$draws,
         function(D) list(Psi = NULL, model = NULL, corrected = sweep(D, 2L, colMeans(D))))
}

# One model's prediction of a held-out experiment: its field data registered
# as the fit registered its own (validate() with windows: to the model in the
# experiment's condition, see register_experiments()), and the prediction at
# the posterior draws of the inputs plus the change (predict(type =
# "added_load", delta = change)) or through the experiment's own emulators.
experiment_prediction <- function(fit, x, level, seed, call, field = NULL) {
  x <- check_holdout_experiment(fit, x, call)
  field <- field %||% holdout_registered(fit, x, call)
  sites <- names(field$curves)
  if (!is.null(x$condition)) {
    pred <- stats::predict(fit, type = "new_condition", condition = x$condition, level = level,
                           seed = seed)
    setup <- with_rng_seed(setup_seed_of(pred$seed),
                           new_condition_setup(fit, x$condition, call = call))
    return(list(field = field, pred = pred, draws = condition_draws(fit, setup, sites)))
  }
  if (!is.null(x$change)) {
    pred <- stats::predict(fit, type = "added_load", delta = x$change, level = level, seed = seed)
    dW <- added_load_emulated(fit, x$change, call = call)$Dw
    return(list(field = field, pred = pred, draws = fit_draws(fit, sites, dW)))
  }
  post <- fit_draws_matrix(fit)[, fit_get(fit, "inputs"), drop = FALSE]
  em <- x$emulators
  zbar <- matrix(colMeans(post)[em$inputs], 1L)
  Ms <- stats::setNames(lapply(sites, function(s) {
    bank_predict(site_bank(em, s), post[, em$inputs, drop = FALSE])$mean
  }), sites)
  rows <- with_rng_seed(seed, lapply(sites, function(s) {
    M <- Ms[[s]]
    W <- M + fit_get(fit, "wb")[[s]] +
      sqrt(fit_get(fit, "sigma2")[[s]]) * matrix(stats::rnorm(length(M)), nrow(M))
    band <- band_frame(tcrossprod(W, fit_get(fit, "basis")$Psi), fit_get(fit, "basis")$t, s, level)
    band$model <- drop(tcrossprod(bank_predict(site_bank(em, s), zbar)$mean,
                                  fit_get(fit, "basis")$Psi))
    band
  }))
  pred <- structure(list(summary = do.call(rbind, rows), type = "experiment", bias = "additive",
                         level = level,
                         seed = seed), class = "wv_prediction")
  dW <- stats::setNames(lapply(sites, function(s) Ms[[s]] - fit_get(fit, "wM")[[s]]), sites)
  list(field = field, pred = pred, draws = fit_draws(fit, sites, dW))
}

check_holdout_experiment <- function(fit, x, call) {
  x <- check_experiments(list(holdout = x), fit_get(fit, "emulators"), list(curves = list()),
                         iu = fit_get(fit, "iu"),
                         call = call)$holdout
  miss <- setdiff(names(x$field$curves), base_sites(fit))
  if (length(miss)) wv_abort(
    "The held-out field data have site{?s} {.val {miss}}, which the fit lacks.", call = call)
  x
}

# The held-out experiment's field data registered as `fit` registered its
# own (validate() with windows: to the model in the experiment's condition,
# see register_experiments()); as given when the fit registered nothing.
holdout_registered <- function(fit, x, call) {
  x <- check_holdout_experiment(fit, x, call)
  reg <- fit_controls(fit)$registration
  if (is.null(reg$windows)) return(x$field)
  ke <- registration_knots(reg$knots_every, fit_get(fit, "basis")$t)
  # as validate() registers: landmarks of every site; a fit made before it
  # did so is registered as it was
  how <- if (identical(attr(fit_get(fit, "field")$warps, "landmark_site"), "all"))
    list(landmark_site = "all")
  do.call(register_experiments, c(list(list(holdout = x), fit_get(fit, "emulators"),
                                       fit_pipeline(fit)$runs,
                                        reg$windows, features = reg$features, knots_every = ke,
                                       quiet = TRUE),
                                   how))$holdout$field
}

# The paired comparison behind the verdict. Each of n_boot resamples takes
# one draw index h (the same for both fits: draw h of before and of after)
# and one resample of the held-out data (the same for both): at each site its
# replicates drawn with replacement (when it has two or more), and within
# each drawn curve a moving-block bootstrap over time of its residuals about
# each model's bias-corrected mean prediction (the same blocks for both),
# blocks of ceiling(sqrt(T)) time points. With few curves the replicates
# alone give few distinct resamples (three of two curves); the blocks within
# each curve give the verdict the power the record holds. The ratio after /
# before of the RMSE, for the model alone and for the bias-corrected
# prediction; its interval holds the central `interval` share of the
# resamples.
holdout_margin <- function(ho, n_boot, seed, interval = 0.9) {
  sites <- Reduce(intersect, list(unique(ho$before$pred$summary$site),
                                  unique(ho$after$pred$summary$site),
                                  names(ho$before$field$curves), names(ho$after$field$curves)))
  n_t <- length(ho$before$field$t)
  block <- ceiling(sqrt(n_t))
  parts <- lapply(ho, function(h) {
    lapply(stats::setNames(sites, sites), function(s) {
      ps <- h$pred$summary[h$pred$summary$site == s, , drop = FALSE]
      list(y = h$field$curves[[s]], model = ps$model, corrected = ps$mean, draws = h$draws[[s]],
           obs = h$field$observed[[s]])
    })
  })
  n_rep <- vapply(sites, function(s) min(nrow(parts$before[[s]]$y), nrow(parts$after[[s]]$y)),
                  integer(1))
  n_draws <- vapply(c("before", "after"), function(m) {
    d <- parts[[m]][[sites[1]]]$draws
    if (is.null(d)) NA_integer_ else nrow(d$corrected)
  }, integer(1))
  H <- if (all(is.na(n_draws))) 0L else min(n_draws, na.rm = TRUE)
  sse <- array(0, c(n_boot, 2L, 2L),
               dimnames = list(NULL, c("before", "after"), c("model", "corrected")))
  with_rng_seed(seed, {
    h <- if (H > 0L) sample.int(H, n_boot, replace = TRUE)
    for (s in sites) {
      R <- n_rep[[s]]
      rows <- if (R >= 2L) matrix(sample.int(R, R * n_boot, replace = TRUE), n_boot) else
        matrix(1L, n_boot, 1L)
      time <- lapply(seq_len(R), function(j) t(replicate(n_boot, moving_blocks(n_t, block))))
      for (m in c("before", "after")) {
        p <- parts[[m]][[s]]
        for (kind in c("model", "corrected")) {
          sse[, m, kind] <- sse[, m, kind] + resampled_sse(p$y[seq_len(R), , drop = FALSE],
                                                           p[[kind]], p$corrected,
                                                           rows, time, p$draws, kind, h,
                                                           if (!is.null(p$obs)) p$obs[seq_len(R), , drop = FALSE])
        }
      }
      rm(time)
    }
  })
  ratio <- sqrt(sse[, "after", ] / sse[, "before", ])
  a <- (1 - interval) / 2
  q <- apply(ratio, 2L, stats::quantile, probs = c(a, 1 - a), names = FALSE)
  n_blocks <- sum(n_rep) * floor(n_t / block)
  structure(data.frame(prediction = c("model", "corrected"), lower = q[1, ], upper = q[2, ],
                       stringsAsFactors = FALSE),
            resampling = if (all(n_rep >= 2L)) "replicates" else
              if (all(n_rep < 2L)) "moving_block" else "mixed",
            block = block, n_blocks = n_blocks, n_curves = sum(n_rep), n_boot = n_boot, n_draws = H,
            interval = interval)
}

# Indices of a moving-block bootstrap of n points in blocks of length L.
moving_blocks <- function(n, L) {
  starts <- sample.int(n - L + 1L, ceiling(n / L), replace = TRUE)
  as.vector(outer(seq_len(L) - 1L, starts, `+`))[seq_len(n)]
}

# Sum of squared errors of the prediction `center` plus draw h's deviation
# (Psi d_h, or the curve deviation d_h when Psi is NULL) against each
# resample of the data: for each of the R curve slots j, the replicate
# rows[, j] (n_boot x R) rebuilt as `corrected` plus its residuals about
# `corrected` taken at the block-resampled times time[[j]] (n_boot x T);
# `obs` (R x T) the points measured (curves of their own extent), the others
# left out.
resampled_sse <- function(y, center, corrected, rows, time, d, kind, h, obs = NULL) {
  e <- sweep(y, 2L, corrected)
  n_boot <- nrow(rows)
  n_t <- ncol(y)
  D <- if (!is.null(d) && !is.null(d[[kind]]) && !is.null(h)) d[[kind]][h, , drop = FALSE]
  dev <- if (is.null(D)) 0 else if (is.null(d$Psi)) D else tcrossprod(D, d$Psi)
  shift <- matrix(corrected - center, n_boot, n_t, byrow = TRUE) - dev
  out <- numeric(n_boot)
  for (j in seq_len(ncol(rows))) {
    at <- cbind(rep(rows[, j], times = n_t), as.vector(time[[j]]))
    E <- matrix(e[at], n_boot)
    out <- out + if (is.null(obs)) rowSums((E + shift)^2) else rowSums((E + shift)^2 * matrix(obs[at], n_boot))
  }
  out
}
