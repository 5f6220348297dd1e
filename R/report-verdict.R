# The parts of validation_report() that are built before rendering: the
# verdict in sentences, the assumptions that change the answer, the tables
# of the inputs, the findings, the candidates and the comparison, and the
# figure of one finding's bias on its interval.

# Numbers in sentences: three significant figures.
fmt3 <- function(v) format(signif(v, 3))

# The verdict's sentences (markdown list items without the dash): the
# adequacy for the tolerance, the leading findings, the inputs in conflict,
# the missing effect when candidates were weighed, and the comparison's
# verdict at the held-out condition.
report_verdict <- function(fit, fails, tolerance, expl = NULL, comparison = NULL, n_top = 3L) {
  tol <- attr(fails, "tolerance")
  tol_text <- if (all(tol == tol[1])) fmt3(tol[1]) else
    paste(sprintf("%s at %s", fmt3(tol), names(tol)), collapse = ", ")
  n <- nrow(fails)
  level <- sprintf("%g%%", 100 * (attr(fails, "level") %||% 0.9))
  doubts <- adequacy_doubts(fails, expl)
  unmixed <- unmixed_inputs(list(fit = fit))$fit
  adequacy <- if (length(unmixed)) {
    sprintf("**Not judged**: the chains did not mix (R-hat %s, above 1.1), so neither the bias nor the inputs can be read off them; no verdict of adequacy is given. Draw more (`sampler_control(max_draws = )`), give the input a narrower prior, or reparametrise it, then validate again.",
            paste(sprintf("%s %s", names(unmixed), format(round(unmixed, 2), nsmall = 2)),
                  collapse = ", "))
  } else if (!n && length(doubts)) {
    sprintf("**Not shown adequate**: the %s band of the bias %s, but other readings of the same fit disagree: %s. The verdict rests on them: a wrong model whose misfit the noise, an input or the bias prior's shrinkage took up looks like this.",
            level, if (all(tol == 0)) "holds zero everywhere" else sprintf("lies beyond the tolerance %s nowhere", tol_text),
            paste(doubts, collapse = "; "))
  } else if (!n) {
    if (all(tol == 0)) {
      sprintf("**Adequate**: the %s band of the bias holds zero everywhere and no input is in conflict with its prior (tolerance 0: any credible bias would count).", level)
    } else {
      sprintf("**Adequate for the tolerance %s**: the %s band of the bias lies beyond it nowhere and no input is in conflict with its prior.",
              tol_text, level)
    }
  } else if (all(tol == 0)) {
    sprintf("**Not shown adequate**: %d finding%s where the %s band of the bias excludes zero (tolerance 0; give `tolerance =` the bias the intended use can accept to judge the model against it).",
            n, if (n == 1) "" else "s", level)
  } else {
    sprintf("**Not adequate for the tolerance %s**: %d finding%s where the %s band of the bias lies beyond it.",
            tol_text, n, if (n == 1) "" else "s", level)
  }
  out <- adequacy
  if (n) {
    k <- min(n, n_top)
    lead <- vapply(seq_len(k), function(i) {
      s <- top_finding(fails[i:n, , drop = FALSE])
      sub("^Top finding \\(1 of [0-9]+\\), ", sprintf("Finding %d of %d: ", i, n), s)
    }, character(1))
    out <- c(out, paste0(lead, "."))
  }
  out <- c(out, conflict_sentence(fit, fails))
  if (!is.null(expl) && nrow(expl)) {
    e <- expl[1L, ]
    out <- c(out, sprintf("Missing effect: the most probable candidate is **%s**, inclusion probability %s (it alone explains %s%% of what the candidates explain).",
                          e$candidate, format(round(e$inclusion_prob, 2), nsmall = 2),
                          format(round(100 * e$share_explained))))
  }
  if (!is.null(comparison)) out <- c(out, comparison_sentence(comparison))
  out
}

