# Methods of wv_fit: print, summary, the coda conversion and the figures. The
# diagnostics they report are computed in fit-diagnostics.R.

#' @importFrom coda as.mcmc.list
#' @export
as.mcmc.list.wv_fit <- function(x, ...) fit_get(x, "draws")

#' Posterior means of the calibrated inputs
#'
#' The posterior mean of each input of a fit (calibration inputs and, for
#' inputs with manufacturing variation, the nominal plus the variation), in
#' the inputs' own units: the point at which to run the model once more, for
#' instance to register the field data to a run at the calibrated inputs.
#'
#' Test conditions (inputs of type `"condition"`) are known settings, not
#' estimates: they are left out, and their values in the base experiment
#' come as the attribute `conditions`.
#'
#' @param object A `wv_fit`.
#' @param ... Not used; an unknown argument is an error.
#' @return A named numeric vector, one element per estimated input of the
#'   fit (attribute `conditions` when the fit has test conditions).
#' @export
#' @examples
#' fit <- example_fit()
#' coef(fit)
#' # one row of a design, to run the model there (with a fit's conditions:
#' # c(coef(fit), attr(coef(fit), "conditions")))
#' as.data.frame(as.list(coef(fit)))
coef.wv_fit <- function(object, ...) {
  check_dots_none(...)
  z <- posterior_mean_inputs(object)
  cond <- fit_get(object, "conditions")
  if (is.null(cond) || !length(cond$inputs)) return(z)
  out <- z[setdiff(names(z), cond$inputs)]
  attr(out, "conditions") <- unlist(cond$base)[cond$inputs]
  out
}

#' @export
print.wv_fit <- function(x, ...) {
  draws <- fit_get(x, "draws")
  settings <- fit_get(x, "settings")
  H <- nrow(draws[[1]])
  n <- ncol(fit_get(x, "basis")$Psi)
  sites <- fit_sites(x)
  cli::cat_line(sprintf("<wv_fit> %d site%s (%s), %d coefficients, %d draws x %d chain%s (thinning %d)",
                        length(sites), if (length(sites) == 1) "" else "s",
                        paste(sites, collapse = ", "),
                        n, H, length(draws), if (length(draws) == 1) "" else "s",
                        settings$n_inner))
  acc <- fit_get(x, "acceptance")
  glob <- if (!is.null(acc$global) && any(!is.na(acc$global))) {
    paste0("; global ", paste(format_rate(acc$global), collapse = " "))
  } else ""
  cli::cat_line("Acceptance by chain (", settings$proposal %||% "report", " proposal): tau2 ",
                paste(format_rate(acc$tau2), collapse = " "),
                "; inputs ", paste(format_rate(acc$inputs), collapse = " "), glob)
  print(input_table(x), row.names = FALSE, digits = 3)
  cli::cat_line("(sd_ratio: posterior sd / prior sd; near 1 the data say little of the input)")
  for (line in c(stopping_lines(x), sampling_speed_lines(x))) cli::cat_line(line)
  for (line in prior_lines(fit_get(x, "prior_iu"), fit_get(x, "conditions"))) cli::cat_line(line)
  for (line in noise_lines(x)) cli::cat_line(line)
  for (line in shared_error_lines(x)) cli::cat_line(line)
  for (line in experiment_lines(x)) cli::cat_line(line)
  em <- fit_get(x, "emulators")
  if (!is.null(em)) {
    cli::cat_line("Emulators: ", em$engine, " engine, ", nrow(em$design), " runs")
    for (line in emulator_calibration_text(em)) cli::cat_line(line)
  }
  warps <- fit_get(x, "field")$warps
  lo <- if (!is.null(warps)) attr(warps, "left_out")
  if (!is.null(lo) && nrow(lo)) {
    cli::cat_line("! Registration left out landmarks in another order than the reference's: ",
                  left_out_summary(lo, length(unique(warps$replicate))))
  }
  il <- settings$inform_levels
  if (length(il)) {
    cli::cat_line("Inputs informed by wavelet level", if (length(il) > 1) "s " else " ",
                  paste(il, collapse = ", "),
                  " only; the other levels' bias follows the inputs drawn (inform_levels)")
  }
  tp <- settings$temper %||% 1
  if (tp < 1) cli::cat_line("Tempered posterior: the likelihood raised to the power ",
                            signif(tp, 3), " (temper)")
  ctl <- fit_get(x, "control")
  if (!is.null(ctl)) {
    cli::cat_line("Model: ", control_call(ctl$bias, always = "input_likelihood"))
    cli::cat_line("Sampler: ", control_call(ctl$sampler), ", chains = ", length(draws), ", seed = ",
                  fit_get(x, "seed"))
  }
  flags <- fit_get(x, "flags")
  if (length(flags$rhat)) cli::cat_line("! R-hat > 1.1: ", paste(flags$rhat, collapse = ", "))
  b <- flags$boundary
  if (nrow(b)) {
    cli::cat_line("! Posterior piled at a bound: ",
                  paste(sprintf("%s (%s, %.0f%% of draws)", b$input, b$bound, 100 * b$posterior),
                        collapse = ", "))
  }
  cf <- input_conflicts(x)
  if (any(cf$conflict)) {
    cf <- cf[cf$conflict, , drop = FALSE]
    cli::cat_line("! In conflict with their prior (inputs that may mimic a missing effect; where_fails() reads the ",
                  "bias with them held to it): ",
                  paste(sprintf("%s (%+.1f prior sd%s)", cf$input, cf$prior_sds,
                                ifelse(cf$piled,
                                       sprintf(", %.0f%% at its %s bound", 100 * cf$share_at_bound,
                                               cf$side), "")),
                        collapse = ", "))
  }
  held <- fit_get(x, "held")
  if (!is.null(held)) {
    cli::cat_line("Held to their prior: ", paste(held$inputs, collapse = ", "),
                  if (identical(held$how, "reread")) " (the bias read again with them drawn from it)"
                  else sprintf(" (calibrated again at %d strata of it)", nrow(held$values)))
  }
  invisible(x)
}

