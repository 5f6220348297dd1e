# Small plotting helpers shared by the autoplot() methods of several classes.

# Rows of a long data frame (column t) within each of `windows` (a list of
# c(from, to)), labelled by a factor `window`; without windows, `d` itself,
# labelled `whole` when that is given.
with_windows <- function(d, windows, whole = NULL) {
  if (is.null(d)) return(d)
  if (is.null(windows)) {
    if (!is.null(whole)) d$window <- whole
    return(d)
  }
  ok <- is.list(windows) && all(vapply(windows, function(w) is.numeric(w) && length(w) == 2L &&
                                       w[1] < w[2],
                                       logical(1)))
  if (!ok) wv_abort("{.arg windows} must be a list of increasing pairs of times, e.g. {.code list(c(6, 11), c(37, 41))}.")
  labels <- vapply(windows, function(w) sprintf("[%g, %g]", w[1], w[2]), "")
  out <- do.call(rbind, lapply(seq_along(windows), function(k) {
    w <- windows[[k]]
    x <- d[d$t >= w[1] & d$t <= w[2], , drop = FALSE]
    x$window <- rep(labels[k], nrow(x))
    x
  }))
  out$window <- factor(out$window, levels = labels)
  out
}

# A curve and its reconstruction on the retained basis.
plot_reconstruction <- function(t, y, yhat, title) {
  d <- rbind(data.frame(t = t, y = y, curve = "original"),
             data.frame(t = t, y = yhat, curve = "reconstructed"))
  ggplot2::ggplot(d, ggplot2::aes(.data$t, .data$y, colour = .data$curve, linetype = .data$curve)) +
    ggplot2::geom_line(linewidth = 0.35) +
    ggplot2::scale_colour_manual(values = c(original = "black", reconstructed = "red")) +
    ggplot2::scale_linetype_manual(values = c(original = "solid", reconstructed = "dashed")) +
    ggplot2::labs(x = "time", y = "output", colour = NULL, linetype = NULL,
                  title = title %||%
                  sprintf("Relative L2 error %.3g", sqrt(sum((y - yhat)^2) / sum(y^2)))) +
    ggplot2::theme_bw()
}
