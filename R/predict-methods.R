# as.data.frame, print, summary, autoplot and plot methods of the
# wv_prediction of predict() on a fit.

#' @export
as.data.frame.wv_prediction <- function(x, ...) {
  x$summary
}

#' @export
print.wv_prediction <- function(x, ...) {
  labels <- c(reality = "bias-corrected prediction of reality", field_run = "a new field run",
              added_load = "the same vehicle with an added load",
              new_vehicle = "a new vehicle of the same type",
              new_nominal = "a new vehicle with new nominal inputs",
              new_condition = "the system at a new condition",
              experiment = "a held-out experiment")
  cli::cat_line(sprintf("<wv_prediction> %s, %s bias, %g%% bands", labels[[x$type]], x$bias,
                        100 * x$level))
  if (identical(x$type, "new_condition")) {
    cli::cat_line(sprintf("  condition %s: %s",
                          paste(sprintf("%s = %g", names(x$condition), x$condition),
                                collapse = ", "),
                          switch(x$bias_from,
                                 tested = sprintf("tested (experiment %s), its own draws",
                                                  x$tested),
                                 shared = "untested, the bias shared by the experiments",
                                 pooled = "untested, the tested conditions' biases pooled")))
  }
  s <- x$summary
  for (site in unique(s$site)) {
    d <- s[s$site == site, ]
    cli::cat_line(sprintf("  %s: %d time points, median pointwise band width %.3g, whole-curve band width %.3g",
                          site, nrow(d), stats::median(d$upper - d$lower),
                          stats::median(d$upper_curve - d$lower_curve)))
  }
  if (isTRUE(x$residual)) {
    cli::cat_line("  includes the field detail outside the retained basis (residual = TRUE)")
  }
  if (sum(x$n_guarded) > 0) {
    cli::cat_line(sprintf("  multiplicative bias replaced by additive at %d draw-time points near zero model output",
                          sum(x$n_guarded)))
  }
  invisible(x)
}

#' @export
summary.wv_prediction <- function(object, ...) {
  s <- object$summary
  structure(list(
    type = object$type, bias = object$bias, level = object$level,
    width = do.call(rbind, lapply(split(s, s$site), function(d) {
      data.frame(site = d$site[1], median_width = stats::median(d$upper - d$lower),
                 median_curve_width = stats::median(d$upper_curve - d$lower_curve),
                 max_abs_correction = max(abs(d$mean - d$model)))
    }))
  ), class = "summary_wv_prediction")
}

#' @export
print.summary_wv_prediction <- function(x, ...) {
  cli::cat_line(sprintf("Prediction (%s, %s bias, %g%% bands)", x$type, x$bias, 100 * x$level))
  print(x$width, row.names = FALSE, digits = 3)
  invisible(x)
}

#' Plot a prediction
#'
#' Bias-corrected prediction (black) with its tolerance band (dashed), the
#' pure-model prediction (grey), field runs (orange) and, for new nominals, the
#' model runs (light grey): the report's Figures 7 to 11.
#'
#' @inheritParams autoplot.wv_fit
#' @param object A `wv_prediction`.
#' @param field Field runs to overlay (default: those kept in the prediction).
#' @param band `"pointwise"` or `"curve"` (the whole-curve band).
#' @param ... Unused.
#' @return A ggplot object.
#' @export
autoplot.wv_prediction <- function(object, field = NULL, windows = NULL,
                                   band = c("pointwise", "curve"), ...) {
  band <- check_choice(band)
  s <- object$summary
  if (band == "curve") {
    s$lower <- s$lower_curve
    s$upper <- s$upper_curve
  }
  field <- field %||% object$field
  win <- function(d) with_windows(d, windows, whole = "whole record")
  s <- win(s)
  p <- ggplot2::ggplot(s, ggplot2::aes(.data$t))
  if (!is.null(object$runs)) {
    rr <- do.call(rbind,
                  lapply(unique(s$site),
                         function(si) curves_long(object$runs$curves[[si]], object$runs$t, si)))
    p <- p + ggplot2::geom_line(data = win(rr), ggplot2::aes(.data$t, .data$y, group = .data$run),
                                colour = "grey85", linewidth = 0.2)
  }
  if (!is.null(field)) {
    ff <- do.call(rbind, lapply(intersect(unique(s$site), names(field$curves)), function(si) {
      curves_long(field$curves[[si]], field$t, si, "replicate")
    }))
    p <- p + ggplot2::geom_line(data = win(ff),
                                ggplot2::aes(.data$t, .data$y, group = .data$replicate),
                                colour = "#E69F00", linewidth = 0.3)
  }
  p + ggplot2::geom_line(ggplot2::aes(y = .data$model), colour = "grey50", linewidth = 0.4) +
    ggplot2::geom_line(ggplot2::aes(y = .data$lower), linetype = 2, linewidth = 0.3) +
    ggplot2::geom_line(ggplot2::aes(y = .data$upper), linetype = 2, linewidth = 0.3) +
    ggplot2::geom_line(ggplot2::aes(y = .data$mean), linewidth = 0.4) +
    ggplot2::facet_grid(site ~ window, scales = "free") +
    ggplot2::labs(x = "time", y = "output",
                  title = sprintf("Prediction: %s (%s bias, %g%% band)",
                                  gsub("_", " ", object$type),
                                  object$bias, 100 * object$level)) +
    ggplot2::theme_bw()
}

#' @export
plot.wv_prediction <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}
