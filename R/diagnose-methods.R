# print, summary, autoplot and plot methods of the wv_fails table of
# where_fails() (autoplot() is documented with where_fails()).

#' @export
print.wv_fails <- function(x, ...) {
  um <- attr(x, "unmixed")
  if (length(um)) {
    cli::cat_line(sprintf("The chains did not mix (R-hat %s, above 1.1): what follows is not to be trusted. Draw more (sampler_control(max_draws = )), narrow the input's prior or reparametrise it, and validate again.",
                          paste(sprintf("%s %.2f", names(um), um), collapse = ", ")))
  }
  cli::cat_line(top_finding(x))
  lev <- attr(x, "level")
  tol <- attr(x, "tolerance")
  what <- if (is.null(tol) || all(tol == 0)) {
    "excludes zero"
  } else if (length(unique(tol)) == 1L) {
    sprintf("lies beyond the tolerance %s", format(signif(tol[[1]], 3)))
  } else {
    sprintf("lies beyond the tolerance (%s)",
            paste(names(tol), signif(tol, 3), sep = " ", collapse = ", "))
  }
  iv <- finding_rows(x, "interval")
  cli::cat_line(sprintf("<wv_fails> %d finding%s ranked by size (the peak of |posterior mean bias|%s); %d interval%s where the %g%% %s band of the %sbias %s",
                        nrow(x), if (nrow(x) == 1) "" else "s",
                        if (any(x$kind %in% "timing")) ", or for a timing finding the change its shift makes in the curve" else "",
                        nrow(iv), if (nrow(iv) == 1) "" else "s", 100 * lev,
                        if (identical(attr(x, "band"), "pointwise")) "pointwise" else "whole-curve",
                        if (identical(attr(x, "scales"), "split")) "localised " else "", what))
  if (nrow(x)) {
    cols <- intersect(c("kind", "site", "start", "end", "size", "credible", "sign", "inputs",
                        "event",
                        "experiment", "condition"), names(x))
    df <- as.data.frame(unclass(x)[cols], stringsAsFactors = FALSE)
    if (all(is.na(df$inputs))) df$inputs <- NULL
    if (all(is.na(df$event))) df$event <- NULL
    num <- vapply(df, is.numeric, logical(1))
    df[num] <- lapply(df[num], signif, digits = 3)
    print(utils::head(df, 10), row.names = FALSE)
    if (nrow(df) > 10) cli::cat_line(sprintf("... and %d more", nrow(df) - 10))
  }
  nd <- attr(x, "no_data")
  if (!is.null(nd)) {
    cli::cat_line("No field data (no curve reaches): ",
                  paste(sprintf("%s [%s, %s]", nd$site, format(signif(nd$start, 4)), format(signif(nd$end, 4))),
                        collapse = "; "),
                  ". The bias there is its prior's: nothing can be found there.")
  }
  rw <- attr(x, "record_wide")
  if (!is.null(rw)) {
    txt <- sprintf("%s %s [%s, %s]%s", rw$site, format(signif(rw$offset, 3)),
                   format(signif(rw$offset_lower, 3)),
                   format(signif(rw$offset_upper, 3)),
                   ifelse(rw$credible, "", " (not credibly non-zero)"))
    cli::cat_line(sprintf("Record-wide part (levels %s, an offset or a slow trend), its time average: ", rw$levels[1]),
                  paste(txt, collapse = "; "))
  }
  tm <- attr(x, "timing")
  if (!is.null(tm)) {
    cli::cat_line(sprintf("Events' timing, field less model at the calibrated inputs (%d landmark%s, each at %s%% so that together they hold %g%%): %s",
                          nrow(tm), if (nrow(tm) == 1L) "" else "s",
                          format(signif(100 * (1 - (1 - attr(tm, "level")) / nrow(tm)), 3)),
                          100 * attr(tm, "level"),
                          paste(sprintf("%s %s %s %s [%s, %s]%s", tm$site, tm$window, tm$feature,
                                        format(signif(tm$shift, 2)), format(signif(tm$lower, 2)),
                                        format(signif(tm$upper, 2)),
                                        ifelse(tm$flagged, " (a finding)", "")),
                                collapse = "; ")))
  }
  levs <- attr(x, "wavelet_levels")
  if (!is.null(levs)) {
    top <- levs[order(-levs$energy), ][seq_len(min(3, nrow(levs))), ]
    cli::cat_line("Bias energy is highest at wavelet level",
                  if (nrow(top) > 1) "s " else " ",
                  paste(sprintf("%d (%s, %.0f%%)", top$level, top$site, 100 * top$share),
                        collapse = ", "))
    off <- levs$site[levs$level == 0 & levs$significant > 0]
    if (length(off) && !isTRUE(attr(x, "pooled_level0"))) {
      cli::cat_line("The mean of the record (level 0) is credibly off at ",
                    paste(off, collapse = ", "),
                    ". One coefficient barely informs its bias variance, so the calibrated inputs may trade",
                    " that offset against the events; compare with bias_control(pool_levels = \"coarse\"), the default")
    }
  }
  cr <- attr(x, "credible")
  if (!is.null(cr) && any(cr$credible_bias > 0)) {
    k <- which.max(cr$credible_bias)
    cli::cat_line(sprintf("The bias is credibly at least %s (%s, t = %s); a tolerance above that flags nothing",
                          format(signif(cr$credible_bias[k], 3)), cr$site[k],
                          format(signif(cr$t[k], 4))))
  }
  bd <- attr(x, "boundary")
  cf <- attr(x, "conflicts")
  conflicted <- if (is.null(cf)) character() else cf$input[cf$conflict]
  weak <- if (is.null(bd)) character() else setdiff(bd$input[bd$flagged], conflicted)
  if (length(weak)) {
    cli::cat_line("Posterior partly piled up at a bound of its range: ",
                  paste(weak, collapse = ", "),
                  " (an input acting as a tuning knob?)")
  }
  if (length(conflicted)) {
    cli::cat_line("Inputs in conflict with their prior (the data pull them where the prior says they hardly are; ",
                  "an input that mimics a missing effect does this):")
    for (line in conflict_text(cf)) cli::cat_line("  ", line)
    for (line in held_lines(x)) cli::cat_line(line)
  }
  hf <- attr(x, "holds", exact = TRUE)
  if (!is.null(hf)) {
    cli::cat_line(sprintf("This fit holds %s to %s prior: its bias includes what %s covered.",
                          paste(hf$inputs, collapse = ", "),
                          if (length(hf$inputs) == 1L) "its" else "their",
                          if (length(hf$inputs) == 1L) "it" else "they"))
  }
  invisible(x)
}

