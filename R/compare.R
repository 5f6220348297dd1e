#' Compare two validations of the same system
#'
#' Sets a validation before a model change beside one after it (for example
#' after adding the missing effect that [explain_bias()] pointed to; the
#' "after" model may have extra calibration inputs): how large the bias is,
#' how wide the bands of reality are, and, on held-out field data, how well
#' each predicts.
#'
#' One yardstick: both fits are graded against one target. Validated again
#' with `update(fit, runs = , iu = )` ([update.wv_fit()]), the new model's
#' field data are registered to the reference the first fit registered them
#' to, so the two fits hold the same registered field; the fitted errors
#' (`model_rmse`) are taken net of the registration's shifts as each fit's
#' sampler drew them. A held-out [experiment()] is registered once, as
#' `before` registered its own data (as `after` when only it registered),
#' and both models are graded against it. When the two fits hold
#' differently registered field data, the print says their fitted errors
#' are not comparable.
#'
#' @param before,after `wv_fit` objects fitted to the same field data, e.g.
#'   `fit` and `update(fit, runs = , iu = )` ([update.wv_fit()]).
#' @param holdout Optional held-out condition, in one of these forms:
#'   * an [experiment()] with `change` (another load, mass or dose: the same
#'     unit with a known change of some inputs): each model predicts it
#'     itself, at the posterior draws of its inputs plus the change through
#'     its emulators, plus its bias (as `predict(fit, type = "added_load",
#'     delta = change)`); the change must name inputs of both models;
#'   * an [experiment()] with `condition`: a held-out test condition (a dose
#'     or load never fitted, the fits' I/U maps holding it as a condition
#'     input): each model predicts it as `predict(fit, type =
#'     "new_condition", condition = )` does, the bias carried from the tested
#'     conditions;
#'   * a list of two experiments, `before` and `after`, one for each model:
#'     with their own `change` (when the models name the changed input
#'     differently) or their own `emulators`, fitted to each model's runs at
#'     that condition on that model's basis (`fit_emulators(runs_m,
#'     fit$basis)`), through which each model predicts it at its posterior
#'     draws, plus its bias;
#'   * a `wv_field` of the same system, predicted as new field runs of each
#'     fit (the fitted condition: an input that absorbs a missing effect can
#'     predict it as well as the fix);
#'   * a list with `field` and `before`, `after`: `wv_prediction` objects of
#'     each fit for that field data (e.g. `predict(fit, type = "new_nominal",
#'     ...)`); `field` is a `wv_field`, or a list of two, `before` and
#'     `after`, when each model's held-out field is registered to that
#'     model's runs. Predictions made with `keep_draws = TRUE` (best with
#'     `noise = FALSE`) carry their uncertainty into the verdict.
#'
#'   The held-out field data of one experiment are registered once, as
#'   `before` registered its own: for a fit of [validate()] with `windows`,
#'   to its model in the experiment's condition (see the argument
#'   `experiments` of [validate()]); a fit of [calibrate()] takes them as
#'   given. Both models are graded against that one registered field.
#' @param n_boot Number of paired resamples behind the verdict's intervals.
#' @param seed `NULL` or a whole number: the seed of the predictions and of
#'   the resampling.
#' @inheritParams bands
#' @return A `wv_comparison` data frame with columns `metric`, `before`,
#'   `after`, `change` (after / before - 1) and rows `bias_rms` (root mean
#'   square of the posterior mean bias over sites and time),
#'   `bias_rms_local` and `bias_rms_record` (its localised and record-wide
#'   parts, as [where_fails()] splits them; their squares sum to `bias_rms`
#'   squared), `bias_peak`, `band_width`, `model_rmse` (the model alone
#'   against the fitted field mean, net of the registration's shifts),
#'   `inputs_in_conflict` (as [where_fails()] judges them) and, with a
#'   holdout, `holdout_rmse` (the bias-corrected prediction),
#'   `holdout_rmse_model` (the model alone) and `holdout_coverage`.
#'   Attributes: `holdout_ratio` (rows `model` and `corrected`, columns
#'   `prediction`, `ratio` after / before of the held-out RMSE, `lower` and
#'   `upper` of its 90% interval over the paired resamples; with attributes
#'   `resampling`, `block`, `n_boot`, `n_draws`, `n_curves`, `n_blocks`),
#'   `holdout_field` (the held-out data as each model was graded against),
#'   `same_field` (whether both fits hold the same registered field),
#'   `unmixed` (by fit, inputs with R-hat above 1.1) and `verdict`
#'   (`"helped"`, `"worse"`, `"no clear change"`, `"not judged"`, or `NA`
#'   without a holdout).
#'
#' @section The verdict:
#' The print ends with a verdict: whether the conflicts were resolved and,
#' with a holdout, whether the change helped at the held-out condition, where
#' an input that absorbs the missing effect cannot fake an improvement. Each
#' of `n_boot` paired resamples takes one posterior draw index h of both fits
#' and one resample of the held-out data, the same for both: replicates drawn
#' with replacement when a site has two or more, and within each curve a
#' moving-block bootstrap of its residuals about each model's bias-corrected
#' mean, in blocks of `ceiling(sqrt(T))` points, so that one or two held-out
#' curves still give a verdict (under 20 blocks in all, the print says they
#' are too few to judge firmly). The ratios after / before of the held-out
#' RMSE of the model alone and of the bias-corrected prediction decide:
#' **helped** when the model-alone ratio's 90% interval lies below 1 / 1.05
#' and the bias-corrected ratio's lower limit is not above 1.05; **worse**
#' when the model-alone ratio's lower limit is above 1.05; else **no clear
#' change**. When either fit's chains did not mix (an input's R-hat above
#' 1.1, attribute `unmixed`) the verdict is **not judged**. The 5% margin is
#' there because a decoy effect can take up a little of the misfit: on the
#' test beds, without it, two decoys of ten were called "helped"
#' (`studies/README.md` in the package's source repository, "yardstick.R").
#' Predictions given without draws contribute only the data's resampling.
#' When the bias grows but its localised part falls, the print says so: the
#' calibrated inputs can trade an offset of the whole record against the
#' events.
#' @export
#' @examples
#' before <- example_fit()
#' ex <- example_problem()
#' # in practice `after` is the model with the added effect, validated again
#' # with update(before, runs = , iu = ) (see
#' # vignette("missing-effect", package = "wavevalid")); here the same model
#' # with the bias variances held small, to show the layout
#' after <- calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 1,
#'                    bias = bias_control(fix_tau2 = 1e-4),
#'                    sampler = sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE))
#' cmp <- compare_validations(before, after)
#' cmp
#' autoplot(cmp)
#'
#' # judged at a held-out condition: x1 raised by 0.2 (here its field data
#' # are the fitted ones moved by the model's own change, for the layout)
#' moved <- ex$field
#' moved$curves$site1 <- sweep(moved$curves$site1, 2, 0.1 * sin(2 * pi * moved$t), `+`)
#' cmp_held <- compare_validations(before, after,
#'                                 holdout = experiment(moved, change = c(x1 = 0.2)), seed = 1)
#' cmp_held
#' autoplot(cmp_held, type = "holdout")
compare_validations <- function(before, after, holdout = NULL, level = 0.9, n_boot = 1000,
                                seed = NULL) {
  check_class(before, "wv_fit")
  check_class(after, "wv_fit")
  check_level(level)
  check_number(n_boot, min = 100, integer = TRUE)
  seed <- resolve_seed(seed)
  if (!identical(fit_sites(before), fit_sites(after))) {
    wv_abort("{.arg before} and {.arg after} must have the same sites.")
  }
  if (!isTRUE(all.equal(fit_get(before, "basis")$t, fit_get(after, "basis")$t))) {
    wv_abort("{.arg before} and {.arg after} must be on the same time grid.")
  }
  conflicts <- list(before = input_conflicts(before), after = input_conflicts(after))
  m_before <- c(validation_metrics(before, level),
                inputs_in_conflict = sum(conflicts$before$conflict))
  m_after <- c(validation_metrics(after, level), inputs_in_conflict = sum(conflicts$after$conflict))
  ratio <- NULL
  if (!is.null(holdout)) {
    ho <- holdout_predictions(before, after, holdout, level, seed)
    m_before <- c(m_before, holdout_metrics(ho$before$pred, ho$before$field))
    m_after <- c(m_after, holdout_metrics(ho$after$pred, ho$after$field))
    ratio <- holdout_margin(ho, n_boot, seed)
    ratio$ratio <- c(m_after[["holdout_rmse_model"]] / m_before[["holdout_rmse_model"]],
                     m_after[["holdout_rmse"]] / m_before[["holdout_rmse"]])
    kept <- attributes(ratio)[c("resampling", "block", "n_boot", "n_draws", "interval")]
    ratio <- ratio[c("prediction", "ratio", "lower", "upper")]
    rownames(ratio) <- NULL
    attributes(ratio)[names(kept)] <- kept
  }
  out <- data.frame(metric = names(m_before), before = unname(m_before),
                    after = unname(m_after[names(m_before)]),
                    stringsAsFactors = FALSE)
  out$change <- ifelse(out$before == 0 & out$after == 0, 0, out$after / out$before - 1)
  attr(out, "curves") <- list(before = bias(before, level), after = bias(after, level))
  attr(out, "conflicts") <- conflicts
  attr(out, "holdout_ratio") <- ratio
  attr(out, "holdout_field") <- if (!is.null(holdout)) list(before = ho$before$field,
                                                            after = ho$after$field)
  attr(out, "holdout_predictions") <- if (!is.null(holdout)) list(before = ho$before$pred$summary,
                                                                  after = ho$after$pred$summary)
  unmixed <- unmixed_inputs(list(before = before, after = after))
  attr(out, "verdict") <-
    if (!is.null(ratio) && length(unmixed)) "not judged" else holdout_verdict(ratio)
  attr(out, "unmixed") <- unmixed
  attr(out, "same_field") <- same_field(before, after)
  class(out) <- c("wv_comparison", "data.frame")
  out
}

