# The findings of where_fails() as one table ranked by size, the sentence
# that says the first of them (print, summary() of a fit, the report), and
# the rows of one kind that the interval readings use.

# The ranked table of findings: the localised `intervals` (with their
# `credible` gap), the credible record-wide parts of `record_wide`, the
# intervals of the bias read with the inputs in conflict held (`held`), the
# inputs' pull (where it moves the model most, by how much), and inputs in
# conflict not read again. `r`: reality's pointwise mean (share of signal of the record-wide
# part); `experiments`: the experiment of each site, or NULL.
findings_table <- function(intervals, record_wide, held, conflicts, r, experiments,
                           proposals = NULL, timing = NULL,
                           misfit = NULL) {
  cols <- c("kind", "site", "start", "end", "size", "credible", "integrated_abs_bias",
            "share_of_signal", "sign",
            "inputs", "event")
  row <- function(kind, site, start, end, size, credible, integrated, share, sign, inputs,
                  event = NA_character_) {
    data.frame(kind = kind, site = site, start = start, end = end, size = size, credible = credible,
               integrated_abs_bias = integrated, share_of_signal = share, sign = sign,
               inputs = inputs,
               event = event, stringsAsFactors = FALSE)
  }
  local <- function(x, kind, inputs) {
    if (!nrow(x)) return(NULL)
    row(kind, x$site, x$start, x$end, x$peak_abs_bias, x$credible, x$integrated_abs_bias,
        x$share_of_signal,
        x$sign, inputs)
  }
  parts <- list(local(intervals, "interval", NA_character_))
  if (!is.null(record_wide) && any(record_wide$credible)) {
    rw <- record_wide[record_wide$credible, , drop = FALSE]
    signal <- vapply(rw$site, function(s) sum(abs(r$mean[r$site == s])) * diff(r$t[1:2]),
                     numeric(1))
    parts <- c(parts, list(row("record-wide", rw$site, rw$start, rw$end, rw$peak_abs_bias,
                               rw$credible_bias,
                               rw$integrated_abs_bias,
                               rw$integrated_abs_bias / pmax(signal, .Machine$double.eps),
                               ifelse(rw$offset > 0, "reality above model", "reality below model"),
                               NA_character_)))
  }
  conflicted <- if (is.null(conflicts)) character() else conflicts$input[conflicts$conflict]
  if (!is.null(held)) {
    who <- paste(held$inputs, collapse = ", ")
    covered <- finding_rows(held$fails, "interval")
    if (nrow(covered)) parts <- c(parts, list(local(covered, "covered", who)))
    # the inputs themselves, where their pull moves the model most: what they took up
    p <- held$pull[which.max(abs(held$pull$shift)), , drop = FALSE]
    parts <- c(parts, list(row("input", p$site, p$start, p$end, abs(p$shift), NA_real_, NA_real_,
                               NA_real_,
                               if (p$shift > 0) "reality above model" else "reality below model",
                               who)))
  } else if (length(conflicted)) {
    parts <- c(parts, list(row("input", NA_character_, NA_real_, NA_real_, NA_real_, NA_real_,
                               NA_real_, NA_real_,
                               NA_character_, paste(conflicted, collapse = ", "))))
  }
  if (!is.null(proposals)) {
    pr <- proposals[proposals$inclusion_prob >= 0.5, , drop = FALSE]
    if (nrow(pr)) {
      parts <- c(parts, list(row("term", pr$site, pr$from, pr$to, pr$peak, NA_real_, NA_real_,
                                 NA_real_,
                                 NA_character_, pr$term)))
    }
  }
  if (!is.null(timing) && any(timing$flagged)) {
    tm <- timing[timing$flagged, , drop = FALSE]
    parts <- c(parts, list(row("timing", tm$site, pmin(tm$field, tm$model),
                               pmax(tm$field, tm$model), tm$size,
                               tm$credible, NA_real_, NA_real_,
                               ifelse(tm$shift > 0, "reality later than model",
                                      "reality earlier than model"),
                               NA_character_, timing_event(tm))))
  }
  if (!is.null(misfit) && nrow(misfit)) {
    # only what the bias's band left out: a stretch that overlaps a finding
    # of the bias at its site (an interval, a covered interval, a record-wide
    # part) says nothing new
    found <- do.call(rbind, c(Filter(Negate(is.null), parts), list(NULL)))
    found <- if (!is.null(found))
      found[found$kind %in% c("interval", "covered", "record-wide"), , drop = FALSE]
    new <- vapply(seq_len(nrow(misfit)), function(i) {
      if (is.null(found) || !nrow(found)) return(TRUE)
      f <- found[found$site %in% misfit$site[i], , drop = FALSE]
      !any(f$start < misfit$end[i] & f$end > misfit$start[i])
    }, logical(1))
    misfit <- misfit[new, , drop = FALSE]
  }
  if (!is.null(misfit) && nrow(misfit)) {
    signal <- vapply(seq_len(nrow(misfit)), function(i) {
      k <- r$site == misfit$site[i] & r$t >= misfit$start[i] & r$t < misfit$end[i]
      sum(abs(r$mean[k])) * diff(r$t[1:2])
    }, numeric(1))
    parts <- c(parts, list(row("misfit", misfit$site, misfit$start, misfit$end, misfit$size,
                               misfit$credible,
                               misfit$integrated,
                               misfit$integrated / pmax(signal, .Machine$double.eps), misfit$sign,
                               NA_character_)))
  }
  out <- do.call(rbind, parts)
  if (is.null(out)) {
    out <- row(character(), character(), numeric(), numeric(), numeric(), numeric(), numeric(),
               numeric(),
               character(), character(), character())
  }
  out <- out[order(-out$size, na.last = TRUE), cols, drop = FALSE]
  if (!is.null(experiments))
    out$experiment <- experiments$experiment[match(out$site, experiments$site)]
  out$peak_abs_bias <- out$size
  out$scale <- c(interval = "local", `record-wide` = "record", covered = "held", input = "held",
                 term = "term", timing = "timing", misfit = "time")[out$kind]
  rownames(out) <- NULL
  out
}

