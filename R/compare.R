#' Compare two validations of the same system
#'
#' Sets a validation before a model change beside one after it (for example
#' after adding the missing effect that [explain_bias()] pointed to; the
#' "after" model may have extra calibration inputs): how large the bias is,
#' how wide the bands of reality are, and, on held-out field data, how well
#' each predicts.
#'
#' Each fit is judged against its own field data (`fit$field`). The field
#' data are registered to a reference made of the model's runs, so a model
#' that lacks a mechanism which moves the peaks of an event also moves the
#' landmarks of the registered field; after adding the mechanism, register the
#' raw field data again to the new model's runs and give each fit its own
#' registration (and, for held-out data, its own registered held-out field).
#'
#' @param before,after `wv_fit` objects fitted to the same field data (each
#'   possibly registered to its own model's runs).
#' @param holdout Optional held-out field data: a `wv_field` of the same
#'   system (predicted as new field runs of each fit), or a list with `field`
#'   and `before`, `after`: `wv_prediction` objects of each fit for that field
#'   data (e.g. `predict(fit, type = "new_nominal", ...)` for a system with
#'   other nominal inputs). `field` is a `wv_field`, or a list of two,
#'   `before` and `after`, when each model's held-out field is registered to
#'   that model's runs.
#' @inheritParams bands
#' @return A `wv_comparison` data frame with columns `metric`, `before`,
#'   `after`, `change` (relative change, after / before - 1) and rows
#'   `bias_rms` (root mean square of the posterior mean bias over sites and
#'   time), `bias_rms_local` and `bias_rms_record` (the same for its localised
#'   part and for its record-wide part, the levels whose functions span the
#'   whole record, as [where_fails()] splits them: `bias_rms` squared is the
#'   sum of their squares), `bias_peak`, `band_width`, `model_rmse`
#'   (pure-model prediction against the mean of the fitted field data) and,
#'   `inputs_in_conflict` (inputs in conflict with their prior, as
#'   [where_fails()] judges them: an input that mimics a missing effect) and,
#'   with a holdout, `holdout_rmse` (the bias-corrected prediction),
#'   `holdout_rmse_model` (the model alone, the prediction's `model` column)
#'   and `holdout_coverage`. The print ends with a verdict: whether the
#'   conflicts were resolved and, with a holdout, whether the model alone and
#'   the bias-corrected prediction err less there; at a held-out condition an
#'   input that absorbs the missing effect cannot fake an improvement. When the bias grows
#'   but its localised part falls, the print says so: the calibrated inputs
#'   can trade an offset of the whole record against the events.
#' @export
#' @examples
#' before <- example_fit()
#' ex <- example_problem()
#' # in practice `after` is the model with the added effect (see
#' # vignette("missing-effect", package = "wavevalid")); here the same model
#' # with the bias variances held small, to show the layout
#' after <- calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 1, bias = bias_control(fix_tau2 = 1e-4),
#'                    sampler = sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE))
#' cmp <- compare_validations(before, after)
#' cmp
#' autoplot(cmp)
compare_validations <- function(before, after, holdout = NULL, level = 0.9) {
  check_class(before, "wv_fit")
  check_class(after, "wv_fit")
  check_level(level)
  if (!identical(names(before$wb), names(after$wb))) {
    wv_abort("{.arg before} and {.arg after} must have the same sites.")
  }
  if (!isTRUE(all.equal(before$basis$t, after$basis$t))) {
    wv_abort("{.arg before} and {.arg after} must be on the same time grid.")
  }
  conflicts <- list(before = input_conflicts(before), after = input_conflicts(after))
  m_before <- c(validation_metrics(before, level), inputs_in_conflict = sum(conflicts$before$conflict))
  m_after <- c(validation_metrics(after, level), inputs_in_conflict = sum(conflicts$after$conflict))
  if (!is.null(holdout)) {
    preds <- holdout_predictions(before, after, holdout, level)
    m_before <- c(m_before, holdout_metrics(preds$before, preds$field$before))
    m_after <- c(m_after, holdout_metrics(preds$after, preds$field$after))
  }
  out <- data.frame(metric = names(m_before), before = unname(m_before), after = unname(m_after[names(m_before)]),
                    stringsAsFactors = FALSE)
  out$change <- ifelse(out$before == 0 & out$after == 0, 0, out$after / out$before - 1)
  attr(out, "curves") <- list(before = bias(before, level), after = bias(after, level))
  attr(out, "conflicts") <- conflicts
  class(out) <- c("wv_comparison", "data.frame")
  out
}

