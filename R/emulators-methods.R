# Methods of wv_emulators: print, summary, prediction (eq. 11), the eq. 26
# augmentation, leave-one-out residuals and plots.

#' @export
print.wv_emulators <- function(x, ...) {
  p <- x$params
  n_site <- length(x$banks)
  cli::cli_text("{.cls wv_emulators}: {nrow(p)} GASP emulator{?s} ({x$engine} engine), {length(unique(p$index))} coefficient{?s} at {n_site} site{?s}.")
  cli::cli_text("{nrow(x$design)} runs of {length(x$inputs)} input{?s}: {.val {x$inputs}}.")
  ll <- p$loglik[is.finite(p$loglik)]
  if (length(ll)) {
    cli::cli_text("Maximised log-likelihood: median {signif(stats::median(ll), 4)}, range [{signif(min(ll), 4)}, {signif(max(ll), 4)}].")
  }
  n_nug <- sum(p$nugget > 0 & is.finite(p$loglik))
  n_flat <- sum(!is.finite(p$loglik))
  if (n_nug) cli::cli_text("{n_nug} emulator{?s} with a nugget.")
  if (n_flat) cli::cli_text("{n_flat} flat emulator{?s} (constant coefficient).")
  invisible(x)
}

#' Summary of GASP emulators
#'
#' Leave-one-out quality of the emulators by site and resolution level.
#'
#' @param object A `wv_emulators` object.
#' @param ... Unused.
#' @return A `summary_wv_emulators` object: a list with `engine`, `n_runs`,
#'   `inputs` and `by_level`, a data frame with, per site and level, the
#'   number of coefficients, the median log-likelihood, the root mean square of
#'   the studentised LOO residuals (about 1 for a well-calibrated emulator),
#'   the share of them beyond 3 in absolute value, and the counts of emulators
#'   with a nugget and of flat emulators.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' design <- data.frame(a = seq(0, 1, length.out = 8), b = c(3, 7, 1, 5, 8, 2, 6, 4) / 8)
#' curves <- t(apply(design, 1, function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t))
#' runs <- model_runs(design, curves, t)
#' em <- fit_emulators(runs, wavelet_basis(runs))
#' summary(em)
summary.wv_emulators <- function(object, ...) {
  p <- object$params
  loo <- loo_residuals(object)
  key <- paste(p$site, p$level, sep = "\r")
  lkey <- paste(loo$site, loo$level, sep = "\r")
  groups <- unique(key)
  by_level <- do.call(rbind, lapply(groups, function(g) {
    rows <- key == g
    r <- loo$residual[lkey == g]
    r <- r[is.finite(r)]
    data.frame(site = p$site[rows][1], level = p$level[rows][1], n = sum(rows),
               median_loglik = if (any(is.finite(p$loglik[rows]))) stats::median(p$loglik[rows], na.rm = TRUE) else NA_real_,
               loo_rms = if (length(r)) sqrt(mean(r^2)) else NA_real_,
               loo_beyond_3 = if (length(r)) mean(abs(r) > 3) else NA_real_,
               nugget = sum(p$nugget[rows] > 0 & is.finite(p$loglik[rows])),
               flat = sum(!is.finite(p$loglik[rows])), stringsAsFactors = FALSE)
  }))
  rownames(by_level) <- NULL
  structure(list(engine = object$engine, n_runs = nrow(object$design), inputs = object$inputs,
                 by_level = by_level), class = "summary_wv_emulators")
}

#' @export
print.summary_wv_emulators <- function(x, ...) {
  cli::cli_text("GASP emulators ({x$engine} engine), {x$n_runs} runs, {length(x$inputs)} inputs.")
  cli::cli_text("Leave-one-out studentised residuals by site and level:")
  b <- x$by_level
  b$median_loglik <- signif(b$median_loglik, 4)
  b$loo_rms <- signif(b$loo_rms, 3)
  b$loo_beyond_3 <- signif(b$loo_beyond_3, 3)
  print(b, row.names = FALSE)
  invisible(x)
}

#' Predictions of GASP emulators
#'
#' Predictive means and variances (report eq. 11) of every coefficient at new
#' inputs.
#'
#' @param object A `wv_emulators` object.
#' @param newdata A data frame or matrix with one column per input (matched by
#'   name when named) and one row per point.
#' @param site Site name; `NULL` for every site.
#' @param ... Unused.
#' @return For one `site`: a list with `mean` and `var`, N x n matrices (rows:
#'   points, columns: coefficients, named by their index). For `site = NULL`:
#'   a named list of such lists, one per site.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' design <- data.frame(a = seq(0, 1, length.out = 8), b = c(3, 7, 1, 5, 8, 2, 6, 4) / 8)
#' curves <- t(apply(design, 1, function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t))
#' runs <- model_runs(design, curves, t)
#' em <- fit_emulators(runs, wavelet_basis(runs))
#' pr <- predict(em, data.frame(a = c(0.2, 0.7), b = 0.5), site = "site1")
#' dim(pr$mean)
predict.wv_emulators <- function(object, newdata, site = NULL, ...) {
  Z <- emulator_newdata(object, newdata)
  sites <- site %||% names(object$banks)
  miss <- setdiff(sites, names(object$banks))
  if (length(miss)) {
    wv_abort("No emulators for site{?s} {.val {miss}}; sites are {.val {names(object$banks)}}.")
  }
  out <- lapply(sites, function(s) {
    pr <- gasp_bank_predict_cpp(object$banks[[s]], Z)
    cn <- as.character(object$params$index[object$params$site == s])
    colnames(pr$mean) <- colnames(pr$var) <- cn
    pr
  })
  names(out) <- sites
  if (!is.null(site) && length(site) == 1L) out[[1]] else out
}

