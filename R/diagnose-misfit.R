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
#' site has two replicates or more, else the noise the fit learned. With few
#' replicates their scatter is itself uncertain: each simulated draw of it is
#' scaled by `sqrt(nu / chi^2_nu)`, `nu` one less than their number, which
#' gives the standardised misfit the t tails it has.
#'
#' The band is simultaneous over every time point of every site and over the
#' means of windows of 2, 4, 8, ... points up to the whole record (each
#' width's windows overlapping by half): its half-width is the `level`
#' quantile of the largest standardised deviation of the simulated curves
#' over all of them. A narrow misfit stands out point by point; a small one
#' spread over the record in the mean of a wide window, where the noise
#' averages away. Where a point or a window's mean lies beyond the band, the
#' model is rejected there; [where_fails()] reports such stretches as
#' findings of kind `"misfit"` (beyond the tolerance, as the bias's band).
#'
#' @section Replicates that are units:
#' When the field declares its replicates as different units
#' (`field_runs(units = )`), their spread is not measurement noise: each unit
#' has its own inputs. The population's misfit is then judged net of what
#' each unit's own inputs explain: the misfit and its simulated errors are
#' projected off the directions in which the variation inputs of the map
#' (every estimated input when it has none) move the model at the calibrated
#' inputs (the emulators' central differences), and the field mean's error is
#' the scatter of the units' means (Gaussian multipliers of the units'
#' deviations with the t scaling above), never below their measurement noise
#' (from the units' repeats about their own means, or, with one curve per
#' unit, the level's mean of that scatter). A small smooth misfit that the
#' spread between units hides when they are read as repeats is found.
#'
#' @param fit A `wv_fit`.
#' @param level Coverage of the simultaneous band.
#' @param n_sim Number of simulated curves behind the band.
#' @param seed Seed of the simulation (the caller's random stream is left
#'   as it was).
#' @return A `wv_misfit_check` data frame, one row per site and time point:
#'   `site`, `t`, `misfit` (field mean less model), `se` (its standard
#'   error), `z` (`misfit / se`), `crit` (the band's half-width in standard
#'   errors, the same at every point and window), `excess` (the largest
#'   amount by which a point or window holding the point lies beyond the
#'   band, 0 where none does), `scale`, `window_mean` and `window_se` (that
#'   window's length in time, its mean misfit and the mean's standard error;
#'   `NA` where none is beyond the band), `rejected` (`excess > 0`) and
#'   `covered` (`FALSE` where no field curve reaches: misfit 0, never
#'   rejected).
#'   Its attributes: `level`, `crit`, `p_value` (the share of simulated
#'   curves whose largest standardised deviation exceeds the observed one:
#'   small when the model fails somewhere),
#'   `noise` (by site, `"replicates"`, `"units"` or `"learned"`) and
#'   `noise_text` (the same in words).
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
  field <- fit_get(fit, "field")
  sims <- with_rng_seed(seed, lapply(stats::setNames(sites, sites), function(s) {
    Z <- shift_inputs(fit, s, X[rows, , drop = FALSE])
    bank <- site_bank(fit_get(fit, "emulators"), s)
    pr <- bank_predict(bank, Z)
    D <- field_mean_draws(fit, s, rows) - pr$mean
    dbar <- colMeans(D)
    k <- ncol(D)
    h <- sample.int(length(rows), n_sim, replace = TRUE)
    E <- sweep(D[h, , drop = FALSE], 2L, dbar) +
      sqrt(pmax(pr$var[h, , drop = FALSE], 0)) * matrix(stats::rnorm(n_sim * k), n_sim)
    R <- fit_get(fit, "n_rep")[[s]]
    reg <- fit_get(fit, "registration_var")[[s]] %||% 0
    # curves missing beyond their own extent: judged where some curve
    # covers, their mean of fewer curves with its own variance there
    fill <- missing_fill_variance(field$curves[[s]], field$observed[[s]], Psi)
    if (!is.null(fill)) reg <- pmax(reg - (fit_get(fit, "missing_var")[[s]] %||% 0), 0)
    units <- field$units[[s]]
    Q <- NULL
    if (R >= 2L) {
      Wr <- basis_coef(fit_get(fit, "basis"), field$curves[[s]])
      if (is.null(units)) {
        E <- E + scatter_draws(sweep(Wr, 2L, colMeans(Wr)), n_sim)
        noise <- c(replicates = "the replicates' scatter along the record")
      } else {
        Wu <- rowsum(Wr, units) / as.vector(table(units))
        nu <- nrow(Wu)
        Du <- sweep(Wu, 2L, colMeans(Wu))
        E <- E + scatter_draws(Du, n_sim)
        floor <- unit_noise_floor(Wr, units, fit_get(fit, "basis")$level) -
          colSums(Du^2) / (nu - 1) / nu
        E <- E + rep(sqrt(pmax(floor, 0)), each = n_sim) * matrix(stats::rnorm(n_sim * k), n_sim)
        Q <- unit_directions(fit, bank, Z, Psi)
        noise <- c(units = sprintf(
          "the scatter of %d units' means, net of what their own %s explain",
          nu, paste(attr(Q, "inputs"), collapse = ", ")))
      }
      E <- E + sweep(matrix(stats::rnorm(n_sim * k), n_sim), 2L, sqrt(reg), `*`)
    } else {
      v <- field_mean_variance(fit, s, rows[h])
      if (!is.null(fill)) v <- pmax(sweep(v, 2L, fit_get(fit, "missing_var")[[s]] %||% 0), 0)
      E <- E + sqrt(v) * matrix(stats::rnorm(n_sim * k), n_sim)
      noise <- c(learned = "the learned noise")
    }
    Et <- basis_curves(fit_get(fit, "basis"), E)
    m <- drop(basis_curves(fit_get(fit, "basis"), dbar))
    covered <- rep(TRUE, length(m))
    if (!is.null(fill)) {
      covered <- fill$covered
      Et <- Et + sweep(matrix(stats::rnorm(n_sim * length(m)), n_sim), 2L,
                       sqrt(ifelse(covered, fill$point, 0)), `*`)
      Et[, !covered] <- 0
      m[!covered] <- 0
    }
    if (!is.null(Q)) {
      Et <- Et - tcrossprod(Et %*% Q, Q)
      m <- m - drop(Q %*% crossprod(Q, m))
    }
    c(list(misfit = m, noise = noise, covered = covered), misfit_scan(m, Et))
  }))
  zmax <- do.call(pmax, lapply(sims, `[[`, "zmax"))
  crit <- unname(stats::quantile(zmax, level))
  t <- fit_get(fit, "basis")$t
  out <- do.call(rbind, lapply(sites, function(s) {
    sc <- sims[[s]]
    ex <- scan_excess(sc$windows, crit, length(t))
    data.frame(site = s, t = t, misfit = sc$misfit, se = sc$windows[[1]]$se,
               z = sc$windows[[1]]$z, crit = crit, excess = ex$excess,
               scale = ex$width * diff(t[1:2]), window_mean = ex$mean, window_se = ex$se,
               rejected = ex$excess > 0, covered = sc$covered, stringsAsFactors = FALSE)
  }))
  observed <- max(vapply(sims, `[[`, numeric(1), "observed"))
  structure(out, class = c("wv_misfit_check", "data.frame"), level = level, crit = crit,
            p_value = mean(zmax >= observed),
            noise = vapply(sims, function(x) names(x$noise), character(1)),
            noise_text = vapply(sims, function(x) unname(x$noise), character(1)))
}

