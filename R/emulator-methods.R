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
  for (line in emulator_calibration_text(x)) cli::cat_line(line)
  vc <- x$variance_check
  if (!is.null(vc)) {
    up <- vc[vc$scale > 1, , drop = FALSE]
    if (nrow(up)) {
      cli::cli_text("Predictive variances widened at {nrow(up)} of {nrow(vc)} site and level group{?s} from {x$variance_runs} held-out run{?s}, by a factor of up to {signif(max(up$scale), 3)}.")
    } else {
      cli::cli_text(
        "Predictive variances checked at {x$variance_runs} held-out run{?s}: none widened.")
    }
  }
  invisible(x)
}

#' Summary of GASP emulators
#'
#' Leave-one-out quality of the emulators by site and resolution level and,
#' given model runs that the emulators were not fitted to, their quality there.
#'
#' Leave-one-out residuals are computed at the design points, where a
#' space-filling design leaves the largest gaps when a point is removed; they
#' can look well calibrated while the emulators' errors at other inputs (the
#' interior of the ranges, where the posterior of the inputs usually lies)
#' exceed their predictive variances. A few runs at inputs drawn from the
#' prior (or near the calibrated inputs) in `new_runs` show it: a root mean
#' square of the studentised errors well above 1 there means that the
#' posterior of the inputs will be too narrow and off; add runs to the design,
#' or widen the predictive variances by level with [rescale_emulators()].
#'
#' @inheritParams rescale_emulators
#' @param object A `wv_emulators` object.
#' @param ... Unused.
#' @return A `summary_wv_emulators` object: a list with `engine`, `n_runs`,
#'   `inputs`, `n_new` and `by_level`, a data frame with, per site and level,
#'   the number of coefficients, the median log-likelihood, the root mean
#'   square of the studentised LOO residuals (about 1 for a well-calibrated
#'   emulator), the share of them beyond 3 in absolute value, the counts of
#'   emulators with a nugget and of flat emulators and, with `new_runs`, the
#'   root mean square of the studentised errors at the new runs
#'   (`heldout_rms`) and their share beyond 3 (`heldout_beyond_3`).
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' design <- data.frame(a = seq(0, 1, length.out = 8), b = c(3, 7, 1, 5, 8, 2, 6, 4) / 8)
#' curves <- t(apply(design, 1, function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t))
#' runs <- model_runs(design, curves, t)
#' em <- fit_emulators(runs, wavelet_basis(runs))
#' summary(em)
summary.wv_emulators <- function(object, new_runs = NULL, ...) {
  p <- object$params
  held <- if (is.null(new_runs)) NULL else heldout_residuals(object, new_runs)
  key <- paste(p$site, p$level, sep = "\r")
  groups <- unique(key)
  ls <- loo_stats_by_level(object)
  by_level <- do.call(rbind, lapply(seq_along(groups), function(i) {
    rows <- key == groups[i]
    data.frame(site = ls$site[i], level = ls$level[i], n = sum(rows),
               median_loglik = if (any(is.finite(p$loglik[rows])))
                 stats::median(p$loglik[rows], na.rm = TRUE) else NA_real_,
               loo_rms = sqrt(ls$mean_square[i]), loo_beyond_3 = ls$beyond_3[i],
               nugget = sum(p$nugget[rows] > 0 & is.finite(p$loglik[rows])),
               flat = sum(!is.finite(p$loglik[rows])), stringsAsFactors = FALSE)
  }))
  if (!is.null(held)) {
    hs <- residual_stats_by_level(p, held)
    by_level$heldout_rms <- sqrt(hs$mean_square)
    by_level$heldout_beyond_3 <- hs$beyond_3
  }
  rownames(by_level) <- NULL
  structure(list(engine = object$engine, n_runs = nrow(object$design), inputs = object$inputs,
                 n_new = if (is.null(new_runs)) 0L else nrow(new_runs$design), by_level = by_level),
            class = "summary_wv_emulators")
}

