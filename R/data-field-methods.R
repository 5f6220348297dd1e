# Methods of wv_field: its print and summary.

#' @export
print.wv_field <- function(x, ...) {
  n <- vapply(x$curves, nrow, integer(1))
  cli::cat_line(sprintf("<wv_field> field data on %d time points in [%s, %s]%s", length(x$t),
                        format(signif(min(x$t), 4)), format(signif(max(x$t), 4)),
                        if (!is.null(x$warps)) ", registered" else ""))
  for (s in names(n)) {
    interp <- x$noise[[s]]$interpolated
    if (!is.null(interp$n_points)) interp <- list(interp)
    interp <- interp[!vapply(interp, is.null, logical(1))]
    units <- if (!is.null(x$units[[s]])) sprintf(" of %d units", length(unique(x$units[[s]]))) else ""
    obs <- x$observed[[s]]
    if (!is.null(obs)) {
      k <- range(rowSums(obs))
      units <- sprintf("%s, each over its own extent (%s of %d points)", units,
                       if (k[1] == k[2]) k[1] else paste(k, collapse = " to "), ncol(obs))
    }
    cli::cat_line(sprintf("  %s: %d replicate%s%s%s", s, n[[s]], if (n[[s]] == 1) "" else "s", units,
                          if (length(interp)) sprintf(" (%d read as interpolated, noise evidence from %s measured points%s)",
                                                      length(interp),
                                                      sum(vapply(interp, function(z) z$n_measured,
                                                                 integer(1))),
                                                      if (x$noise[[s]]$detail_sd > 0) "" else " that cannot tell it") else ""))
  }
  if (!is.null(x$x_nom)) {
    cli::cat_line("  nominal inputs: ", paste(sprintf("%s = %s", names(x$x_nom),
                                                      format(signif(x$x_nom, 4))),
                                                collapse = ", "))
  }
  invisible(x)
}

#' @export
summary.wv_field <- function(object, ...) {
  structure(list(
    n_t = length(object$t),
    range_t = range(object$t),
    replicates = vapply(object$curves, nrow, integer(1)),
    spread = vapply(object$curves,
                    function(m) if (nrow(m) > 1) mean(apply(m, 2, stats::sd)) else NA_real_,
                    numeric(1)),
    registered = !is.null(object$warps),
    x_nom = object$x_nom
  ), class = "summary_wv_field")
}

#' @export
print.summary_wv_field <- function(x, ...) {
  cli::cat_line(sprintf("Field data on %d time points in [%s, %s]%s", x$n_t,
                        format(signif(x$range_t[1], 4)),
                        format(signif(x$range_t[2], 4)), if (x$registered) " (registered)" else ""))
  print(data.frame(site = names(x$replicates), replicates = x$replicates,
                   mean_pointwise_sd = signif(x$spread, 4), row.names = NULL), row.names = FALSE)
  invisible(x)
}