validation_metrics <- function(fit, level) {
  b <- bias(fit, level)
  r <- reality(fit, level)
  mp <- model_prediction(fit, level)
  fm <- do.call(rbind, lapply(names(fit$field$curves), function(s) {
    data.frame(site = s, t = fit$field$t, y = colMeans(fit$field$curves[[s]]))
  }))
  mp <- merge(mp[c("site", "t", "mean")], fm, by = c("site", "t"))
  wide <- fit$basis$level %in% record_wide_levels(fit$basis)
  c(
    bias_rms = sqrt(mean(b$mean^2)),
    bias_rms_local = part_rms(fit, !wide),
    bias_rms_record = part_rms(fit, wide),
    bias_peak = max(abs(b$mean)),
    band_width = mean(r$upper - r$lower),
    model_rmse = sqrt(mean((mp$mean - mp$y)^2))
  )
}

holdout_predictions <- function(before, after, holdout, level, call = rlang::caller_env()) {
  if (inherits(holdout, "wv_field")) {
    return(list(
      field = list(before = holdout, after = holdout),
      before = stats::predict(before, type = "field_run", level = level),
      after = stats::predict(after, type = "field_run", level = level)
    ))
  }
  fld <- if (is.list(holdout)) holdout$field
  if (inherits(fld, "wv_field")) fld <- list(before = fld, after = fld)
  ok <- is.list(holdout) && is.list(fld) && inherits(fld$before, "wv_field") && inherits(fld$after, "wv_field") &&
    inherits(holdout$before, "wv_prediction") && inherits(holdout$after, "wv_prediction")
  if (!ok) {
    wv_abort(c(
      "{.arg holdout} must be a {.cls wv_field} or a list with {.field field}, {.field before} and {.field after}.",
      "i" = "{.field before} and {.field after} are predictions of each fit for the held-out system.",
      "i" = "{.field field} is a {.cls wv_field}, or a list of two ({.field before}, {.field after}) when each model registers the held-out data to its own runs."
    ), call = call)
  }
  list(field = fld[c("before", "after")], before = holdout$before, after = holdout$after)
}

# RMSE of the prediction mean against each held-out replicate, and the share
# of held-out points inside the band.
holdout_metrics <- function(pred, field, call = rlang::caller_env()) {
  p <- as.data.frame(pred)
  sites <- intersect(unique(p$site), names(field$curves))
  if (!length(sites)) wv_abort("The held-out field data share no site with the prediction.", call = call)
  err <- err_model <- inside <- numeric()
  for (s in sites) {
    ps <- p[p$site == s, ]
    if (!isTRUE(all.equal(ps$t, field$t))) {
      wv_abort("The held-out field data are not on the prediction's grid.", call = call)
    }
    y <- field$curves[[s]]
    err <- c(err, as.vector(sweep(y, 2, ps$mean)))
    err_model <- c(err_model, as.vector(sweep(y, 2, ps$model)))
    inside <- c(inside, as.vector(sweep(y, 2, ps$lower, `>=`) & sweep(y, 2, ps$upper, `<=`)))
  }
  c(holdout_rmse = sqrt(mean(err^2)), holdout_rmse_model = sqrt(mean(err_model^2)), holdout_coverage = mean(inside))
}

#' @export
print.wv_comparison <- function(x, ...) {
  cli::cat_line("<wv_comparison> validation before and after the model change")
  df <- as.data.frame(unclass(x)[c("metric", "before", "after", "change")], stringsAsFactors = FALSE)
  df$before <- signif(df$before, 4)
  df$after <- signif(df$after, 4)
  df$change <- ifelse(is.finite(df$change), sprintf("%+.1f%%", 100 * df$change), "-")
  print(df, row.names = FALSE)
  ch <- stats::setNames(x$change, x$metric)
  if (all(c("bias_rms", "bias_rms_local", "bias_rms_record") %in% names(ch))) {
    if (ch[["bias_rms"]] >= 0 && ch[["bias_rms_local"]] < 0) {
      cli::cat_line("The localised bias fell; what grew is the record-wide part (an offset or a slow trend), which ",
                    "the calibrated inputs can trade against the events: see where_fails() of each fit.")
    }
  }
  for (line in comparison_verdict(x)) cli::cat_line(line)
  invisible(x)
}

