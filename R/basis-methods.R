# Methods of wv_basis: print, summary and the figures, with the texts of its
# rule and reconstruction error.

# --- print, summary, plot ----------------------------------------------------------

family_label <- function(settings) {
  sprintf("%s %d", settings$family, settings$filter.number)
}

#' @export
print.wv_basis <- function(x, ...) {
  st <- x$settings
  cli::cat_line(sprintf("<wv_basis> %d of %d wavelet coefficients kept (%s, %s)",
                        length(x$index), st$n_t, family_label(st), st$boundary %||% "periodic"))
  alone <- vapply(x$by_site, length, integer(1))
  cli::cat_line("  sites: ", paste(sprintf("%s (%d alone)", names(alone), alone), collapse = ", "))
  if (!is.null(x$n_curves)) {
    cli::cat_line(sprintf("  from %d model-run and %d field curves", sum(x$n_curves[, "runs"]),
                          sum(x$n_curves[, "field"])))
  }
  cli::cat_line("  rule: ", basis_rule_text(st))
  tab <- table(factor(x$level, levels = 0:st$n_levels))
  tab <- tab[tab > 0]
  cli::cat_line("  kept by level: ", paste(sprintf("%s:%d", names(tab), tab), collapse = " "))
  if (!is.null(x$error)) cli::cat_line("  reconstruction error (relative L2): ",
                                       basis_error_text(x$error))
  invisible(x)
}

basis_rule_text <- function(st) {
  wl <- st$whole_levels %||% c(0L, st$keep_levels + 1L)
  lv <- if (length(wl) > 1L) sprintf("all of levels %s (0: the scaling coefficient)",
                                     paste(range(wl), collapse = "-"))
        else "the scaling coefficient"
  rule <- sprintf("%s, plus each curve's top %s%% of coefficients", lv, format(100 * st$fraction))
  if (identical(st$retain, "error")) {
    rule <- sprintf("%s, plus what the curves need for relative L2 errors within %s (median of the runs) and %s or the noise level (each field curve)",
                    rule, percent_text(st$tolerance[["runs"]]),
                    percent_text(st$tolerance[["field"]]))
  }
  rule
}

percent_text <- function(x) paste0(format(signif(100 * x, 2), scientific = FALSE,
                                          drop0trailing = TRUE), "%")

# "runs median 0.28%, max 0.9%; field 1.2%" from a table of relative errors.
basis_error_text <- function(error) {
  parts <- character(0)
  r <- error$rel_l2[error$source == "run"]
  if (length(r)) parts <- c(parts,
                            sprintf("runs median %s, max %s", percent_text(stats::median(r)),
                                    percent_text(max(r))))
  f <- error$rel_l2[error$source == "field"]
  if (length(f) == 1L) parts <- c(parts, sprintf("field %s", percent_text(f)))
  if (length(f) > 1L) parts <- c(parts,
                                 sprintf("field median %s, max %s", percent_text(stats::median(f)),
                                         percent_text(max(f))))
  paste(parts, collapse = "; ")
}

#' @export
summary.wv_basis <- function(object, ...) {
  st <- object$settings
  lev <- 0:st$n_levels
  total <- c(1L, 2L^(lev[-1] - 1L))
  kept <- as.integer(table(factor(object$level, levels = lev)))
  structure(list(
    by_level = data.frame(level = lev, total = total, kept = kept, share = kept / total),
    n_kept = length(object$index), n_t = st$n_t,
    by_site = vapply(object$by_site, length, integer(1)),
    settings = st, error = object$error
  ), class = "summary_wv_basis")
}

#' @export
print.summary_wv_basis <- function(x, ...) {
  cli::cat_line(sprintf("Wavelet basis: %d of %d coefficients kept (%s, %s)", x$n_kept, x$n_t,
                        family_label(x$settings), x$settings$boundary %||% "periodic"))
  cli::cat_line("Rule: ", basis_rule_text(x$settings))
  cli::cat_line("Sites alone: ",
                paste(sprintf("%s %d", names(x$by_site), x$by_site), collapse = ", "))
  d <- x$by_level
  d$share <- sprintf("%.1f%%", 100 * d$share)
  print(d, row.names = FALSE)
  if (!is.null(x$error)) cli::cat_line("Reconstruction error (relative L2): ",
                                       basis_error_text(x$error))
  invisible(x)
}

#' Plot a wavelet basis
#'
#' `type = "levels"` shows which coefficients are kept: one point per retained
#' coefficient at the time its wavelet is centred on, by level.
#' `type = "reconstruction"` draws `curve` and its reconstruction from the
#' retained coefficients (report Figure 2; see also [reconstruction_check()]).
#'
#' @param object A `wv_basis` object.
#' @param type `"levels"` or `"reconstruction"`.
#' @param curve For `type = "reconstruction"`: a numeric vector on the basis
#'   grid.
#' @param ... Unused.
#' @return A ggplot object.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 128)
#' runs <- model_runs(data.frame(a = 1:5), t(sapply(1:5, function(a) sin(2 * pi * a * t^2))), t)
#' basis <- wavelet_basis(runs)
#' autoplot(basis)
#' autoplot(basis, type = "reconstruction", curve = runs$curves$site1[5, ])
autoplot.wv_basis <- function(object, type = c("levels", "reconstruction"), curve = NULL, ...) {
  type <- check_choice(type)
  if (type == "reconstruction") {
    if (!is.numeric(curve) || length(curve) != length(object$t)) {
      wv_abort(
        "{.arg curve} must be a numeric vector of {length(object$t)} values on the basis grid.")
    }
    return(plot_reconstruction(object$t, curve,
                               basis_curves(object, basis_coef(object, curve))[1, ], NULL))
  }
  rg <- range(object$t)
  pos <- ifelse(object$level == 0L, 0.5, (object$index - 2^pmax(object$level - 1L, 0) - 0.5) /
                  2^pmax(object$level - 1L, 0))
  d <- data.frame(t = rg[1] + pos * diff(rg), level = object$level)
  ggplot2::ggplot(d, ggplot2::aes(.data$t, .data$level)) +
    ggplot2::geom_point(size = 0.8) +
    ggplot2::scale_y_reverse(breaks = 0:object$settings$n_levels) +
    ggplot2::labs(x = "time (centre of the wavelet)", y = "level",
                  title = sprintf("%d retained wavelet coefficients", length(object$index))) +
    ggplot2::theme_bw()
}

#' @export
plot.wv_basis <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}
