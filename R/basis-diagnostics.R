# Diagnostics of the wavelet representation: reconstruction accuracy of the
# retained coefficients and the independent-coefficient error model.

# --- diagnostics ---------------------------------------------------------------

#' Accuracy of the wavelet reconstruction
#'
#' Projects every model-run and field curve on the retained basis and reports
#' how much is lost: the relative L2 error `||y - Psi Psi' y|| / ||y||` and the
#' largest absolute error of each curve. `autoplot()` of the result draws one
#' curve and its reconstruction (report Figure 2).
#'
#' @inheritParams wavelet_coef
#' @param runs,field `wv_runs` and `wv_field` objects on the basis grid (either
#'   may be `NULL`).
#' @return A `wv_reconstruction` data frame with columns `site`, `source`
#'   (`"run"` or `"field"`), `id` (run or replicate number), `rel_l2` and
#'   `max_abs`, one row per curve; the curves are kept as an attribute for
#'   plotting.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 256)
#' runs <- model_runs(data.frame(a = 1:6), t(sapply(1:6, function(a) sin(2 * pi * a * t^2))), t)
#' basis <- wavelet_basis(runs)
#' chk <- reconstruction_check(basis, runs)
#' chk
#' autoplot(chk)
reconstruction_check <- function(basis, runs = NULL, field = NULL) {
  check_class(basis, "wv_basis")
  sets <- list()
  if (!is.null(runs)) {
    check_class(runs, "wv_runs")
    check_same_grid(basis$t, runs$t, "basis", "runs")
    sets$run <- runs$curves
  }
  if (!is.null(field)) {
    check_class(field, "wv_field")
    check_same_grid(basis$t, field$t, "basis", "field")
    sets$field <- field$curves
  }
  if (!length(sets)) wv_abort("Give {.arg runs}, {.arg field} or both.")
  rows <- list()
  curves <- list()
  for (src in names(sets)) for (s in names(sets[[src]])) {
    m <- sets[[src]][[s]]
    err <- basis_remainder(basis, m)
    rows[[length(rows) + 1L]] <- data.frame(site = s, source = src, id = seq_len(nrow(m)),
                                            rel_l2 = sqrt(rowSums(err^2) / rowSums(m^2)),
                                            max_abs = apply(abs(err), 1L, max),
                                            stringsAsFactors = FALSE)
    curves[[paste(src, s)]] <- m
  }
  out <- do.call(rbind, rows)
  structure(out, basis = basis, curves = curves, class = c("wv_reconstruction", "data.frame"))
}

#' @export
print.wv_reconstruction <- function(x, ...) {
  d <- as.data.frame(x)
  cli::cat_line(sprintf("<wv_reconstruction> %d curves on %d of %d coefficients", nrow(d),
                        length(attr(x, "basis")$index), length(attr(x, "basis")$t)))
  agg <- stats::aggregate(rel_l2 ~ site + source, data = d,
                          FUN = function(v) c(median = stats::median(v), max = max(v)))
  agg <- data.frame(agg[c("site", "source")], median_rel_l2 = signif(agg$rel_l2[, "median"], 3),
                    max_rel_l2 = signif(agg$rel_l2[, "max"], 3))
  print(agg, row.names = FALSE)
  invisible(x)
}

#' @export
as.data.frame.wv_reconstruction <- function(x, ...) {
  attr(x, "basis") <- attr(x, "curves") <- NULL
  class(x) <- "data.frame"
  x
}

#' @export
summary.wv_reconstruction <- function(object, ...) {
  d <- as.data.frame(object)
  structure(list(worst = d[which.max(d$rel_l2), ],
                 quantiles = stats::quantile(d$rel_l2, c(0, 0.5, 0.9, 1))),
            class = "summary_wv_reconstruction")
}

#' @export
print.summary_wv_reconstruction <- function(x, ...) {
  cli::cat_line("Relative L2 reconstruction error, quantiles over curves:")
  print(signif(x$quantiles, 3))
  cli::cat_line(sprintf("Worst: %s %s %d (%.3g)", x$worst$site, x$worst$source, x$worst$id,
                        x$worst$rel_l2))
  invisible(x)
}

#' @rdname reconstruction_check
#' @param object A `wv_reconstruction` object.
#' @param which Row of `object` whose curve is drawn; by default the first
#'   field curve if there is one (as the report's Figure 2), else the worst
#'   reconstructed curve.
#' @param ... Unused.
#' @export
autoplot.wv_reconstruction <- function(object, which = NULL, ...) {
  d <- as.data.frame(object)
  if (is.null(which))
    which <- if (any(d$source == "field")) which(d$source == "field")[1] else which.max(d$rel_l2)
  check_number(which, "which", min = 1, max = nrow(d), integer = TRUE)
  r <- d[which, ]
  y <- attr(object, "curves")[[paste(r$source, r$site)]][r$id, ]
  basis <- attr(object, "basis")
  plot_reconstruction(basis$t, y, basis_curves(basis, basis_coef(basis, y))[1, ],
                      sprintf("%s %s %d: relative L2 error %.3g", r$site, r$source, r$id, r$rel_l2))
}

#' @export
plot.wv_reconstruction <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}