# Studentised errors (w - m) / sqrt(V) of the emulators at held-out runs: one
# row per site, coefficient and run, like loo_residuals(). Flat emulators give NA.
heldout_residuals <- function(object, new_runs, call = rlang::caller_env()) {
  if (!inherits(new_runs, "wv_runs")) {
    wv_abort("{.arg new_runs} must be a {.cls wv_runs} object; it is {.obj_type_friendly {new_runs}}.",
             call = call)
  }
  sites <- names(object$banks)
  miss <- setdiff(sites, names(new_runs$curves))
  if (length(miss)) {
    wv_abort("{.arg new_runs} has no curves for the emulated site{?s} {.val {miss}}.", call = call)
  }
  check_same_grid(object$basis$t, new_runs$t, "emulators", "new_runs", call = call)
  Z <- emulator_newdata(object, new_runs$design, arg = "new_runs$design", call = call)
  W <- wavelet_coef(object$basis, new_runs)
  do.call(rbind, lapply(sites, function(s) {
    pr <- gasp_bank_predict_cpp(object$banks[[s]], Z)
    prm <- object$params[object$params$site == s, , drop = FALSE]
    flat <- !is.finite(prm$loglik)
    res <- (W[[s]] - pr$mean) / sqrt(pr$var)
    res[, flat] <- NA_real_
    k <- nrow(Z)
    data.frame(site = s, index = rep(prm$index, each = k), level = rep(prm$level, each = k),
               run = rep(seq_len(k), times = nrow(prm)), residual = as.vector(res),
               stringsAsFactors = FALSE)
  }))
}