# What the inputs in conflict covered: the intervals of the bias with them
# held to their prior, or where their pull moves the model most.
held_lines <- function(x) {
  hd <- attr(x, "held", exact = TRUE)
  if (is.null(hd)) {
    if (!is.null(attr(x, "experiments"))) return("Hold them in the fit of each experiment on its own (hold_inputs()) to see what they cover.")
    return("Read the bias with them held to their prior to see what they cover: where_fails(fit, hold = TRUE).")
  }
  who <- paste(hd$inputs, collapse = ", ")
  rms <- signif(hd$bias_rms_local, 3)
  hw <- finding_rows(hd$fails, "interval")
  pull <- hd$pull
  k <- which.max(abs(pull$shift))
  pull_txt <- sprintf("%s [%s, %s] (by %s at t = %s)", pull$site[k],
                      format(signif(pull$start[k], 4)),
                      format(signif(pull$end[k], 4)), format(signif(abs(pull$shift[k]), 3)),
                      format(signif(pull$t[k], 4)))
  if (!nrow(hw)) {
    return(sprintf("With %s held to the prior the localised bias's band still holds zero (root mean square %s, %s as fitted); the pull moves the model most at %s: the misfit %s cover%s, if any, lies there.",
                   who, format(rms[["held"]]), format(rms[["fitted"]]), pull_txt,
                   if (length(hd$inputs) == 1L) "it" else "they",
                   if (length(hd$inputs) == 1L) "s" else ""))
  }
  sprintf("With %s held to the prior, the localised bias's band excludes zero in %d interval%s (the findings of kind \"covered\"; localised bias root mean square %s, %s as fitted); the pull moves the model most at %s.",
          who, nrow(hw), if (nrow(hw) == 1L) "" else "s", format(rms[["held"]]),
          format(rms[["fitted"]]), pull_txt)
}