# "helped", "worse" or "no clear change" from the ratios' intervals (NA
# without a holdout); the rule of the help page's section "The verdict".
holdout_verdict <- function(ratio) {
  if (is.null(ratio)) return(NA_character_)
  m <- ratio[ratio$prediction == "model", ]
  cc <- ratio[ratio$prediction == "corrected", ]
  if (m$upper < 1 / verdict_margin && cc$lower <= verdict_margin) "helped"
  else if (m$lower > verdict_margin) "worse" else "no clear change"
}

# The verdict's margin: a change is judged to help (or to harm) only when
# the model alone's held-out error moves by more than this factor credibly,
# and the bias-corrected prediction may not be credibly worse by more than
# it. A change of a few per cent is what a decoy effect that absorbs some of
# the misfit makes: on the test beds most decoys' noise-free ratios were 0.92
# to 1.13 (one 0.71), the true effects' 0.21 to 0.98, and without the margin
# two decoys of ten were called helped, at 0.95 and 0.94 (studies/README.md,
# "yardstick.R").
verdict_margin <- 1.05

# Fewer independent blocks of held-out data than this, in all the curves, and
# the print says the data are too few to judge: a bootstrap of fewer than
# about 20 blocks gives intervals of unreliable coverage.
min_holdout_blocks <- 20L