#' @export
print.summary_wv_emulators <- function(x, ...) {
  cli::cli_text("GASP emulators ({x$engine} engine), {x$n_runs} runs, {length(x$inputs)} inputs.")
  n_new <- x$n_new %||% 0L
  if (n_new > 0L) {
    cli::cli_text(
      "Studentised residuals by site and level: leave-one-out, and at {n_new} held-out run{?s}:")
  } else {
    cli::cli_text("Leave-one-out studentised residuals by site and level:")
  }
  b <- x$by_level
  b$median_loglik <- signif(b$median_loglik, 4)
  rest <- intersect(c("loo_rms", "loo_beyond_3", "heldout_rms", "heldout_beyond_3"), names(b))
  b[rest] <- lapply(b[rest], signif, digits = 3)
  print(b, row.names = FALSE)
  if (n_new > 0L) {
    worst <- suppressWarnings(max(b$heldout_rms, na.rm = TRUE))
    if (is.finite(worst) && worst > 1.5) {
      cli::cli_alert_warning(paste0(
        "At the held-out runs the errors exceed the predictive standard deviations ",
        "(RMS up to {worst}); the posterior of the inputs would be too narrow. Add runs to the design, ",
        "or widen the variances with {.fn rescale_emulators}."))
    }
  }
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
#' @param ... Must be empty: an unknown argument is an error.
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
  check_dots_none(...)
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

emulator_newdata <- function(object, newdata, arg = "newdata", call = rlang::caller_env()) {
  if (is.null(dim(newdata)) && is.numeric(newdata)) {
    newdata <- matrix(newdata, nrow = 1L, dimnames = list(NULL, names(newdata)))
  }
  if (!is.data.frame(newdata) && !is.matrix(newdata)) {
    wv_abort("{.arg {arg}} must be a data frame or matrix with one column per input.", call = call)
  }
  nm <- colnames(newdata)
  if (!is.null(nm)) {
    miss <- setdiff(object$inputs, nm)
    if (length(miss)) {
      wv_abort("{.arg {arg}} lacks input{?s} {.val {miss}}.", call = call)
    }
    newdata <- newdata[, object$inputs, drop = FALSE]
  } else if (ncol(newdata) != length(object$inputs)) {
    wv_abort("{.arg {arg}} has {ncol(newdata)} columns; the emulators have {length(object$inputs)} inputs.",
             call = call)
  }
  Z <- as.matrix(newdata)
  storage.mode(Z) <- "double"
  if (any(!is.finite(Z))) wv_abort("{.arg {arg}} must be finite.", call = call)
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
#' @inheritParams calibrate
#' @param z The new input point: a named numeric vector or one-row data frame.
#' @param w Its coefficient values: for one site a numeric vector (one value
#'   per coefficient), otherwise a named list by site.
#' @param ... Must be empty. `object`, the former name of `emulators`, is
#'   still accepted, with a deprecation warning.
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
augment_emulators <- function(emulators, z, w, ...) {
  if (...length()) {
    call <- renamed_arg(sys.call(), "object", "emulators", "augment_emulators")
    if (!is.null(call)) return(eval(call, parent.frame()))
    check_dots_none(...)
  }
  check_class(emulators, "wv_emulators")
  Z <- emulator_newdata(emulators, z, arg = "z")
  if (nrow(Z) != 1L) wv_abort("{.arg z} must be a single point.")
  sites <- names(emulators$banks)
  if (!is.list(w)) {
    if (length(sites) != 1L) wv_abort("{.arg w} must be a named list by site: {.val {sites}}.")
    w <- stats::setNames(list(w), sites)
  }
  miss <- setdiff(sites, names(w))
  if (length(miss)) wv_abort("{.arg w} lacks site{?s} {.val {miss}}.")
  for (s in sites) {
    v <- as.numeric(w[[s]])
    n <- length(emulators$banks[[s]]$mu)
    if (length(v) != n || any(!is.finite(v))) {
      wv_abort("{.arg w} for site {.val {s}} must hold {n} finite values, one per coefficient; it has {length(v)}.")
    }
    emulators$banks[[s]] <- bank_augment(emulators$banks[[s]], Z[1, ], v)
  }
  emulators$design <- rbind(emulators$design, Z)
  emulators
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
  type <- check_choice(type)
  p <- object$params
  if (!is.null(site)) p <- p[p$site %in% site, , drop = FALSE]
  # flat emulators (every beta zero, no likelihood) carry no parameters to show
  betas <- as.matrix(p[paste0("beta_", object$inputs)])
  p <- p[is.finite(p$loglik) | rowSums(betas) > 0, , drop = FALSE]
  if (type == "parameters") {
    long <- do.call(rbind, lapply(object$inputs, function(v) {
      data.frame(site = p$site, index = p$index, input = v, beta = p[[paste0("beta_", v)]],
                 alpha = p[[paste0("alpha_", v)]], stringsAsFactors = FALSE)
    }))
    long$input <- factor(long$input, levels = object$inputs)
    long$beta <- pmax(long$beta, 1e-6)
    return(ggplot2::ggplot(long,
                           ggplot2::aes(x = .data$beta, y = .data$alpha, colour = .data$site)) +
      ggplot2::geom_point(alpha = 0.6, size = 1) +
      ggplot2::scale_x_log10() +
      ggplot2::facet_wrap(~input) +
      ggplot2::labs(x = expression(beta ~ "(unit-cube scale)"), y = expression(alpha),
                    colour = "site",
                    title = "GASP correlation parameters by input") +
      ggplot2::theme_bw())
  }
  loo <- loo_residuals(object)
  if (!is.null(site)) loo <- loo[loo$site %in% site, , drop = FALSE]
  loo <- loo[is.finite(loo$residual), , drop = FALSE]
  ggplot2::ggplot(loo,
                  ggplot2::aes(x = factor(.data$level), y = .data$residual, colour = .data$site)) +
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

# One line on the emulators' calibration: the mean squares of the
# leave-one-out studentised residuals by level (1 for honest emulators) and,
# after rescale_emulators(), those at its held-out runs.
emulator_calibration_text <- function(em) {
  lc <- em$loo_check
  out <- character()
  if (!is.null(lc) && nrow(lc)) {
    out <- c(paste0("Leave-one-out studentised errors, mean square by level (1 is honest): ",
                    paste(sprintf("%d: %.2f", lc$level, lc$mean_square), collapse = ", "),
                    sprintf("; 90%% intervals cover %.0f%%.",
                            100 * stats::weighted.mean(lc$cover90, lc$n))),
             paste("These are taken at the design points; errors between them can be larger:",
                   "check held-out runs with `summary(emulators, new_runs = )`."))
  }
  vc <- em$variance_check
  if (!is.null(vc) && nrow(vc)) {
    ok <- vc$n_errors > 0 & is.finite(vc$rms_before)
    ms <- tapply(vc$rms_before[ok]^2 * vc$n_errors[ok], vc$level[ok], sum) /
      tapply(vc$n_errors[ok], vc$level[ok], sum)
    if (length(ms)) {
      out <- c(out, paste0("At ", em$variance_runs, " held-out runs, before rescaling, by level: ",
                           paste(sprintf("%s: %.2f", names(ms), ms), collapse = ", "), "."))
    }
  }
  out
}