format_rate <- function(r) ifelse(is.na(r), "-", sprintf("%.2f", r))

# The estimated inputs: a test condition is known (its values are in the
# priors' and the experiments' lines), so it has no row.
input_table <- function(x) {
  X <- fit_draws_matrix(x)
  all_inputs <- fit_get(x, "inputs")
  prior_iu <- fit_get(x, "prior_iu")
  est <- !all_inputs %in% fit_get(x, "conditions")$inputs
  inputs <- all_inputs[est]
  sd_ratio <- apply(X[, inputs, drop = FALSE], 2, stats::sd) /
    (fit_get(x, "prior_sd") %||% prior_sds(prior_iu))[inputs]
  data.frame(input = inputs, type = prior_iu$type[match(inputs, prior_iu$name)],
             mean = colMeans(X[, inputs, drop = FALSE]),
             q2.5 = apply(X[, inputs, drop = FALSE], 2, stats::quantile, 0.025, names = FALSE),
             q97.5 = apply(X[, inputs, drop = FALSE], 2, stats::quantile, 0.975, names = FALSE),
             sd_ratio = unname(sd_ratio),
             rhat = unname(fit_get(x, "rhat")[inputs]),
             ess = round(unname(fit_get(x, "ess")[inputs])),
             stringsAsFactors = FALSE)
}

#' @export
summary.wv_fit <- function(object, ...) {
  X <- fit_draws_matrix(object)
  tau_cols <- setdiff(colnames(X), fit_get(object, "inputs"))
  groups <- fit_get(object, "groups")
  tau <- data.frame(group = groups$name, site = groups$site, level = groups$level,
                    mean = colMeans(X[, tau_cols, drop = FALSE]),
                    q2.5 = apply(X[, tau_cols, drop = FALSE], 2, stats::quantile, 0.025,
                                 names = FALSE),
                    q97.5 = apply(X[, tau_cols, drop = FALSE], 2, stats::quantile, 0.975,
                                  names = FALSE),
                    stringsAsFactors = FALSE)
  rownames(tau) <- NULL
  structure(list(inputs = input_table(object),
                 priors = prior_lines(fit_get(object, "prior_iu"), fit_get(object, "conditions")),
                 noise = noise_lines(object),
                 experiments = experiment_lines(object), tau2 = tau,
                 acceptance = fit_get(object, "acceptance"),
                 flags = fit_get(object, "flags"), settings = fit_get(object, "settings"),
                 n_coef = ncol(fit_get(object, "basis")$Psi), sites = fit_sites(object),
                 top_finding = top_finding(where_fails(object))),
            class = "summary_wv_fit")
}

#' @export
print.summary_wv_fit <- function(x, ...) {
  if (!is.null(x$top_finding)) cli::cat_line(x$top_finding)
  cli::cat_line("Calibration of ", x$n_coef, " coefficients at ", length(x$sites), " site(s): ",
                paste(x$sites, collapse = ", "))
  cli::cat_line(x$settings$chains, " chain(s) of ", x$settings$n_draws, " draws, ",
                x$settings$n_inner, " cycles between draws")
  cli::cat_line("Inputs:")
  print(x$inputs, row.names = FALSE, digits = 3)
  for (line in x$priors) cli::cat_line(line)
  for (line in x$noise) cli::cat_line(line)
  for (line in x$experiments) cli::cat_line(line)
  cli::cat_line("Bias variances tau2 by site and level:")
  print(x$tau2[c("group", "mean", "q2.5", "q97.5")], row.names = FALSE, digits = 3)
  cli::cat_line("Acceptance rates:")
  print(x$acceptance, row.names = FALSE, digits = 3)
  invisible(x)
}

# --- figures ---------------------------------------------------------------------