#' Field residual processes against the independent-coefficient error model
#'
#' The method models the measurement error of each retained wavelet
#' coefficient as independent across coefficients, with its own variance.
#' This check (report Figure 3) sets the residual processes of the field data
#' (each replicate minus the replicate mean) beside R processes simulated from
#' that model, `Psi \%*\% rnorm(|I|, sd = sigma)`, with `sigma_i^2 = s_i^2 / (R -
#' 1)` the unbiased replicate variance of coefficient i. Similar time
#' correlation in both panels supports the model. The field needs at least
#' two replicates at the site checked.
#'
#' @inheritParams wavelet_coef
#' @inheritParams calibrate
#' @param site Site to check (name or position; default the first).
#' @param project If `TRUE`, the field residuals are projected on the retained
#'   basis first, so both panels hold processes in the span of `Psi` (the
#'   simulated ones always are); by default they are the raw residuals, as in
#'   the report.
#' @return A `wv_error_processes` data frame with columns `site`, `process`
#'   (`"field residuals"` or `"simulated"`), `replicate`, `t`, `y`; attributes
#'   `sigma2` (per retained coefficient) and `seed`.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 128)
#' runs <- model_runs(data.frame(a = 1:5), t(sapply(1:5, function(a) sin(2 * pi * a * t))), t)
#' field <- field_runs(t(replicate(4, sin(4 * pi * t) + cumsum(rnorm(128, sd = 0.05)))), t)
#' basis <- wavelet_basis(runs, field)
#' ep <- error_processes(basis, field, seed = 1)
#' ep
#' autoplot(ep)
error_processes <- function(basis, field, site = 1L, seed = NULL, project = FALSE) {
  check_class(basis, "wv_basis")
  check_class(field, "wv_field")
  check_same_grid(basis$t, field$t, "basis", "field")
  site <- resolve_site(site, names(field$curves), "site")
  m <- field$curves[[site]]
  n_rep <- nrow(m)
  if (n_rep < 2L)
    wv_abort("Site {.val {site}} has {n_rep} replicate; the check needs at least two.")
  seed <- resolve_seed(seed)
  w <- basis_coef(basis, m)
  sigma2 <- colSums(sweep(w, 2L, colMeans(w))^2) / (n_rep - 1L)
  resid <- sweep(m, 2L, colMeans(m))
  if (isTRUE(project)) resid <- basis_curves(basis, basis_coef(basis, resid))
  z <- with_rng_seed(seed, matrix(stats::rnorm(n_rep * length(sigma2)), n_rep))
  sim <- basis_curves(basis, sweep(z, 2L, sqrt(sigma2), `*`))
  out <- rbind(
    data.frame(curves_long(resid, basis$t, site, "replicate"), process = "field residuals"),
    data.frame(curves_long(sim, basis$t, site, "replicate"), process = "simulated")
  )
  out <- out[c("site", "process", "replicate", "t", "y")]
  structure(out, sigma2 = sigma2, seed = seed, class = c("wv_error_processes", "data.frame"))
}

# Mean pointwise sd and mean lag-k autocorrelation of each process.
error_process_stats <- function(x, lags = c(1L, 10L)) {
  d <- as.data.frame(x)
  do.call(rbind, lapply(split(d, d$process), function(p) {
    m <- do.call(rbind, split(p$y, p$replicate))
    acf_k <- vapply(lags,
                    function(k) mean(apply(m, 1L,
                                           function(y) stats::cor(y[-seq_len(k)],
                                                                  y[seq_len(length(y) - k)]))),
                    numeric(1))
    data.frame(process = p$process[1], mean_sd = mean(apply(m, 2L, stats::sd)),
               t(stats::setNames(acf_k, paste0("acf_lag", lags))))
  }))
}

#' @export
as.data.frame.wv_error_processes <- function(x, ...) {
  attr(x, "sigma2") <- attr(x, "seed") <- NULL
  class(x) <- "data.frame"
  x
}

#' @export
print.wv_error_processes <- function(x, ...) {
  cli::cat_line(sprintf("<wv_error_processes> site %s: %d field residual and %d simulated processes",
                        x$site[1], length(unique(x$replicate)), length(unique(x$replicate))))
  s <- error_process_stats(x)
  s[-1] <- signif(s[-1], 3)
  print(s, row.names = FALSE)
  invisible(x)
}

#' @export
summary.wv_error_processes <- function(object, ...) {
  structure(list(stats = error_process_stats(object), sigma2 = attr(object, "sigma2")),
            class = "summary_wv_error_processes")
}

#' @export
print.summary_wv_error_processes <- function(x, ...) {
  cli::cat_line("Residual vs simulated error processes:")
  print(x$stats, row.names = FALSE)
  cli::cat_line("Coefficient error variances: ",
                paste(format(signif(stats::quantile(x$sigma2, c(0, 0.5, 1)), 3)), collapse = " / "),
                " (min / median / max)")
  invisible(x)
}

#' @rdname error_processes
#' @param object A `wv_error_processes` object.
#' @param ... Unused.
#' @export
autoplot.wv_error_processes <- function(object, ...) {
  d <- as.data.frame(object)
  d$replicate <- factor(d$replicate)
  ggplot2::ggplot(d, ggplot2::aes(.data$t, .data$y, colour = .data$replicate)) +
    ggplot2::geom_line(linewidth = 0.3) +
    ggplot2::facet_wrap(~process, nrow = 1) +
    ggplot2::labs(x = "time", y = "error process", colour = "replicate",
                  title = sprintf("Site %s: field residuals and processes from the error model",
                                  d$site[1])) +
    ggplot2::theme_bw()
}

#' @export
plot.wv_error_processes <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}

# The levels (the report's numbering) whose functions each span the whole
# record: the scaling coefficient, and the detail levels whose wavelets'
# support, (2N - 1) / 2^j of the record for Daubechies' wavelets with N
# vanishing moments at wavethresh level j, is at least the record.
record_wide_levels <- function(basis) {
  N <- basis$settings$filter.number
  j_max <- floor(log2(2 * N - 1))
  0:(j_max + 1L)
}