emulator_newdata <- function(object, newdata, call = rlang::caller_env()) {
  if (is.null(dim(newdata)) && is.numeric(newdata)) {
    newdata <- matrix(newdata, nrow = 1L, dimnames = list(NULL, names(newdata)))
  }
  if (!is.data.frame(newdata) && !is.matrix(newdata)) {
    wv_abort("{.arg newdata} must be a data frame or matrix with one column per input.", call = call)
  }
  nm <- colnames(newdata)
  if (!is.null(nm)) {
    miss <- setdiff(object$inputs, nm)
    if (length(miss)) {
      wv_abort("{.arg newdata} lacks input{?s} {.val {miss}}.", call = call)
    }
    newdata <- newdata[, object$inputs, drop = FALSE]
  } else if (ncol(newdata) != length(object$inputs)) {
    wv_abort("{.arg newdata} has {ncol(newdata)} columns; the emulators have {length(object$inputs)} inputs.",
             call = call)
  }
  Z <- as.matrix(newdata)
  storage.mode(Z) <- "double"
  if (any(!is.finite(Z))) wv_abort("{.arg newdata} must be finite.", call = call)
  Z
}

#' Add one run to GASP emulators without refitting
#'
#' The predictor of report eq. (26): the design is augmented by one point
#' `z` with known coefficient values `w` (for instance a draw of the model
#' coefficients at the tested system's inputs), keeping every hyperparameter
#' (`beta`, `alpha`, `mu`, `lambda`, nugget) fixed. The Cholesky factors gain
#' one row and the weights are updated by the block-inverse formula, at
#' O(K^2) cost per coefficient.
#'
#' @param object A `wv_emulators` object.
#' @param z The new input point: a named numeric vector or one-row data frame.
#' @param w Its coefficient values: for one site a numeric vector (one value
#'   per coefficient), otherwise a named list by site.
#' @return A `wv_emulators` object with the augmented design and banks
#'   (`params` unchanged).
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' design <- data.frame(a = seq(0, 1, length.out = 8), b = c(3, 7, 1, 5, 8, 2, 6, 4) / 8)
#' curves <- t(apply(design, 1, function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t))
#' runs <- model_runs(design, curves, t)
#' em <- fit_emulators(runs, wavelet_basis(runs))
#' z <- c(a = 0.5, b = 0.5)
#' em2 <- augment_emulators(em, z, predict(em, z, site = "site1")$mean[1, ])
#' nrow(em2$design)
augment_emulators <- function(object, z, w) {
  check_class(object, "wv_emulators")
  Z <- emulator_newdata(object, z)
  if (nrow(Z) != 1L) wv_abort("{.arg z} must be a single point.")
  sites <- names(object$banks)
  if (!is.list(w)) {
    if (length(sites) != 1L) wv_abort("{.arg w} must be a named list by site: {.val {sites}}.")
    w <- stats::setNames(list(w), sites)
  }
  miss <- setdiff(sites, names(w))
  if (length(miss)) wv_abort("{.arg w} lacks site{?s} {.val {miss}}.")
  for (s in sites) {
    v <- as.numeric(w[[s]])
    n <- length(object$banks[[s]]$mu)
    if (length(v) != n || any(!is.finite(v))) {
      wv_abort("{.arg w} for site {.val {s}} must hold {n} finite values, one per coefficient; it has {length(v)}.")
    }
    object$banks[[s]] <- bank_augment(object$banks[[s]], Z[1, ], v)
  }
  object$design <- rbind(object$design, Z)
  object
}

# eq. (26) on one bank (list form), in C++.
bank_augment <- function(bank, z, w) {
  out <- gasp_bank_augment_cpp(bank, as.numeric(z), as.numeric(w))
  out$y <- rbind(bank$y, w)
  rownames(out$y) <- NULL
  colnames(out$y) <- colnames(bank$y)
  out$loglik <- bank$loglik
  out
}