# Draws of the error of a mean of n curves (their deviations from it, the
# rows of `Dev`) estimated from their own scatter: Gaussian multipliers of
# the deviations, each draw scaled by sqrt(nu / chi^2_nu), nu = n - 1, so
# that the standardised error has the t tails a scatter of few curves gives.
scatter_draws <- function(Dev, n_sim) {
  n <- nrow(Dev)
  scale <- sqrt((n - 1) / stats::rchisq(n_sim, n - 1))
  scale * (matrix(stats::rnorm(n_sim * n), n_sim) %*% Dev) / sqrt(n * (n - 1))
}

# The least variance of a mean of unit means, by coefficient: their
# measurement noise, from the scatter of each unit's repeats about its mean
# (pooled over the units, many degrees of freedom) when units were tested
# more than once, else the level's mean of the unit means' scatter (the
# noise of a level's coefficients is alike). The scatter of a few units'
# means alone leaves some coefficients' error far too small by chance.
unit_noise_floor <- function(Wr, units, level) {
  n_u <- table(units)
  nu <- length(n_u)
  Wu <- rowsum(Wr, units) / as.vector(n_u)
  if (nrow(Wr) > nu) {
    within <- colSums((Wr - Wu[match(units, rownames(Wu)), , drop = FALSE])^2) / (nrow(Wr) - nu)
    return(within * mean(1 / as.vector(n_u)) / nu)
  }
  between <- colSums(sweep(Wu, 2L, colMeans(Wu))^2) / (nu - 1) / nu
  stats::ave(between, level)
}

