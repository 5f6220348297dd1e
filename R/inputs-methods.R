# print, summary, as.data.frame, autoplot and plot methods of the I/U map
# (iu_map()).

#' @export
print.wv_iu <- function(x, ...) {
  x <- iu_upgrade(x)
  n_cal <- sum(x$type == "calibration")
  n_var <- sum(x$type == "variation")
  n_cond <- sum(x$type == "condition")
  cli::cat_line(sprintf("<wv_iu> %d input%s: %d calibration, %d with manufacturing variation%s",
                        nrow(x), if (nrow(x) == 1) "" else "s", n_cal, n_var,
                        if (n_cond) sprintf(", %d condition%s", n_cond,
                                            if (n_cond == 1) "" else "s") else ""))
  df <- data.frame(name = x$name, type = x$type,
                   nominal = format(signif(x$nominal, 4), trim = TRUE),
                   `prior on [lower, upper]` = prior_labels(x, range = FALSE), check.names = FALSE,
                   stringsAsFactors = FALSE)
  print(df, row.names = FALSE, right = FALSE)
  for (line in joint_prior_text(x)) cli::cat_line(line)
  if (n_cond) {
    cli::cat_line(sprintf("Condition%s, known and set by each experiment (nominal: the base experiment's): %s",
                          if (n_cond == 1) "" else "s",
                          paste(x$name[x$type == "condition"], collapse = ", ")))
  }
  invisible(x)
}

#' @export
summary.wv_iu <- function(object, ...) {
  structure(list(
    n = nrow(object),
    calibration = object$name[object$type == "calibration"],
    variation = object$name[object$type == "variation"],
    condition = object$name[object$type == "condition"],
    width = stats::setNames(object$upper - object$lower, object$name)
  ), class = "summary_wv_iu")
}

#' @export
print.summary_wv_iu <- function(x, ...) {
  cli::cat_line("I/U map of ", x$n, " inputs")
  cli::cat_line("  calibration: ",
                if (length(x$calibration)) paste(x$calibration, collapse = ", ") else "none")
  cli::cat_line("  variation:   ",
                if (length(x$variation)) paste(x$variation, collapse = ", ") else "none")
  if (length(x$condition)) cli::cat_line("  condition:   ", paste(x$condition, collapse = ", "))
  invisible(x)
}

#' @export
as.data.frame.wv_iu <- function(x, ...) {
  as.data.frame(unclass(x), stringsAsFactors = FALSE)
}

#' Prior density of each input of an I/U map
#'
#' @param object A `wv_iu` object.
#' @param ... Unused.
#' @return A ggplot of the prior density of every input on its range.
#' @export
#' @examples
#' iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), c(0, 0), c(1, 1))
#' autoplot(iu)
autoplot.wv_iu <- function(object, ...) {
  object <- object[object$type != "condition", , drop = FALSE]
  grid <- do.call(rbind, lapply(seq_len(nrow(object)), function(k) {
    v <- seq(object$lower[k], object$upper[k], length.out = 201)
    data.frame(input = object$name[k], value = v, density = iu_prior_density(object, k, v))
  }))
  grid$input <- factor(grid$input, levels = object$name)
  ggplot2::ggplot(grid, ggplot2::aes(.data$value, .data$density)) +
    ggplot2::geom_line() +
    ggplot2::facet_wrap(~input, scales = "free") +
    ggplot2::labs(x = "input value", y = "prior density", title = "Prior of each input") +
    ggplot2::theme_bw()
}

#' @export
plot.wv_iu <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}