#' @export
summary.wv_fails <- function(object, ...) {
  iv <- finding_rows(object, "interval")
  structure(list(
    top = top_finding(object),
    kinds = table(factor(object$kind, levels = c("record-wide", "interval", "covered", "input",
                                                 if (any(object$kind == "timing")) "timing",
                                                 if (any(object$kind == "term")) "term",
                                                 if (any(object$kind == "misfit")) "misfit"))),
    n = nrow(iv),
    by_site = if (nrow(iv)) tapply(iv$integrated_abs_bias, iv$site, sum) else numeric(),
    total_length = sum(iv$end - iv$start),
    wavelet_levels = attr(object, "wavelet_levels"),
    boundary = attr(object, "boundary"),
    credible = attr(object, "credible")
  ), class = "summary_wv_fails")
}

#' @export
print.summary_wv_fails <- function(x, ...) {
  cli::cat_line(x$top)
  cli::cat_line("Findings by kind: ",
                paste(sprintf("%s %d", names(x$kinds), x$kinds), collapse = ", "))
  cli::cat_line(sprintf("%d failure intervals covering %.3g time units", x$n, x$total_length))
  if (length(x$by_site)) {
    cli::cat_line("Integrated absolute bias by site: ",
                  paste(sprintf("%s %.3g", names(x$by_site), x$by_site), collapse = ", "))
  }
  if (!is.null(x$credible)) {
    cli::cat_line("Largest credible bias by site: ",
                  paste(sprintf("%s %.3g (t = %.4g)", x$credible$site, x$credible$credible_bias,
                                x$credible$t),
                        collapse = ", "))
  }
  cli::cat_line("Bias energy by wavelet level:")
  lv <- x$wavelet_levels
  lv$share <- round(lv$share, 3)
  lv$energy <- signif(lv$energy, 3)
  print(lv, row.names = FALSE)
  invisible(x)
}