#' Leave-one-out residuals of GASP emulators
#'
#' Studentised leave-one-out cross-validation residuals of every emulator in
#' closed form, with the hyperparameters and `mu` fixed at their estimates:
#' for run k, the prediction error is `e_k = [R^-1 (y - mu)]_k / [R^-1]_kk`
#' and its variance `1 / (lambda [R^-1]_kk)`.
#'
#' @param object A `wv_emulators` object.
#' @return A data frame with one row per site, coefficient and run: `site`,
#'   `index`, `level`, `run`, `observed`, `predicted` (LOO mean), `sd` (LOO
#'   standard deviation) and `residual` (`(observed - predicted) / sd`). Flat
#'   emulators give `NA` residuals.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' design <- data.frame(a = seq(0, 1, length.out = 8), b = c(3, 7, 1, 5, 8, 2, 6, 4) / 8)
#' curves <- t(apply(design, 1, function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t))
#' runs <- model_runs(design, curves, t)
#' em <- fit_emulators(runs, wavelet_basis(runs))
#' head(loo_residuals(em))
loo_residuals <- function(object) {
  check_class(object, "wv_emulators")
  out <- lapply(names(object$banks), function(s) {
    b <- object$banks[[s]]
    p <- object$params[object$params$site == s, , drop = FALSE]
    k <- nrow(b$X)
    n <- length(b$mu)
    res <- lapply(seq_len(n), function(i) {
      Ri_diag <- colSums(forwardsolve(b$chol[, , i], diag(k))^2)
      e <- b$weights[, i] / Ri_diag
      sd <- sqrt(1 / (b$lambda[i] * Ri_diag))
      flat <- !is.finite(p$loglik[i])
      data.frame(site = s, index = p$index[i], level = p$level[i], run = seq_len(k),
                 observed = b$y[, i], predicted = b$y[, i] - e, sd = sd,
                 residual = if (flat) NA_real_ else e / sd, stringsAsFactors = FALSE)
    })
    do.call(rbind, res)
  })
  out <- do.call(rbind, out)
  rownames(out) <- NULL
  out
}

#' Plot GASP emulators
#'
#' `type = "parameters"` draws the report's Figure 4: `(beta, alpha)` of every
#' coefficient, one panel per input (beta on a log scale). `type = "loo"`
#' draws the studentised leave-one-out residuals by resolution level, with
#' reference lines at -2 and 2.
#'
#' @param object A `wv_emulators` object.
#' @param type `"parameters"` or `"loo"`.
#' @param site Site to show; `NULL` for every site (coloured by site).
#' @param x A `wv_emulators` object (for `plot()`).
#' @param ... Passed to `autoplot()` by `plot()`.
#' @return A ggplot object.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' design <- data.frame(a = seq(0, 1, length.out = 8), b = c(3, 7, 1, 5, 8, 2, 6, 4) / 8)
#' curves <- t(apply(design, 1, function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t))
#' runs <- model_runs(design, curves, t)
#' em <- fit_emulators(runs, wavelet_basis(runs))
#' autoplot(em)
#' autoplot(em, type = "loo")
autoplot.wv_emulators <- function(object, type = c("parameters", "loo"), site = NULL, ...) {
  type <- rlang::arg_match(type)
  p <- object$params
  if (!is.null(site)) p <- p[p$site %in% site, , drop = FALSE]
  p <- p[is.finite(p$loglik), , drop = FALSE]
  if (type == "parameters") {
    long <- do.call(rbind, lapply(object$inputs, function(v) {
      data.frame(site = p$site, index = p$index, input = v, beta = p[[paste0("beta_", v)]],
                 alpha = p[[paste0("alpha_", v)]], stringsAsFactors = FALSE)
    }))
    long$input <- factor(long$input, levels = object$inputs)
    long$beta <- pmax(long$beta, 1e-6)
    return(ggplot2::ggplot(long, ggplot2::aes(x = .data$beta, y = .data$alpha, colour = .data$site)) +
      ggplot2::geom_point(alpha = 0.6, size = 1) +
      ggplot2::scale_x_log10() +
      ggplot2::facet_wrap(~input) +
      ggplot2::labs(x = expression(beta ~ "(unit-cube scale)"), y = expression(alpha), colour = "site",
                    title = "GASP correlation parameters by input") +
      ggplot2::theme_bw())
  }
  loo <- loo_residuals(object)
  if (!is.null(site)) loo <- loo[loo$site %in% site, , drop = FALSE]
  loo <- loo[is.finite(loo$residual), , drop = FALSE]
  ggplot2::ggplot(loo, ggplot2::aes(x = factor(.data$level), y = .data$residual, colour = .data$site)) +
    ggplot2::geom_hline(yintercept = c(-2, 2), linetype = 2, colour = "grey40") +
    ggplot2::geom_jitter(width = 0.2, height = 0, alpha = 0.4, size = 0.8) +
    ggplot2::labs(x = "resolution level", y = "studentised LOO residual", colour = "site",
                  title = "Leave-one-out residuals of the emulators") +
    ggplot2::theme_bw()
}

#' @rdname autoplot.wv_emulators
#' @export
plot.wv_emulators <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}
