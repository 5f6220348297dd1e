# The check the bias prior's shrinkage cannot hide: the registered field mean
# against the model at the calibrated inputs, in the time domain, each point
# standardised by its own uncertainty, with a simultaneous band.

#' The field mean against the calibrated model, point by point
#'
#' A check of the model that does not go through the bias prior: the
#' registered field mean less the model at the calibrated inputs, at every
#' time point, divided by its own standard error, and compared with a
#' simultaneous band. The bias's band in [where_fails()] reads the same
#' misfit through the wavelet coefficients, one variance per coefficient:
#' where the field's spread changes along the record (units rather than
#' repeats, a spread large early and small late), a coarse coefficient that
#' spans the record takes the large spread as its noise, and a small smooth
#' misfit where the spread is small hides under it. Here each point keeps its
#' own spread.
#'
#' The misfit is the posterior mean of the field mean's retained part (net
#' of the registration's shifts the sampler drew) less the emulators' mean
#' at 100 posterior draws of the inputs spread evenly over the chains. Its uncertainty, simulated
#' `n_sim` times in the wavelet domain and carried to the time points: the
#' posterior spread of that difference over the draws (the inputs, the
#' registration's shifts), the emulators' predictive variance, the field
#' mean's own error and the registration's remaining variance. The field
#' mean's error is the replicates' scatter about their mean (a Gaussian
#' multiplier draw of their deviations, which keeps how the spread changes
#' along the record and how the points of a replicate go together) when a
#' site has two replicates or more, else the noise the fit learned. The band
#' is simultaneous over every time point of every site: its half-width is
#' the `level` quantile of the largest standardised deviation of the
#' simulated curves. Where the standardised misfit lies beyond it, the model
#' is rejected there; [where_fails()] reports such stretches as findings of
#' kind `"misfit"` (beyond the tolerance, as the bias's band).
#'
#' @param fit A `wv_fit`.
#' @param level Coverage of the simultaneous band.
#' @param n_sim Number of simulated curves behind the band.
#' @param seed Seed of the simulation (the caller's random stream is left
#'   as it was).
#' @return A `wv_misfit_check` data frame, one row per site and time point:
#'   `site`, `t`, `misfit` (field mean less model), `se` (its standard
#'   error), `z` (`misfit / se`), `crit` (the band's half-width in standard
#'   errors, the same at every point) and `rejected` (`|z| > crit`). Its
#'   attributes: `level`, `crit`, `p_value` (the share of simulated curves
#'   whose largest standardised deviation exceeds the observed one: small
#'   when the model fails somewhere) and `noise` (by site, `"replicates"`
#'   or `"learned"`).
#' @seealso [where_fails()], whose findings include this check's.
#' @export
#' @examples
#' fit <- example_fit()
#' chk <- misfit_check(fit)
#' chk
#' autoplot(chk)
misfit_check <- function(fit, level = 0.9, n_sim = 400L, seed = 1L) {
  check_class(fit, "wv_fit")
  check_level(level)
  check_number(n_sim, min = 100, integer = TRUE)
  check_number(seed, integer = TRUE)
  sites <- fit_sites(fit)
  X <- fit_draws_matrix(fit)[, fit_get(fit, "inputs"), drop = FALSE]
  rows <- unique(round(seq(1, nrow(X), length.out = min(nrow(X), 100L))))
  Psi <- fit_get(fit, "basis")$Psi
  sims <- with_rng_seed(seed, lapply(stats::setNames(sites, sites), function(s) {
    Z <- shift_inputs(fit, s, X[rows, , drop = FALSE])
    pr <- bank_predict(site_bank(fit_get(fit, "emulators"), s), Z)
    D <- field_mean_draws(fit, s, rows) - pr$mean
    dbar <- colMeans(D)
    k <- ncol(D)
    h <- sample.int(length(rows), n_sim, replace = TRUE)
    E <- sweep(D[h, , drop = FALSE], 2L, dbar) +
      sqrt(pmax(pr$var[h, , drop = FALSE], 0)) * matrix(stats::rnorm(n_sim * k), n_sim)
    R <- fit_get(fit, "n_rep")[[s]]
    reg <- fit_get(fit, "registration_var")[[s]] %||% 0
    if (R >= 2L) {
      Wr <- basis_coef(fit_get(fit, "basis"), fit_get(fit, "field")$curves[[s]])
      Dr <- sweep(Wr, 2L, colMeans(Wr))
      E <- E + matrix(stats::rnorm(n_sim * R), n_sim) %*% Dr / sqrt(R * (R - 1))
      E <- E + sweep(matrix(stats::rnorm(n_sim * k), n_sim), 2L, sqrt(reg), `*`)
    } else {
      v <- field_mean_variance(fit, s, rows[h])
      E <- E + sqrt(v) * matrix(stats::rnorm(n_sim * k), n_sim)
    }
    Et <- tcrossprod(E, Psi)
    se <- pmax(sqrt(colMeans(Et^2)), .Machine$double.eps)
    list(misfit = drop(Psi %*% dbar), se = se,
         zmax = apply(abs(Et) / rep(se, each = n_sim), 1L, max),
         noise = if (R >= 2L) "replicates" else "learned")
  }))
  zmax <- do.call(pmax, lapply(sims, `[[`, "zmax"))
  crit <- unname(stats::quantile(zmax, level))
  out <- do.call(rbind, lapply(sites, function(s) {
    z <- sims[[s]]$misfit / sims[[s]]$se
    data.frame(site = s, t = fit_get(fit, "basis")$t, misfit = sims[[s]]$misfit, se = sims[[s]]$se,
               z = z, crit = crit,
               rejected = abs(z) > crit, stringsAsFactors = FALSE)
  }))
  observed <- max(abs(out$z))
  structure(out, class = c("wv_misfit_check", "data.frame"), level = level, crit = crit,
            p_value = mean(zmax >= observed), noise = vapply(sims, `[[`, character(1), "noise"))
}