verdict_rule <- paste(
  "Rule: helped when the model-alone ratio (after / before of the held-out RMSE) has its 90% interval below",
  "1 / 1.05 (0.952) and the bias-corrected ratio's lower limit is not above 1.05; worse when the model-alone",
  "ratio's lower limit is above 1.05; else no clear change (intervals over paired posterior draws and resamples",
  "of the held-out data)."
)

validation_metrics <- function(fit, level) {
  b <- bias(fit, level)
  r <- reality(fit, level)
  mp <- model_prediction(fit, level)
  fm <- do.call(rbind, lapply(names(fit_get(fit, "field")$curves), function(s) {
    y <- field_mean_curve(fit, s)
    y[!covered_points(fit_get(fit, "field"), s)] <- NA
    data.frame(site = s, t = fit_get(fit, "field")$t, y = y)
  }))
  mp <- merge(mp[c("site", "t", "mean")], fm, by = c("site", "t"))
  wide <- fit_get(fit, "basis")$level %in% record_wide_levels(fit_get(fit, "basis"))
  c(
    bias_rms = sqrt(mean(b$mean^2)),
    bias_rms_local = part_rms(fit, !wide),
    bias_rms_record = part_rms(fit, wide),
    bias_peak = max(abs(b$mean)),
    band_width = mean(r$upper - r$lower),
    model_rmse = sqrt(mean((mp$mean - mp$y)^2, na.rm = TRUE))
  )
}