# The readings of a fit that contradict "adequate" when the bias's band
# finds nothing: a candidate effect the data include at probability 0.5 or
# more, an input whose posterior piles up at a bound of its range, and a
# failing check of where_fails() of another kind than the bias's band.
adequacy_doubts <- function(fails, expl = NULL) {
  out <- character()
  if (!is.null(expl) && nrow(expl) && isTRUE(expl$inclusion_prob[1] >= 0.5)) {
    out <- c(out, sprintf("the candidate effect %s is included at probability %s",
                          expl$candidate[1],
                          format(round(expl$inclusion_prob[1], 2), nsmall = 2)))
  }
  bd <- attr(fails, "boundary")
  if (!is.null(bd) && any(bd$flagged)) {
    piled <- unique(bd$input[bd$flagged])
    out <- c(out, sprintf("the posterior of %s piles up at a bound of %s range (an input acting as a tuning knob)",
                          paste(piled, collapse = ", "),
                          if (length(piled) == 1L) "its" else "their"))
  }
  out
}

# The inputs in conflict with their prior, with where their posterior sits.
conflict_sentence <- function(fit, fails) {
  cf <- attr(fails, "conflicts") %||% input_conflicts(fit)
  if (is.null(cf) || !any(cf$conflict)) return("Inputs in conflict with their prior: none.")
  cf <- cf[cf$conflict, , drop = FALSE]
  each <- sprintf("%s (posterior median %s, %s prior sds from the prior's mean%s)", cf$input,
                  fmt3(cf$median),
                  fmt3(cf$prior_sds), ifelse(cf$piled, ", piled at a bound", ""))
  sprintf("Inputs in conflict with their prior: %s; an input in conflict can mimic what the model lacks.",
          paste(each, collapse = "; "))
}

# Whether the change helped at the held-out condition, with both ratios and
# their intervals; without a holdout, what the fitted data say.
comparison_sentence <- function(comparison) {
  hr <- attr(comparison, "holdout_ratio")
  verdict <- attr(comparison, "verdict")
  if (is.null(hr) || is.null(verdict) || is.na(verdict)) {
    return(paste("Model change (no held-out condition, no verdict):",
                 paste(comparison_verdict(comparison), collapse = " ")))
  }
  f <- function(z) format(round(z, 2), nsmall = 2)
  m <- hr[hr$prediction == "model", ]
  cc <- hr[hr$prediction == "corrected", ]
  word <- switch(verdict, helped = "**helped**", worse = "**did not help** (worse)",
                 `not judged` = "is **not judged** (the chains of a fit did not mix)",
                 "made **no clear change**")
  sprintf("Model change: at the held-out condition it %s: verdict \"%s\"; the model alone errs %s times as much as before (90%% interval %s to %s), the bias-corrected prediction %s times (%s to %s).",
          word, verdict, f(m$ratio), f(m$lower), f(m$upper), f(cc$ratio), f(cc$lower), f(cc$upper))
}

# The assumptions that change the answer: the noise and its source, the
# grouping of the bias prior's variances, the inputs' likelihood.
report_assumptions <- function(fit) {
  c(noise_source_text(fit), bias_prior_text(fit), likelihood_text(fit))
}

# The field noise: its source at each site (replicates, learned in the
# posterior from one replicate, given, the finest level), then its size.
noise_source_text <- function(fit) {
  sites <- fit_sites(fit)
  n <- unlist(fit_get(fit, "n_rep")[sites])
  src <- fit_get(fit, "noise_setting") %||%
    stats::setNames(ifelse(n >= 2, "replicates", "given"), sites)
  each <- vapply(sites, function(s) {
    switch(src[[s]],
           replicates = sprintf("%s estimated from %d replicates", s, n[[s]]),
           learned = if (n[[s]] == 1) {
             sprintf("%s learned in the posterior from one replicate (no replicates to estimate it from)", s)
           } else {
             sprintf("%s learned in the posterior (%d replicates)", s, n[[s]])
           },
           given = sprintf("%s given by the user", s),
           finest = sprintf("%s estimated from the finest wavelet level of one curve", s),
           sprintf("%s %s", s, src[[s]]))
  }, character(1))
  size <- trimws(fit_assumptions(fit, "noise")[-1])
  sprintf("Field noise, source: %s. %s.", paste(each, collapse = "; "),
          paste(size, collapse = "; "))
}