# The rows of a where_fails() table of the given kinds (all its attributes
# kept); a table made before findings had kinds is all intervals.
finding_rows <- function(x, kinds = "interval") {
  if (is.null(x$kind)) return(x)
  x[x$kind %in% kinds, , drop = FALSE]
}

# The first line when there is no finding.
no_finding_text <- function(x) {
  tol <- attr(x, "tolerance")
  band <- sprintf("%g%% %s band", 100 * (attr(x, "level") %||% 0.9),
                  if (identical(attr(x, "band"), "pointwise")) "pointwise" else "whole-curve")
  within <- if (is.null(tol) || all(tol == 0)) "holds zero everywhere" else "lies beyond the tolerance nowhere"
  sprintf("No finding: the %s of the bias %s%s, %s%sno input is in conflict with its prior",
          band, within, if (identical(attr(x, "scales"), "split")) " (the record-wide part and the localised part)" else "",
          if (is.null(attr(x, "misfit"))) "" else "the field mean lies inside the simultaneous band of its pointwise error about the calibrated model, ",
          if (is.null(attr(x, "timing"))) "and " else "no event's timing differs from the model's, and ")
}

# What explain_bias() regresses for the first row of the where_fails() table
# `finding`: the fit (the held re-reading for a misfit an input covered or an
# input in conflict) and which coefficients, all sites stacked in the order
# of fit$wb (`use`; NULL for all): for an interval, those of its site whose
# basis function's support overlaps it (the localised levels only when the
# table read the bias by scale); for a record-wide bias, the record-wide
# levels of its site.
finding_scope <- function(fit, finding, call = rlang::caller_env()) {
  if (!inherits(finding, "wv_fails") || is.null(finding$kind) || !nrow(finding)) {
    wv_abort(c("{.arg finding} must be a row of a {.fn where_fails} table, such as {.code where_fails(fit)[2, ]}.",
               "i" = if (inherits(finding, "wv_fails")) "The table has no finding." else
                 "It is {.obj_type_friendly {finding}}."), call = call)
  }
  r <- finding[1L, ]
  label <- if (is.na(r$site)) sprintf("%s (%s)", r$kind, r$inputs) else
    sprintf("%s at %s [%s, %s]", r$kind, r$site, format(signif(r$start, 4)),
            format(signif(r$end, 4)))
  if (r$kind == "misfit") {
    # read as the localised interval it lies on
    r$kind <- "interval"
  }
  if (r$kind == "timing") {
    wv_abort(c("The finding {label} is a shift of an event's timing, which the registration takes out of the bias.",
               "i" = "Judge a candidate effect by the time it moves that event to: simulate the model with it."),
             class = "finding", call = call)
  }
  if (r$kind %in% c("covered", "input")) {
    hd <- attr(finding, "held", exact = TRUE)
    if (is.null(hd)) {
      wv_abort(c("The finding {label} has no re-reading with {r$inputs} held to the prior to explain.",
                 "i" = "Read it with {.code where_fails(fit, hold = TRUE)}."), call = call)
    }
    fit <- hd$fit
    if (r$kind == "input") return(list(fit = fit, use = NULL, label = label))
  }
  sites <- fit_sites(fit)
  b <- attr(finding, "bias")
  if (!r$site %in% sites || length(unique(b$t)) != length(fit_get(fit, "basis")$t)) {
    wv_abort(c("The finding {label} is not one of {.arg fit}'s.",
               "i" = "Give the fit whose {.fn where_fails} table it comes from; its sites are {.val {sites}}."),
             call = call)
  }
  wide <- fit_get(fit, "basis")$level %in% record_wide_levels(fit_get(fit, "basis"))
  coef <- if (r$kind == "record-wide") wide else {
    t <- fit_get(fit, "basis")$t
    dt <- diff(t[1:2])
    P <- abs(fit_get(fit, "basis")$Psi)
    inside <- t >= r$start - dt / 2 & t < r$end - dt / 2
    overlap <- colSums(sweep(P[inside, , drop = FALSE], 2L, 1e-10 * apply(P, 2L, max), `>`)) > 0
    overlap & (!wide | !identical(attr(finding, "scales"), "split"))
  }
  use <- unlist(lapply(sites, function(s) coef & s == r$site), use.names = FALSE)
  list(fit = fit, use = use,
       label = sprintf("%s, %d coefficient%s", label, sum(coef), if (sum(coef) == 1L) "" else "s"))
}

# The event of each row of a timing table: its landmark's feature and window.
timing_event <- function(tm) sprintf("%s in window %s", tm$feature, tm$window)

# The sentence of a timing finding (row `r` of the table, `tm` the table of
# the landmarks' timing, matched by site and event).
timing_finding_text <- function(r, tm, f) {
  k <- if (is.null(tm) || is.null(r$event)) integer() else
    which(tm$flagged & tm$site == r$site & timing_event(tm) == r$event)
  if (!length(k)) {
    return(sprintf("a shift of an event's timing, %s [%s, %s] (%s)", r$site, f(r$start, 4),
                   f(r$end, 4), r$sign))
  }
  k <- k[1L]
  sprintf("a shift of an event's timing, %s: its %s in window %s comes at %s in the field and at %s in the model at the calibrated inputs, %s by %s [%s, %s]; moved by that shift the curve changes by up to %s there (credibly at least %s)",
          r$site, tm$feature[k], tm$window[k], f(tm$field[k], 4), f(tm$model[k], 4),
          if (tm$shift[k] > 0) "later" else "earlier", f(abs(tm$shift[k])), f(tm$lower[k]),
          f(tm$upper[k]),
          f(r$size), f(r$credible))
}