# The registered field mean at site `s`, net of the registration's shifts
# at their posterior mean when the fit samples them (the target the model's
# error is taken against).
field_mean_curve <- function(fit, s) {
  y <- colMeans(fit_get(fit, "field")$curves[[s]])
  rs <- fit_get(fit, "registration_shifts")
  U <- rs$U[[s]]
  if (is.null(U) || is.null(rs$draws)) return(y)
  dw <- colMeans(as.matrix(rs$draws)) %*% t(U)
  y - drop(tcrossprod(dw, fit_get(fit, "basis")$Psi))
}

# Whether two fits grade their models against the same registered field
# data (the same grid, sites and registered curves).
same_field <- function(a, b) {
  fa <- fit_get(a, "field")$curves
  fb <- fit_get(b, "field")$curves
  identical(names(fa), names(fb)) &&
    isTRUE(all.equal(fit_get(a, "field")$t, fit_get(b, "field")$t)) &&
    all(vapply(names(fa), function(s) isTRUE(all.equal(fa[[s]], fb[[s]], tolerance = 1e-8)),
               logical(1)))
}

# RMSE of the prediction mean against each held-out replicate, and the share
# of held-out points inside the band.
holdout_metrics <- function(pred, field, call = rlang::caller_env()) {
  p <- as.data.frame(pred)
  sites <- intersect(unique(p$site), names(field$curves))
  if (!length(sites)) wv_abort("The held-out field data share no site with the prediction.",
                               call = call)
  err <- err_model <- inside <- numeric()
  for (s in sites) {
    ps <- p[p$site == s, ]
    if (!isTRUE(all.equal(ps$t, field$t))) {
      wv_abort("The held-out field data are not on the prediction's grid.", call = call)
    }
    y <- field$curves[[s]]
    obs <- as.vector(observed_mask(field, s))
    err <- c(err, as.vector(sweep(y, 2, ps$mean))[obs])
    err_model <- c(err_model, as.vector(sweep(y, 2, ps$model))[obs])
    inside <- c(inside, as.vector(sweep(y, 2, ps$lower, `>=`) & sweep(y, 2, ps$upper, `<=`))[obs])
  }
  c(holdout_rmse = sqrt(mean(err^2)), holdout_rmse_model = sqrt(mean(err_model^2)),
    holdout_coverage = mean(inside))
}

