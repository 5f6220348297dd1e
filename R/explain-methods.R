# print, summary, autoplot and plot methods of the wv_explain table of
# explain_bias() (autoplot() is documented with explain_bias()).

#' @export
print.wv_explain <- function(x, ...) {
  cli::cat_line("<wv_explain> candidate effects ranked by posterior inclusion probability")
  if (!is.null(attr(x, "finding"))) cli::cat_line("Explaining one finding of where_fails(): ",
                                                  attr(x, "finding"))
  cols <- intersect(c("candidate", "inclusion_prob", "amplitude", "amplitude_lower",
                      "amplitude_upper",
                      "share_explained", "share_of_bias"), names(x))
  df <- as.data.frame(unclass(x)[cols], stringsAsFactors = FALSE)
  num <- vapply(df, is.numeric, logical(1))
  df[num] <- lapply(df[num], signif, digits = 3)
  print(df, row.names = FALSE)
  sub <- attr(x, "subsets")
  revalidated <- identical(attr(x, "method"), "revalidated")
  if ("share_of_bias" %in% cols) {
    cli::cat_line(if (revalidated) {
      paste0("share_explained: the fall of the bias energy with the mechanism in the model, without the ",
             "record-wide levels (an offset or slow trend); share_of_bias: the same on the whole bias")
    } else {
      paste0("share_explained: of the bias the most probable subset of candidates explains, the share the ",
             "candidate alone explains; share_of_bias: of the whole bias")
    })
  }
  cli::cat_line(if (revalidated) {
    "Evidence: the model re-validated with each mechanism added (this decides)"
  } else {
    paste0("Evidence: signatures regressed on the bias (a quick screen; re-validating the model with each ",
           "mechanism added decides, see ?explain_bias)")
  })
  if (revalidated) {
    lbf <- attr(x, "log_bf")
    cli::cat_line("Each candidate a re-validated model, weighed against itself with the mechanism off ",
                  "(log Bayes factor: ",
                  paste(sprintf("%s %.1f", names(lbf), lbf), collapse = ", "), ")")
    cli::cat_line("Most probable: ", sub$subset[1], sprintf(" (%.2f)", sub$probability[1]))
    ins <- attr(x, "inputs")
    for (k in unique(ins$candidate[duplicated(ins$candidate)])) {
      r <- ins[ins$candidate == k, , drop = FALSE]
      cli::cat_line("Inputs added by ", k, ": ", paste(sprintf(
        "%s %.3g [%.3g, %.3g]%s", r$input, r$mean, r$lower, r$upper,
        ifelse(is.na(r$off), " (rate)", sprintf(" (off at %.3g)", r$off))), collapse = ", "))
    }
  } else if (!is.null(sub)) {
    cli::cat_line("Most probable subset: ", sub$subset[1], sprintf(" (%.2f)", sub$probability[1]))
  }
  ver <- attr(x, "versions")
  if (!is.null(ver)) {
    multi <- ver$effect %in% ver$effect[duplicated(ver$effect)]
    top <- ver[multi & !duplicated(ver$effect) & ver$inclusion_prob >= 0.005, , drop = FALSE]
    if (nrow(top)) {
      cli::cat_line("Most probable version of each effect: ",
                    paste(sprintf("%s (%.2f)", top$candidate, top$inclusion_prob), collapse = ", "))
    }
  }
  pos <- attr(x, "positive")
  if (length(pos)) {
    cli::cat_line("Amplitudes constrained to be non-negative: ", paste(pos, collapse = ", "))
  }
  ab <- attr(x, "absorbed")
  if (!is.null(ab)) ab <- ab[ab$absorbed >= 0.75, , drop = FALSE]
  for (k in seq_len(NROW(ab))) {
    cli::cat_line(sprintf(paste0("! %.0f%% of the signature of %s is what moving %s would do: the bias can hardly ",
                                 "tell that effect from a change of %s."),
                          100 * ab$absorbed[k], ab$candidate[k], ab$inputs[k],
                          if (grepl(",", ab$inputs[k])) "those inputs" else "that input"))
  }
  bd <- attr(x, "boundary")
  if (length(bd)) {
    cli::cat_line("! The posterior of ", paste(bd, collapse = ", "),
                  " piles up at a bound of its range: ",
                  "candidates simulated at the posterior mean inputs may differ from the effect at the true ",
                  "inputs; give versions simulated at other inputs too (argument `effect`).")
  }
  eta <- attr(x, "eta")
  if (!is.null(eta) && stats::median(eta) < 0.995) {
    cli::cat_line(sprintf(paste0("Evidence tempered by eta = %.2f (median over draws): the residuals are more ",
                                 "dispersed, or more alike within a time segment, than the regression assumes."),
                          stats::median(eta)))
  }
  invisible(x)
}

#' @export
summary.wv_explain <- function(object, ...) {
  lead <- object[1, , drop = FALSE]
  structure(list(
    leader = lead$candidate,
    inclusion = lead$inclusion_prob,
    n_candidates = nrow(object),
    n_likely = sum(object$inclusion_prob >= 0.5),
    subsets = attr(object, "subsets"),
    eta = if (!is.null(attr(object, "eta"))) stats::median(attr(object, "eta"))
  ), class = "summary_wv_explain")
}

#' @export
print.summary_wv_explain <- function(x, ...) {
  cli::cat_line(sprintf("%d candidate effects; %d with inclusion probability >= 0.5",
                        x$n_candidates, x$n_likely))
  cli::cat_line(sprintf("Leading candidate: %s (inclusion probability %.2f)", x$leader,
                        x$inclusion))
  if (!is.null(x$eta) && x$eta < 0.995) {
    cli::cat_line(sprintf("Evidence tempered by eta = %.2f (median over draws)", x$eta))
  }
  print(utils::head(x$subsets, 5), row.names = FALSE)
  invisible(x)
}

#' @export
plot.wv_explain <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}

#' @rdname explain_bias
#' @param object A `wv_explain` result.
#' @export
autoplot.wv_explain <- function(object, ...) {
  d <- attr(object, "curves")
  ggplot2::ggplot(d, ggplot2::aes(.data$t, .data$value, colour = .data$curve)) +
    ggplot2::geom_hline(yintercept = 0, colour = "grey70") +
    ggplot2::geom_line(linewidth = 0.4) +
    ggplot2::facet_wrap(~site, ncol = 1, scales = "free_y") +
    ggplot2::scale_colour_manual(values = c("black", "#D55E00", "#0072B2",
                                            "#009E73")[seq_along(unique(d$curve))],
                                 breaks = unique(d$curve)) +
    ggplot2::labs(x = "time", y = "bias", colour = NULL,
                  title = "Posterior mean bias and the leading candidate effects, scaled") +
    ggplot2::theme_bw() +
    ggplot2::theme(legend.position = "bottom")
}