# The directions in the time domain along which each unit's own inputs move
# the model at the calibrated inputs (T x p, orthonormal): the variation
# inputs of the map, or every estimated input when it has none; from the
# emulators' mean by central differences of a hundredth of each range.
unit_directions <- function(fit, bank, Z, Psi) {
  iu <- fit_get(fit, "iu")
  inputs <- colnames(Z) %||% fit_get(fit, "inputs")
  type <- iu$type[match(inputs, iu$name)]
  own <- inputs[type %in% "variation"]
  if (!length(own)) own <- inputs[!type %in% "condition"]
  x0 <- colMeans(Z)
  width <- (iu$upper - iu$lower)[match(own, iu$name)]
  step <- 0.01 * ifelse(is.finite(width) & width > 0, width, 1)
  P <- matrix(x0, 2L * length(own), length(x0), byrow = TRUE, dimnames = list(NULL, inputs))
  for (j in seq_along(own)) {
    P[2L * j - 1L, own[j]] <- x0[[own[j]]] + step[j]
    P[2L * j, own[j]] <- x0[[own[j]]] - step[j]
  }
  mu <- bank_predict(bank, P)$mean
  J <- (mu[c(TRUE, FALSE), , drop = FALSE] - mu[c(FALSE, TRUE), , drop = FALSE]) / step
  q <- qr(Psi %*% t(J))
  keep <- seq_len(q$rank)
  structure(qr.Q(q)[, keep, drop = FALSE], inputs = own)
}

# The misfit `m` (length T) and its simulated errors `Et` (n_sim x T) averaged
# over windows of 1, 2, 4, ... points (each width's windows overlapping by
# half, the last ending at T): by width, the starts, the window means, their
# standard errors and z; the largest |z| of every simulated curve over all
# windows (`zmax`) and of the misfit (`observed`). A misfit spread smoothly
# over the record stands out in the wide windows' means, where the noise
# averages away; a narrow one in the narrow windows.
misfit_scan <- function(m, Et) {
  if (!is.double(Et)) storage.mode(Et) <- "double"
  misfit_scan_cpp(as.numeric(m), Et)
}

# By point, the largest excess of a rejected window's mean over the band's
# edge among the windows holding the point (0 where none is rejected), and
# that window's width in points, mean and standard error (NA).
scan_excess <- function(windows, crit, n) {
  excess <- numeric(n)
  width <- mean <- se <- rep(NA_real_, n)
  for (wd in windows) {
    gap <- abs(wd$mean) - crit * wd$se
    for (i in which(abs(wd$z) > crit)) {
      idx <- wd$start[i] + seq_len(wd$width) - 1L
      better <- gap[i] > excess[idx]
      excess[idx[better]] <- gap[i]
      width[idx[better]] <- wd$width
      mean[idx[better]] <- wd$mean[i]
      se[idx[better]] <- wd$se[i]
    }
  }
  list(excess = excess, width = width, mean = mean, se = se)
}

#' @export
print.wv_misfit_check <- function(x, ...) {
  cli::cat_line(
    "<wv_misfit_check> the field mean against the model at the calibrated inputs, point by point")
  lv <- 100 * attr(x, "level")
  noise <- attr(x, "noise_text") %||% attr(x, "noise")
  cli::cat_line(sprintf("Standard errors: %s.", paste(sprintf("%s from %s", names(noise), noise),
                                                      collapse = "; ")))
  st <- misfit_stretches(x, tol = stats::setNames(rep(0, length(unique(x$site))), unique(x$site)))
  if (!nrow(st)) {
    cli::cat_line(sprintf("Not rejected: the misfit lies inside the %g%% simultaneous band (%.2f standard errors) at every point and in every window's mean (p = %.2f).",
                          lv, attr(x, "crit"), attr(x, "p_value")))
  } else {
    cli::cat_line(sprintf("Rejected (p = %.3f): the misfit, point by point or in a window's mean, lies beyond the %g%% simultaneous band (%.2f standard errors) on %d stretch%s:",
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
    gap <- d$excess %||% pmax(abs(d$misfit) - crit * d$se, 0)
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