# Whether the change helped, and why: the conflicts of the inputs with their
# prior, and the error at the held-out condition (which an input absorbing
# the effect cannot fake), or the fitted data's localised bias without one.
comparison_verdict <- function(x) {
  v <- stats::setNames(x$after, x$metric)
  b <- stats::setNames(x$before, x$metric)
  cf <- attr(x, "conflicts")
  names_of <- function(d) if (is.null(d) || !any(d$conflict)) "none" else paste(d$input[d$conflict], collapse = ", ")
  lines <- character()
  if (!is.null(cf)) {
    before <- names_of(cf$before)
    after <- names_of(cf$after)
    lines <- c(lines, sprintf("Inputs in conflict with their prior: before %s; after %s%s.", before, after,
                              if (before != "none" && after == "none") " (resolved)"
                              else if (after != "none") " (an input still mimics what the model lacks: see where_fails(after))"
                              else ""))
  }
  ratio <- function(m) v[[m]] / b[[m]]
  if ("holdout_rmse_model" %in% names(v)) {
    rm <- ratio("holdout_rmse_model")
    rc <- ratio("holdout_rmse")
    verdict <- if (rm < 1 && rc <= 1.05) {
      "the change helped: the model alone predicts the held-out data better, and the bias-corrected prediction is no worse"
    } else if (rm < 1) {
      "the model alone predicts the held-out data better, but the bias-corrected prediction is worse: the calibration compensates elsewhere (see the inputs' posteriors of each fit)"
    } else if (rc < 1) {
      "the model alone does not predict the held-out data better; only the bias correction does"
    } else {
      "the change did not help at the held-out condition"
    }
    lines <- c(lines, sprintf("At the held-out condition the model alone errs %s times as much as before and the bias-corrected prediction %s times: %s.",
                              format(round(rm, 2), nsmall = 2), format(round(rc, 2), nsmall = 2), verdict))
  } else {
    lines <- c(lines, sprintf("The localised bias is %s times what it was. Without a held-out condition this rests on the fitted data, where an input that absorbs the effect can fake a fall: give holdout = (another experiment, load or dose).",
                              format(round(ratio("bias_rms_local"), 2), nsmall = 2)))
  }
  lines
}

#' @export
summary.wv_comparison <- function(object, ...) {
  structure(list(table = as.data.frame(unclass(object)[c("metric", "before", "after", "change")]),
                 improved = object$metric[ifelse(object$metric == "holdout_coverage",
                                                 object$after > object$before, object$after < object$before)]),
            class = "summary_wv_comparison")
}

#' @export
print.summary_wv_comparison <- function(x, ...) {
  cli::cat_line("Improved after the change: ", if (length(x$improved)) paste(x$improved, collapse = ", ") else "nothing")
  invisible(x)
}

#' @rdname compare_validations
#' @param object A `wv_comparison`.
#' @param ... Unused.
#' @export
autoplot.wv_comparison <- function(object, ...) {
  cv <- attr(object, "curves")
  d <- rbind(cbind(cv$before, model = "before"), cbind(cv$after, model = "after"))
  d$model <- factor(d$model, levels = c("before", "after"))
  ggplot2::ggplot(d, ggplot2::aes(.data$t)) +
    ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lower, ymax = .data$upper), fill = "grey75") +
    ggplot2::geom_hline(yintercept = 0, colour = "grey40", linetype = 2) +
    ggplot2::geom_line(ggplot2::aes(y = .data$mean), linewidth = 0.3) +
    ggplot2::facet_grid(site ~ model, scales = "free_y") +
    ggplot2::labs(x = "time", y = "bias", title = "Bias before and after the model change") +
    ggplot2::theme_bw()
}

#' @export
plot.wv_comparison <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}