# The grouping of the bias prior's variances.
bias_prior_text <- function(fit) {
  groups <- unique(unlist(fit_get(fit, "bias_group"), use.names = FALSE))
  pooled <- fit_get(fit, "settings")$pool_levels
  bias <- sprintf("Bias prior: one variance per group of wavelet levels, %d group%s (%s)%s.",
                  length(groups),
                  if (length(groups) == 1) "" else "s", paste(groups, collapse = ", "),
                  if (length(pooled)) sprintf("; levels %s pooled",
                                              paste(pooled, collapse = ", ")) else "")
  bias
}

# The inputs' likelihood, when the fit records it.
likelihood_text <- function(fit) {
  lik <- fit_assumptions(fit, "likelihood")
  if (length(lik)) paste0(paste(lik, collapse = " "), ".")
}

# One row per input: type, prior, posterior median and 90% interval, sd
# ratio, R-hat, ESS and whether it is in conflict with its prior.
report_inputs_table <- function(fit) {
  s <- input_table(fit)
  prior_iu <- fit_get(fit, "prior_iu") %||% fit_get(fit, "iu")
  labels <- stats::setNames(prior_labels(prior_iu), as.data.frame(prior_iu)$name)
  d <- do.call(rbind, lapply(fit_get(fit, "draws"), as.matrix))[, s$input, drop = FALSE]
  q <- apply(d, 2, stats::quantile, c(0.5, 0.05, 0.95), names = FALSE)
  cf <- input_conflicts(fit)
  data.frame(input = s$input, type = s$type, prior = unname(labels[s$input]),
             median = signif(q[1, ], 4), `5%` = signif(q[2, ], 4), `95%` = signif(q[3, ], 4),
             sd_ratio = signif(s$sd_ratio, 3), rhat = round(s$rhat, 3), ess = round(s$ess),
             conflict = ifelse(cf$conflict[match(s$input, cf$input)] %in% TRUE, "yes", "no"),
             check.names = FALSE, stringsAsFactors = FALSE, row.names = NULL)
}

# The findings table for the report: rank, kind, site, place, size,
# credible size, share of signal, sign and the inputs that covered it.
report_findings_table <- function(fails) {
  if (!nrow(fails)) return(NULL)
  d <- as.data.frame(fails)
  signif_table(data.frame(rank = seq_len(nrow(d)), kind = d$kind, site = d$site, start = d$start,
                          end = d$end,
                          size = d$size, credible = d$credible, share_of_signal = d$share_of_signal,
                          sign = d$sign,
                          inputs = d$inputs, stringsAsFactors = FALSE), digits = 3)
}

# The comparison's metrics and, with a holdout, its ratios.
report_comparison_tables <- function(comparison) {
  m <- as.data.frame(unclass(comparison)[c("metric", "before", "after", "change")])
  hr <- attr(comparison, "holdout_ratio")
  list(metrics = signif_table(m, digits = 3),
       ratio = if (!is.null(hr))
         signif_table(as.data.frame(hr)[c("prediction", "ratio", "lower", "upper")], digits = 3))
}

# An HTML table (knitr's kable), numbers right-aligned.
html_table <- function(d, caption = NULL) {
  knitr::kable(d, format = "html", caption = caption, row.names = FALSE,
               table.attr = "class=\"table table-condensed\" style=\"width:auto\"")
}