#' @export
print.wv_misfit_check <- function(x, ...) {
  cli::cat_line(
    "<wv_misfit_check> the field mean against the model at the calibrated inputs, point by point")
  lv <- 100 * attr(x, "level")
  noise <- attr(x, "noise")
  cli::cat_line(sprintf("Standard errors: %s.", paste(sprintf("%s from %s", names(noise),
    ifelse(noise == "replicates", "the replicates' scatter along the record", "the learned noise")),
                                                      collapse = "; ")))
  st <- misfit_stretches(x, tol = stats::setNames(rep(0, length(unique(x$site))), unique(x$site)))
  if (!nrow(st)) {
    cli::cat_line(sprintf("Not rejected: the misfit lies inside the %g%% simultaneous band (%.2f standard errors) at every point (p = %.2f).",
                          lv, attr(x, "crit"), attr(x, "p_value")))
  } else {
    cli::cat_line(sprintf("Rejected (p = %.3f): the misfit lies beyond the %g%% simultaneous band (%.2f standard errors) on %d stretch%s:",
                          attr(x, "p_value"), lv, attr(x, "crit"), nrow(st),
                          if (nrow(st) == 1L) "" else "es"))
    for (i in seq_len(min(nrow(st), 5L))) {
      cli::cat_line(sprintf("  %s t in [%s, %s]: misfit up to %s (%s)", st$site[i],
                            format(signif(st$start[i], 4)),
                            format(signif(st$end[i], 4)), format(signif(st$size[i], 3)),
                            st$sign[i]))
    }
  }
  invisible(x)
}

#' @export
autoplot.wv_misfit_check <- function(object, ...) {
  check_dots_none(...)
  d <- as.data.frame(unclass(object)[c("site", "t", "z")])
  crit <- attr(object, "crit")
  ggplot2::ggplot(d, ggplot2::aes(.data$t, .data$z)) +
    ggplot2::annotate("rect", xmin = -Inf, xmax = Inf, ymin = -crit, ymax = crit, fill = "grey85") +
    ggplot2::geom_hline(yintercept = 0, colour = "grey40", linetype = 2) +
    ggplot2::geom_line(linewidth = 0.3) +
    ggplot2::facet_wrap(~site, ncol = 1, scales = "free_x") +
    ggplot2::labs(x = "time", y = "misfit / standard error",
                  title = "Field mean less the model at the calibrated inputs",
                  subtitle = sprintf("%g%% simultaneous band shaded (p = %.3f)",
                                     100 * attr(object, "level"),
                                     attr(object, "p_value"))) +
    ggplot2::theme_bw()
}

# The stretches where the check rejects and the misfit lies beyond the band
# by more than the site's tolerance: site, start, end, size (the largest
# |misfit| there), credible (the largest excess over the band's edge), sign.
misfit_stretches <- function(x, tol, min_steps = 1L) {
  crit <- attr(x, "crit")
  rows <- lapply(unique(x$site), function(s) {
    d <- x[x$site == s, , drop = FALSE]
    dt <- diff(d$t[1:2])
    gap <- pmax(abs(d$misfit) - crit * d$se, 0)
    hit <- d$rejected & gap > tol[[s]]
    r <- rle(hit)
    ends <- cumsum(r$lengths)
    starts <- ends - r$lengths + 1L
    keep <- which(r$values & r$lengths >= min_steps)
    if (!length(keep)) return(NULL)
    do.call(rbind, lapply(keep, function(k) {
      idx <- starts[k]:ends[k]
      data.frame(site = s, start = d$t[starts[k]], end = d$t[ends[k]] + dt,
                 size = max(abs(d$misfit[idx])),
                 credible = max(gap[idx]), integrated = sum(abs(d$misfit[idx])) * dt,
                 sign = if (mean(d$misfit[idx]) > 0) "reality above model" else "reality below model",
                 stringsAsFactors = FALSE)
    }))
  })
  out <- do.call(rbind, rows)
  if (is.null(out)) {
    out <- data.frame(site = character(), start = numeric(), end = numeric(), size = numeric(),
                      credible = numeric(),
                      integrated = numeric(), sign = character(), stringsAsFactors = FALSE)
  }
  out[order(-out$size), , drop = FALSE]
}