#' @rdname where_fails
#' @param object A `wv_fails` result.
#' @param type `"bias"` (the bias band with the failure intervals shaded) or
#'   `"levels"` (bias energy by wavelet level).
#' @export
autoplot.wv_fails <- function(object, type = c("bias", "levels"), ...) {
  type <- check_choice(type)
  if (type == "levels") {
    lv <- attr(object, "wavelet_levels")
    return(ggplot2::ggplot(lv, ggplot2::aes(factor(.data$level), .data$share)) +
      ggplot2::geom_col(fill = "grey40") +
      ggplot2::facet_wrap(~site) +
      ggplot2::labs(x = "wavelet level (coarse to fine)", y = "share of bias energy",
                    title = "Which time scales carry the bias") +
      ggplot2::theme_bw())
  }
  b <- band_limits(attr(object, "bias"), attr(object, "band") %||% "simultaneous")
  regions <- as.data.frame(unclass(finding_rows(object, "interval"))[c("site", "start", "end")])
  split <- identical(attr(object, "scales"), "split") && !is.null(attr(object, "bias_whole"))
  if (split) {
    rw <- attr(object, "record_wide")
    b$part <- "localised"
    whole <- band_limits(attr(object, "bias_whole"), attr(object, "band") %||% "simultaneous")
    whole$part <- "whole bias"
    b <- rbind(b, whole)
    b$part <- factor(b$part, levels = c("whole bias", "localised"))
    if (nrow(regions)) regions$part <- factor("localised", levels = levels(b$part))
  }
  hd <- attr(object, "held", exact = TRUE)
  held_regions <- pull <- NULL
  if (!is.null(hd)) {
    # the bias with the inputs in conflict held to their prior, in a panel of its own
    lab <- paste0("held: ", paste(hd$inputs, collapse = ", "))
    if (!split) b$part <- "bias"
    hb <- band_limits(attr(hd$fails, "bias"), attr(object, "band") %||% "simultaneous")
    hb$part <- lab
    lev <- c(if (is.factor(b$part)) levels(b$part) else unique(b$part), lab)
    b <- rbind(b[names(hb)], hb)
    b$part <- factor(b$part, levels = lev)
    if (nrow(regions)) regions$part <- factor(if (split) "localised" else "bias", levels = lev)
    held_regions <- as.data.frame(unclass(finding_rows(hd$fails,
                                                       "interval"))[c("site", "start", "end")])
    held_regions$part <- factor(rep(lab, nrow(held_regions)), levels = lev)
    pull <- hd$pull
    pull$part <- factor(rep(lab, nrow(pull)), levels = lev)
    split <- TRUE
  }
  p <- ggplot2::ggplot(b, ggplot2::aes(.data$t))
  if (nrow(regions)) {
    p <- p + ggplot2::geom_rect(data = regions, inherit.aes = FALSE,
                                ggplot2::aes(xmin = .data$start, xmax = .data$end, ymin = -Inf,
                                             ymax = Inf),
                                fill = "#D55E00", alpha = 0.25)
  }
  if (!is.null(pull)) {
    p <- p + ggplot2::geom_rect(data = pull, inherit.aes = FALSE,
                                ggplot2::aes(xmin = .data$start, xmax = .data$end, ymin = -Inf,
                                             ymax = Inf),
                                fill = "#0072B2", alpha = 0.12)
  }
  if (!is.null(held_regions) && nrow(held_regions)) {
    p <- p + ggplot2::geom_rect(data = held_regions, inherit.aes = FALSE,
                                ggplot2::aes(xmin = .data$start, xmax = .data$end, ymin = -Inf,
                                             ymax = Inf),
                                fill = "#D55E00", alpha = 0.25)
  }
  tol <- attr(object, "tolerance")
  if (!is.null(tol) && any(tol > 0)) {
    lines <- data.frame(site = rep(names(tol), 2), y = c(tol, -tol))
    p <- p + ggplot2::geom_hline(data = lines, ggplot2::aes(yintercept = .data$y),
                                 colour = "#D55E00",
                                 linetype = 3)
  }
  p + ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lower, ymax = .data$upper), fill = "grey75") +
    ggplot2::geom_hline(yintercept = 0, colour = "grey40", linetype = 2) +
    ggplot2::geom_line(ggplot2::aes(y = .data$mean), linewidth = 0.3) +
    (if (split) ggplot2::facet_grid(part ~ site, scales = "free_y") else
      ggplot2::facet_wrap(~site, ncol = 1, scales = "free_y")) +
    ggplot2::labs(x = "time", y = "bias",
                  title = paste0("Where the model fails: intervals where the ",
                                 if (split) "localised ",
                                 "bias band ", if (any(tol > 0)) "lies beyond the tolerance" else "excludes zero"),
                  subtitle = paste0(
                    if (identical(attr(object, "scales"), "split")) {
                      paste0("The whole bias; what is left without the record-wide levels (",
                             attr(object, "record_wide")$levels[1], ")")
                    },
                    if (!is.null(hd)) {
                      paste0(if (identical(attr(object, "scales"), "split")) ";\n" else "",
                             "at the bottom with ", paste(hd$inputs, collapse = ", "),
                             " held to the prior (blue: where the pull moves the model most)")
                    })) +
    ggplot2::theme_bw()
}

#' @export
plot.wv_fails <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}