# The bias of the finding in row i of `fails` and its band on the finding's
# interval with a margin of half its length (at least two time steps) each
# side, the interval shaded and the tolerance dashed; NULL for a finding
# with no place (an input not read again).
finding_figure <- function(fails, i) {
  r <- fails[i, ]
  if (is.na(r$site) || is.na(r$start) || r$kind == "timing") return(NULL)
  if (r$kind == "misfit") return(misfit_figure(fails, i))
  b <- switch(r$kind, `record-wide` = attr(fails, "bias_whole"),
              covered = attr(attr(fails, "held")$fails, "bias"), attr(fails, "bias"))
  if (is.null(b)) b <- attr(fails, "bias")
  b <- b[b$site == r$site, , drop = FALSE]
  dt <- diff(b$t[1:2])
  margin <- max((r$end - r$start) / 2, 2 * dt)
  b <- b[b$t >= r$start - margin & b$t <= r$end + margin, , drop = FALSE]
  simultaneous <- !identical(attr(fails, "band"), "pointwise") && !is.null(b$lower_curve)
  b$lo <- if (simultaneous) b$lower_curve else b$lower
  b$hi <- if (simultaneous) b$upper_curve else b$upper
  tol <- (attr(fails, "tolerance") %||% c(0))[r$site]
  p <- ggplot2::ggplot(b, ggplot2::aes(.data$t)) +
    ggplot2::annotate("rect", xmin = r$start, xmax = r$end, ymin = -Inf, ymax = Inf,
                      fill = "#f4cccc", alpha = 0.6) +
    ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lo, ymax = .data$hi), fill = "grey75") +
    ggplot2::geom_hline(yintercept = 0, colour = "grey40", linetype = 2) +
    ggplot2::geom_line(ggplot2::aes(y = .data$mean), linewidth = 0.4)
  if (!is.na(tol) && tol > 0) {
    p <- p + ggplot2::geom_hline(yintercept = c(-tol, tol), colour = "firebrick", linetype = 3)
  }
  p + ggplot2::labs(x = "time", y = "bias",
                    title = sprintf("Finding %d: %s at %s [%s, %s]", i, r$kind, r$site,
                                    fmt3(r$start), fmt3(r$end)),
                    subtitle = sprintf("%s band, the interval shaded",
                                       if (simultaneous) "whole-curve" else "pointwise")) +
    ggplot2::theme_bw(base_size = 10)
}

# A misfit finding: the field mean less the calibrated model on the
# stretch with a margin, and its simultaneous band (misfit_check()).
misfit_figure <- function(fails, i) {
  r <- fails[i, ]
  mc <- attr(fails, "misfit")
  cols <- intersect(c("site", "t", "misfit", "se", "crit", "window_mean", "window_se"), names(mc))
  d <- as.data.frame(unclass(mc)[cols])
  d <- d[d$site == r$site, , drop = FALSE]
  dt <- diff(d$t[1:2])
  margin <- max((r$end - r$start) / 2, 2 * dt)
  d <- d[d$t >= r$start - margin & d$t <= r$end + margin, , drop = FALSE]
  d$lo <- d$misfit - d$crit * d$se
  d$hi <- d$misfit + d$crit * d$se
  d$window_mean <- d$window_mean %||% rep(NA_real_, nrow(d))
  d$window_se <- d$window_se %||% rep(NA_real_, nrow(d))
  d$wlo <- d$window_mean - d$crit * d$window_se
  d$whi <- d$window_mean + d$crit * d$window_se
  ggplot2::ggplot(d, ggplot2::aes(.data$t)) +
    ggplot2::annotate("rect", xmin = r$start, xmax = r$end, ymin = -Inf, ymax = Inf,
                      fill = "#f4cccc", alpha = 0.6) +
    ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lo, ymax = .data$hi), fill = "grey75") +
    ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$wlo, ymax = .data$whi), fill = "#cc4125",
                         alpha = 0.35, na.rm = TRUE) +
    ggplot2::geom_hline(yintercept = 0, colour = "grey40", linetype = 2) +
    ggplot2::geom_line(ggplot2::aes(y = .data$misfit), linewidth = 0.4) +
    ggplot2::geom_line(ggplot2::aes(y = .data$window_mean), colour = "#cc4125", linewidth = 0.6,
                       na.rm = TRUE) +
    ggplot2::labs(x = "time", y = "field mean - model",
                  title = sprintf("Finding %d: misfit at %s [%s, %s]", i, r$site, fmt3(r$start),
                                  fmt3(r$end)),
                  subtitle = "the field mean less the model at the calibrated inputs and its simultaneous band (grey); in red, the mean over the window beyond the band and its band; the stretch shaded") +
    ggplot2::theme_bw(base_size = 10)
}

# A data frame for a report table: numeric columns as text with `digits`
# significant digits (ranges of 1e-7 and of 300 side by side keep their
# figures, which fixed decimals would round to zero), missing values empty.
signif_table <- function(d, digits = 4) {
  d[] <- lapply(d, function(v) {
    if (!is.numeric(v)) return(v)
    out <- trimws(formatC(v, digits = digits, format = "g"))
    out[is.na(v)] <- ""
    out
  })
  d
}