#' Plot a calibration fit
#'
#' * `"inputs"`: posterior histogram of every input with its prior density
#'   (report Figure 5);
#' * `"bias"`: posterior mean of the bias with its pointwise band, by site
#'   (Figure 6);
#' * `"reality"`: bias-corrected prediction with its band, pure-model
#'   prediction and the field replicates (Figure 7);
#' * `"trace"`: trace of every input by chain.
#'
#' @param object A `wv_fit` object.
#' @param type One of `"inputs"`, `"bias"`, `"reality"`, `"trace"`.
#' @inheritParams bands
#' @param windows Optional list of `c(from, to)` time windows to zoom into,
#'   one column of panels each (`NULL`: the whole record).
#' @param ... Unused.
#' @return A ggplot object.
#' @export
#' @examples
#' fit <- example_fit()
#' autoplot(fit, "inputs")
#' autoplot(fit, "reality")
autoplot.wv_fit <- function(object, type = c("inputs", "bias", "reality", "trace"), level = 0.9,
                            windows = NULL, ...) {
  type <- check_choice(type)
  switch(type,
    inputs = plot_fit_inputs(object),
    trace = plot_fit_trace(object),
    bias = plot_fit_band(with_windows(bias(object, level), windows), NULL, NULL, "bias",
                         sprintf("Bias with %g%% pointwise band", 100 * level)),
    reality = plot_fit_band(with_windows(reality(object, level), windows),
                            with_windows(model_prediction(object, level), windows),
                            with_windows(field_long(fit_get(object, "field")), windows), "output",
                            sprintf("Bias-corrected prediction with %g%% band", 100 * level))
  )
}

#' @export
plot.wv_fit <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}

plot_fit_inputs <- function(fit) {
  X <- fit_draws_matrix(fit)
  inputs <- fit_get(fit, "inputs")
  d <- do.call(rbind, lapply(inputs, function(v) data.frame(input = v, value = X[, v])))
  pr <- fit_get(fit, "prior_iu")
  dens <- do.call(rbind, lapply(seq_along(inputs), function(k) {
    v <- seq(pr$lower[k], pr$upper[k], length.out = 201)
    data.frame(input = inputs[k], value = v, density = iu_prior_density(pr, k, v))
  }))
  d$input <- factor(d$input, levels = inputs)
  dens$input <- factor(dens$input, levels = inputs)
  ggplot2::ggplot(d, ggplot2::aes(.data$value)) +
    ggplot2::geom_histogram(ggplot2::aes(y = ggplot2::after_stat(density)), bins = 30,
                            fill = "grey75", colour = "grey40") +
    ggplot2::geom_line(data = dens, ggplot2::aes(.data$value, .data$density)) +
    ggplot2::facet_wrap(~input, scales = "free") +
    ggplot2::labs(x = "input value (own units)", y = "density",
                  title = "Posterior draws of each input with its prior") +
    ggplot2::theme_bw()
}

plot_fit_trace <- function(fit) {
  draws <- fit_get(fit, "draws")
  inputs <- fit_get(fit, "inputs")
  d <- do.call(rbind, lapply(seq_along(draws), function(ch) {
    m <- as.matrix(draws[[ch]])
    do.call(rbind, lapply(inputs, function(v) {
      data.frame(chain = factor(ch), draw = seq_len(nrow(m)), input = v, value = m[, v])
    }))
  }))
  d$input <- factor(d$input, levels = inputs)
  ggplot2::ggplot(d, ggplot2::aes(.data$draw, .data$value, colour = .data$chain)) +
    ggplot2::geom_line(linewidth = 0.3) +
    ggplot2::facet_wrap(~input, scales = "free_y") +
    ggplot2::labs(x = "saved draw", y = "value", colour = "chain") +
    ggplot2::theme_bw()
}

field_long <- function(field) {
  do.call(rbind, lapply(names(field$curves), function(s) {
    m <- field$curves[[s]]
    data.frame(site = s, t = rep(field$t, each = nrow(m)),
               replicate = factor(rep(seq_len(nrow(m)), length(field$t))),
               y = as.vector(m))
  }))
}

plot_fit_band <- function(band, model, field, ylab, title) {
  p <- ggplot2::ggplot(band, ggplot2::aes(.data$t))
  if (!is.null(field)) {
    p <- p + ggplot2::geom_line(data = field,
                                ggplot2::aes(.data$t, .data$y, group = .data$replicate),
                                colour = "goldenrod2", linewidth = 0.3)
  }
  p <- p +
    ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lower, ymax = .data$upper), fill = "steelblue",
                         alpha = 0.25)
  if (is.null(model)) p <- p + ggplot2::geom_hline(yintercept = 0, colour = "grey50")
  if (!is.null(model)) {
    p <- p + ggplot2::geom_line(data = model, ggplot2::aes(.data$t, .data$mean), colour = "grey50")
  }
  p <- p +
    ggplot2::geom_line(ggplot2::aes(y = .data$lower), linetype = "dashed", linewidth = 0.3) +
    ggplot2::geom_line(ggplot2::aes(y = .data$upper), linetype = "dashed", linewidth = 0.3) +
    ggplot2::geom_line(ggplot2::aes(y = .data$mean)) +
    ggplot2::labs(x = "t", y = ylab, title = title) +
    ggplot2::theme_bw()
  if ("window" %in% names(band)) {
    p + ggplot2::facet_grid(site ~ window, scales = "free")
  } else {
    p + ggplot2::facet_wrap(~site, ncol = 1, scales = "free_y")
  }
}

utils::globalVariables("density")