#' @export
print.wv_comparison <- function(x, ...) {
  cli::cat_line("<wv_comparison> validation before and after the model change")
  df <- as.data.frame(unclass(x)[c("metric", "before", "after", "change")],
                      stringsAsFactors = FALSE)
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
  if (isFALSE(attr(x, "same_field"))) {
    cli::cat_line("The two fits' field data are registered differently: their fitted errors (model_rmse, bias_rms) ",
                  "are taken against different targets and their ratio is not a change of the model alone. ",
                  "Validate the new model with update(before, runs = , iu = ), which keeps the registration.")
  }
  um <- attr(x, "unmixed")
  if (length(um)) {
    cli::cat_line("Chains that did not mix (R-hat above 1.1): ",
                  paste(sprintf("%s: %s", names(um),
                                vapply(um, function(r) paste(sprintf("%s %.2f", names(r), r),
                                                             collapse = ", "),
                                       "")),
                        collapse = "; "), ".")
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
  names_of <- function(d) if (is.null(d) || !any(d$conflict)) "none" else paste(d$input[d$conflict],
                                                                                collapse = ", ")
  lines <- character()
  if (!is.null(cf)) {
    before <- names_of(cf$before)
    after <- names_of(cf$after)
    lines <- c(lines, sprintf("Inputs in conflict with their prior: before %s; after %s%s.", before,
                              after,
                              if (before != "none" && after == "none") " (resolved)"
                              else if (after != "none") " (an input still mimics what the model lacks: see where_fails(after))"
                              else ""))
  }
  ratio <- function(m) v[[m]] / b[[m]]
  hr <- attr(x, "holdout_ratio")
  if (!is.null(hr)) {
    lines <- c(lines, holdout_lines(hr, attr(x, "verdict") %||% holdout_verdict(hr)))
  } else {
    lines <- c(lines, sprintf("The localised bias is %s times what it was. Without a held-out condition this rests on the fitted data, where an input that absorbs the effect can fake a fall: give holdout = (another experiment, load or dose).",
                              format(round(ratio("bias_rms_local"), 2), nsmall = 2)))
  }
  lines
}

# The verdict at the held-out condition, its ratios with their intervals,
# how they were resampled, and the rule.
holdout_lines <- function(hr, verdict) {
  m <- hr[hr$prediction == "model", ]
  cc <- hr[hr$prediction == "corrected", ]
  why <- switch(verdict,
    helped = paste("the change helped: the model alone predicts the held-out data better by more than the data's",
                   "noise and the predictions' uncertainty produce, and the bias-corrected prediction is not credibly worse"),
    worse = "the change did not help at the held-out condition: the model alone predicts the held-out data credibly worse",
    `not judged` = paste("not judged: the chains of a fit did not mix (R-hat above 1.1), so its draws do not yet",
                         "describe its posterior; run them longer (sampler_control(max_draws = )) and compare again"),
    if (m$upper < 1) {
      paste("no clear change: the model alone predicts the held-out data better, but the bias-corrected prediction",
            "is credibly worse: the calibration compensates elsewhere (see the inputs' posteriors of each fit)")
    } else if (cc$upper < 1) {
      "no clear change: the model alone does not predict the held-out data credibly better; only the bias correction does"
    } else {
      "no clear change: the difference is within what the held-out data's noise and the predictions' uncertainty produce"
    })
  f <- function(z) format(round(z, 2), nsmall = 2)
  blocks <- sprintf("a moving-block bootstrap of each curve's residuals, blocks of %d time points",
                    attr(hr, "block"))
  how <- switch(attr(hr, "resampling") %||% "replicates",
                replicates = paste("the held-out replicates resampled and", blocks),
                moving_block = blocks,
                mixed = paste("replicates resampled where a site has two or more, and", blocks))
  few <- attr(hr, "n_blocks")
  c(sprintf("At the held-out condition the model alone errs %s times as much as before [90%%: %s, %s] and the bias-corrected prediction %s times [%s, %s]: %s.",
            f(m$ratio), f(m$lower), f(m$upper), f(cc$ratio), f(cc$lower), f(cc$upper), why),
    sprintf("(%d paired resamples: %s; %d posterior draw pairs.)", attr(hr, "n_boot"), how,
            attr(hr, "n_draws")),
    if (!is.null(few) && few < min_holdout_blocks) {
      sprintf(paste("The held-out data hold %d blocks in all (%d curve%s): too few to judge a change firmly; the",
                    "intervals are rough. Measure more of the held-out condition, or a longer record."),
              few, attr(hr, "n_curves"), if (attr(hr, "n_curves") == 1L) "" else "s")
    },
    verdict_rule)
}

#' @export
summary.wv_comparison <- function(object, ...) {
  structure(list(table = as.data.frame(unclass(object)[c("metric", "before", "after", "change")]),
                 improved = object$metric[ifelse(object$metric == "holdout_coverage",
                                                 object$after > object$before,
                                                 object$after < object$before)],
                 verdict = attr(object, "verdict") %||% NA_character_,
                 holdout_ratio = attr(object, "holdout_ratio")),
            class = "summary_wv_comparison")
}

#' @export
print.summary_wv_comparison <- function(x, ...) {
  cli::cat_line("Improved after the change: ",
                if (length(x$improved)) paste(x$improved, collapse = ", ") else "nothing")
  hr <- x$holdout_ratio
  if (!is.null(hr)) {
    f <- function(z) format(round(z, 2), nsmall = 2)
    cli::cat_line(sprintf("At the held-out condition: %s (after / before, model alone %s [%s, %s], bias-corrected %s [%s, %s]).",
                          x$verdict, f(hr$ratio[1]), f(hr$lower[1]), f(hr$upper[1]), f(hr$ratio[2]),
                          f(hr$lower[2]),
                          f(hr$upper[2])))
    cli::cat_line(verdict_rule)
  } else {
    cli::cat_line("No held-out condition: no verdict (give holdout = an experiment() of another load, mass or dose).")
  }
  invisible(x)
}

#' @rdname compare_validations
#' @param object A `wv_comparison`.
#' @param type For `autoplot()`: `"bias"` (the default), the bias of each
#'   model on its own field data with its band; `"holdout"`, the error at the
#'   held-out condition (the held-out field mean less each prediction, the
#'   model alone and the bias-corrected one), before and after the change,
#'   with the verdict and its ratios in the title.
#' @param ... Unused.
#' @export
autoplot.wv_comparison <- function(object, type = c("bias", "holdout"), ...) {
  type <- rlang::arg_match(type)
  if (type == "holdout") return(holdout_plot(object))
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

# The held-out error of each model, before and after: the held-out field
# mean (registered as each fit registered its own) less the prediction.
holdout_plot <- function(object) {
  preds <- attr(object, "holdout_predictions")
  fields <- attr(object, "holdout_field")
  if (is.null(preds) || is.null(fields)) {
    wv_abort(c("This comparison has no held-out condition to plot.",
               "i" = "Give {.code compare_validations(before, after, holdout = experiment(...))}."),
             class = "input")
  }
  rows <- list()
  for (m in c("before", "after")) {
    p <- preds[[m]]
    for (s in intersect(unique(p$site), names(fields[[m]]$curves))) {
      ps <- p[p$site == s, , drop = FALSE]
      y <- colMeans(fields[[m]]$curves[[s]])
      y[!covered_points(fields[[m]], s)] <- NA
      rows[[length(rows) + 1L]] <- data.frame(
        t = rep(ps$t, 2L), site = s, model = m,
        prediction = rep(c("model alone", "bias-corrected"), each = nrow(ps)),
        error = c(y - ps$model, y - ps$mean), stringsAsFactors = FALSE)
    }
  }
  d <- do.call(rbind, rows)
  d$model <- factor(d$model, levels = c("before", "after"))
  d$prediction <- factor(d$prediction, levels = c("model alone", "bias-corrected"))
  hr <- attr(object, "holdout_ratio")
  f <- function(z) format(round(z, 2), nsmall = 2)
  sub <- if (!is.null(hr)) {
    sprintf("%s: held-out RMSE after / before, model alone %s [%s, %s], bias-corrected %s [%s, %s]",
            attr(object, "verdict") %||% holdout_verdict(hr), f(hr$ratio[1]), f(hr$lower[1]),
            f(hr$upper[1]),
            f(hr$ratio[2]), f(hr$lower[2]), f(hr$upper[2]))
  }
  ggplot2::ggplot(d, ggplot2::aes(.data$t, .data$error, colour = .data$model)) +
    ggplot2::geom_hline(yintercept = 0, colour = "grey40", linetype = 2) +
    ggplot2::geom_line(linewidth = 0.3) +
    ggplot2::scale_colour_manual(values = c(before = "grey60", after = "black"), name = NULL) +
    ggplot2::facet_grid(site ~ prediction, scales = "free_y") +
    ggplot2::labs(x = "time", y = "held-out field mean less prediction",
                  title = "Error at the held-out condition, before and after the change",
                  subtitle = sub) +
    ggplot2::theme_bw()
}

#' @export
plot.wv_comparison <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}
