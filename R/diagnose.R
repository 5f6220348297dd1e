#' Where does the model fail?
#'
#' Lists every finding of a validation in one table ranked by size, the
#' largest first: a credible record-wide bias, the time intervals where the
#' band of the (localised) bias excludes zero, the misfit that inputs in
#' conflict with their prior covered, and those inputs themselves, where
#' their pull moves the model most (what they took up). It also tells at
#' which wavelet levels (time scales) the bias lives and which inputs have a
#' posterior piled up at a bound of their range (an input used as a tuning
#' knob, like the report's `x5`).
#'
#' Every finding has one size in the units of the curves, the peak of the
#' absolute posterior mean bias over it, so that kinds compare: an offset of
#' 0.3 over the record outranks an interval whose bias peaks at 0.05. Its
#' `credible` size is the largest distance of its band from zero (the bias
#' is credibly at least that large there). The print's first line, `summary()`
#' of a fit and [validation_report()] lead with the first row
#' ([top_finding()]); [explain_bias()] takes a row (`finding = x[k, ]`) to
#' explain that finding alone.
#'
#' The bias is read by scale. Its record-wide part, carried by the wavelet
#' levels whose functions each span the whole record (an offset or a slow
#' trend), is one finding of its own (attribute `record_wide`): a model off
#' by a constant is off everywhere, and flagging every time point says no
#' more. The intervals come from the rest, the localised part, so that they
#' point at where the model fails. `scales = "whole"` finds them in the whole
#' bias, as in the method's report. With `tolerance`, only intervals where
#' the band lies wholly beyond `tolerance` are reported: there the bias is
#' credibly larger than the error the intended use can accept.
#'
#' @section Inputs that cover a misfit:
#' A calibrated input that can mimic a missing effect is pulled to the values
#' that mimic it, and the bias shrinks where the effect acts. Such an input
#' is a finding (attribute `conflicts`) when its posterior median lies in the
#' prior's tail beyond `0.05 / (2 p)` on its side (`p` inputs, so that a right
#' model has some input flagged by chance with probability about 5%), or when
#' its posterior presses on a bound: half of it or more within 2% of the range
#' from the bound (and four times the prior's share there), falling away as a
#' normal centred at least `qnorm(1 - 0.05 / (2 p))` of its sd beyond the
#' bound would (`beyond_bound_sd`). A right model whose true input lies near
#' a bound piles its posterior there too, but centred inside or just beyond,
#' so both rules hold the same error (test-bed cases in `studies/README.md`
#' in the package's source repository, "false_findings.R").
#'
#' With `hold = TRUE` (default) the bias is then read again with those inputs
#' held to their prior: reality stays as the fit reads it (`w^M + w^b`, draw
#' by draw), and the model is evaluated with the inputs in conflict drawn from
#' their prior and the others at their posterior draws. The intervals of that
#' bias are findings of kind `"covered"` (attribute `held`); when its band
#' excludes zero nowhere, the inputs are a finding of kind `"input"` placed
#' where their pull moves the model most, sized by that move. Give the row to
#' [explain_bias()] (`finding =`), or `attr(x, "held")$fit`, to ask which
#' effect is missing there; [hold_inputs()] calibrates the other inputs again
#' with those held.
#'
#' @section Events' timing:
#' Registration moves every replicate's landmarks onto the reference's, so a
#' difference of timing between reality and the model leaves no trace in the
#' bias; the landmarks keep it. For a fit made by [validate()] with `windows`,
#' each landmark's time in the field (the replicates' mean before
#' registration, Student t on R - 1 degrees of freedom) is compared with its
#' time in the model at the calibrated inputs (the landmark on every run,
#' regressed on the runs' inputs, at every posterior draw). A landmark is a
#' finding of kind `"timing"` when the interval of the difference at
#' `1 - (1 - level) / K` (`K` landmarks) excludes zero; its `size` is the
#' largest change that shift makes in the field mean near the event. It needs
#' two replicates or more. On the dosing test bed a hidden absorption lag,
#' which the registration aligns away, was found at every dose
#' (`studies/README.md`, "false_findings.R").
#'
#' @inheritParams bands
#' @param band `"simultaneous"` (default): the narrowest band holding whole
#'   bias curves with probability `level` (see [bias()]), so that a bias curve
#'   that is zero everywhere is flagged nowhere with probability about
#'   `level`; `"pointwise"`: the pointwise band, which excludes zero at about
#'   `1 - level` of the grid points even where there is no bias, and so flags
#'   many short intervals by chance.
#' @param min_steps Shortest interval reported, in grid steps.
#' @param tolerance The bias the intended use can accept, in the units of the
#'   curves: a non-negative number, or a named vector with one per site. `0`
#'   (default) reports every interval where the band excludes zero.
#' @param scales `"split"` (default): the record-wide part of the bias
#'   reported on its own and the intervals found in the rest; `"whole"`: the
#'   intervals found in the whole bias.
#' @param hold If `TRUE` (default), read the bias again with the inputs in
#'   conflict with their prior held to it (see the section Inputs that cover a
#'   misfit). Fits of several experiments report their conflicts without it.
#' @param proposals `NULL` or a `wv_proposals` table of [propose_terms()] on
#'   this fit: each proposed term (inclusion probability 0.5 or more) joins
#'   the table as a finding of kind `"term"`, placed and sized where its
#'   effect is largest, even where the bias band holds zero everywhere (an
#'   input with a flat prior that took the effect up).
#' @param ... Must be empty: an unknown argument is an error.
#' @return A `wv_fails` data frame with one row per finding, ranked by `size`
#'   (an input in conflict not read again last): `kind` (`"record-wide"`,
#'   `"interval"`, `"covered"`, `"input"`, `"timing"`, `"term"` with
#'   `proposals`, or `"misfit"`: a stretch where the field mean lies beyond
#'   the model at the calibrated inputs by more than its own error's band,
#'   see [misfit_check()]), `site`, `start`, `end`, `size`, `credible`,
#'   `integrated_abs_bias`, `share_of_signal` (that integral over the
#'   integral of the absolute predicted reality), `sign` (model above or below
#'   reality), `inputs` (those that covered it), `event` (for `"timing"`, e.g.
#'   `"max in window 2"`), `experiment` (several experiments), `condition`
#'   (with test conditions, [iu_map()]), `peak_abs_bias` (= `size`) and
#'   `scale` (`"record"`, `"local"`, `"held"`). Keep the rows of kind
#'   `"interval"` for the intervals alone, as [flagged_share()] does.
#'   Attributes: `wavelet_levels` (bias energy by site and level), `boundary`
#'   (each input's posterior share within 2% of each bound, `flagged` at 10%
#'   and four times the prior's share), `bias` and `bias_whole` (the bands),
#'   `misfit` (the [misfit_check()]), `tolerance`, `credible` (by site, the
#'   largest credible bias and where), `record_wide` (by site: its `levels`,
#'   `offset` with `offset_lower`, `offset_upper`, `credible_bias`,
#'   `credible`, `peak_abs_bias`, `integrated_abs_bias`, `start`, `end`),
#'   `experiments`, `conflicts` (one row per input: `median`, `prior_mean`,
#'   `prior_sd`, `prior_sds`, `side`, `prior_tail`, `share_at_bound`,
#'   `prior_share_at_bound`, `beyond_bound_sd`, `far`, `piled`, `conflict`),
#'   `held` (the `inputs` held, the re-read `fit` and its `fails`, the `pull`
#'   by site and `bias_rms_local` as fitted and held) and `timing` (one row per
#'   landmark: `site`, `window`, `feature`, `field` and `model` times, `shift`
#'   with `lower`, `upper`, `flagged`, `size`, `credible`) and `unmixed` (the
#'   R-hat, above 1.1, of each input whose chains did not mix: the print then
#'   leads with it, and the report gives no verdict), `no_data` (site,
#'   `start`, `end` where no field curve reaches, curves of their own
#'   extent; `NULL` when there is none). `as.data.frame()`
#'   gives a plain data frame, with `covered_by` when inputs were held.
#' @export
#' @examples
#' # a small problem whose field has a bump near t = 0.25 that the model lacks
#' fit <- example_fit()
#' wf <- where_fails(fit)
#' wf
#' top_finding(wf)
#' # the intervals alone
#' wf[wf$kind == "interval", ]
#' attr(wf, "wavelet_levels")
#' # only where the bias is credibly larger than 0.1
#' where_fails(fit, tolerance = 0.1)
#' autoplot(wf)
where_fails <- function(fit, level = 0.9, band = c("simultaneous", "pointwise"), min_steps = 1L,
                        tolerance = 0, scales = c("split", "whole"), hold = TRUE, proposals = NULL,
                        ...) {
  check_dots_none(...)
  fails_table(fit, level, band, min_steps, tolerance, scales, hold, proposals)
}

# where_fails() itself; `misfit`: whether to run misfit_check() (not for the
# re-reading with inputs held, whose misfit is the fit's own).
fails_table <- function(fit, level = 0.9, band = c("simultaneous", "pointwise"), min_steps = 1L,
                        tolerance = 0,
                        scales = c("split", "whole"), hold = TRUE, proposals = NULL,
                        misfit = TRUE) {
  check_class(fit, "wv_fit")
  if (!is.null(proposals)) check_proposals_of(proposals, fit)
  check_level(level)
  band <- check_choice(band)
  scales <- check_choice(scales)
  check_number(min_steps, min = 1, integer = TRUE)
  check_flag(hold)
  tol <- site_tolerance(tolerance, fit_sites(fit))
  b_whole <- bias(fit, level = level)
  basis <- fit_get(fit, "basis")
  wide_levels <- record_wide_levels(basis)
  wide <- basis$level %in% wide_levels
  b <- if (scales == "split") bias_part(fit, !wide, level) else b_whole
  r <- reality_mean(fit)  # only reality's pointwise mean is used (share_of_signal)
  dt <- diff(basis$t[1:2])
  gap <- band_gap(band_limits(b, band))
  rows <- lapply(unique(b$site), function(s) {
    bs <- b[b$site == s, ]
    rs <- r[r$site == s, ]
    gs <- gap[b$site == s]
    excl <- gs > tol[[s]]
    runs <- rle(excl)
    ends <- cumsum(runs$lengths)
    starts <- ends - runs$lengths + 1L
    keep <- runs$values & runs$lengths >= min_steps
    if (!any(keep)) return(NULL)
    do.call(rbind, lapply(which(keep), function(k) {
      idx <- starts[k]:ends[k]
      ib <- sum(abs(bs$mean[idx])) * dt
      data.frame(
        site = s, start = bs$t[starts[k]], end = bs$t[ends[k]] + dt,
        peak_abs_bias = max(abs(bs$mean[idx])), credible = max(gs[idx]),
        integrated_abs_bias = ib,
        share_of_signal = ib / max(sum(abs(rs$mean[idx])) * dt, .Machine$double.eps),
        sign = if (mean(bs$mean[idx]) > 0) "reality above model" else "reality below model",
        stringsAsFactors = FALSE
      )
    }))
  })
  intervals <- do.call(rbind, rows)
  if (is.null(intervals)) {
    intervals <- data.frame(site = character(), start = numeric(), end = numeric(),
                            peak_abs_bias = numeric(),
                            credible = numeric(), integrated_abs_bias = numeric(),
                            share_of_signal = numeric(),
                            sign = character(), stringsAsFactors = FALSE)
  }
  cf <- input_conflicts(fit)
  held <- NULL
  if (hold && any(cf$conflict) && is.null(fit_get(fit, "experiments"))) {
    hf <- reread_held(fit, cf$input[cf$conflict])
    hw <- fails_table(hf, level = level, band = band, min_steps = min_steps, tolerance = tolerance,
                      scales = scales, hold = FALSE, misfit = FALSE)
    held <- list(inputs = fit_get(hf, "held")$inputs, fit = hf, fails = hw,
                 pull = pull_support(fit, hf, !wide),
                 bias_rms_local = c(fitted = part_rms(fit, !wide), held = part_rms(hf, !wide)))
  }
  rw <- if (scales == "split") record_wide_bias(fit, wide, wide_levels, level, band, tol)
  tm <- timing_table(fit, level)
  if (!is.null(tm)) tm$flagged <- tm$flagged & tm$credible > tol[tm$site]
  mc <- if (misfit) misfit_check(fit, level)
  ms <- if (!is.null(mc)) misfit_stretches(mc, tol, min_steps)
  out <- findings_table(intervals, rw, held, cf, r, fit_get(fit, "experiments"), proposals, tm, ms)
  if (!is.null(fit_get(fit, "conditions"))) {
    # the condition of each finding's experiment ("base" without experiments)
    labs <- condition_labels(fit_get(fit, "conditions"))
    out$condition <- unname(labs[out$experiment %||% rep("base", nrow(out))])
  }
  att <- list(wavelet_levels = bias_by_level(fit, level), boundary = boundary_check(fit), bias = b,
              bias_whole = b_whole, scales = scales, record_wide = rw, level = level, band = band,
              tolerance = tol, credible = credible_with_misfit(credible_bias(b, gap), mc),
              pooled_level0 = 0 %in% fit_get(fit, "settings")$pool_levels,
              experiments = fit_get(fit, "experiments"),
              conflicts = cf, held = held, holds = fit_get(fit, "held"), timing = tm, misfit = mc,
              unmixed = unmixed_inputs(list(fit = fit))$fit, no_data = no_data_stretches(fit))
  for (nm in names(att)) attr(out, nm) <- att[[nm]]
  class(out) <- c("wv_fails", "data.frame")
  out
}

# Where no field curve of a site reaches (curves of their own extent): a
# data frame of site, start and end, NULL when every point has data.
no_data_stretches <- function(fit) {
  field <- fit_get(fit, "field")
  t <- fit_get(fit, "basis")$t
  out <- do.call(rbind, lapply(names(field$observed), function(s) {
    none <- !covered_points(field, s)
    if (!any(none)) return(NULL)
    r <- rle(none)
    ends <- cumsum(r$lengths)
    starts <- ends - r$lengths + 1L
    data.frame(site = s, start = t[starts[r$values]], end = t[ends[r$values]], stringsAsFactors = FALSE)
  }))
  if (!is.null(out) && nrow(out)) out
}

# The bias band of the part of the bias carried by the coefficients `keep`.
bias_part <- function(fit, keep, level) {
  do.call(rbind, lapply(fit_sites(fit), function(s) {
    W <- fit_get(fit, "wb")[[s]][, keep, drop = FALSE]
    Psi <- fit_get(fit, "basis")$Psi[, keep, drop = FALSE]
    src <- curve_source(nrow(W), nrow(Psi), NULL, list(W = W, B = Psi, offset = numeric()))
    band_frame(src, fit_get(fit, "basis")$t, s, level)
  }))
}

# The record-wide part of the bias by site: its time average (an offset) with
# its credible interval, and its credible size (the largest distance of its
# band from zero), against the tolerance.
record_wide_bias <- function(fit, wide, wide_levels, level, band, tol) {
  a <- (1 - level) / 2
  part <- bias_part(fit, wide, level)
  gap <- band_gap(band_limits(part, band))
  basis <- fit_get(fit, "basis")
  do.call(rbind, lapply(fit_sites(fit), function(s) {
    avg <- drop(fit_get(fit, "wb")[[s]][, wide, drop = FALSE] %*%
                colMeans(basis$Psi[, wide, drop = FALSE]))
    k <- which(part$site == s)
    at <- k[which.max(gap[k])]
    dt <- diff(part$t[k[1:2]])
    data.frame(site = s, levels = paste(range(intersect(wide_levels, basis$level)), collapse = "-"),
               offset = mean(avg), offset_lower = stats::quantile(avg, a, names = FALSE),
               offset_upper = stats::quantile(avg, 1 - a, names = FALSE),
               credible_bias = gap[at], t = part$t[at], credible = gap[at] > tol[[s]],
               peak_abs_bias = max(abs(part$mean[k])),
               integrated_abs_bias = sum(abs(part$mean[k])) * dt,
               start = part$t[k[1]], end = part$t[k[length(k)]] + dt, stringsAsFactors = FALSE)
  }))
}

#' @export
as.data.frame.wv_fails <- function(x, row.names = NULL, optional = FALSE, ...) {
  out <- as.data.frame(unclass(x)[names(x)], stringsAsFactors = FALSE)
  if (!is.null(attr(x, "held", exact = TRUE))) out$covered_by <- ifelse(out$scale == "held",
                                                                        out$inputs, NA_character_)
  rownames(out) <- row.names
  out
}

# The bias data frame `b` with `lower`, `upper` the limits of `band` (the
# whole-curve band's are `lower_curve`, `upper_curve`).
band_limits <- function(b, band) {
  if (band == "simultaneous") {
    b$lower <- b$lower_curve
    b$upper <- b$upper_curve
  }
  b
}

# Distance of the band from zero at each row (0 where it holds zero): the
# band lies beyond a tolerance where this exceeds it.
band_gap <- function(b) pmax(b$lower, -b$upper, 0)

# The largest bias the band makes credible, by site: the largest `gap`, and
# where. A tolerance above it flags nothing.
# The credible bias by site, raised to the misfit check's where its
# rejected stretches lie farther beyond their band than the bias's band
# lies from zero (two readings of one quantity: a tolerance above the larger
# flags nothing).
credible_with_misfit <- function(cr, mc) {
  if (is.null(mc)) return(cr)
  gap <- ifelse(mc$rejected, mc$excess %||% pmax(abs(mc$misfit) - mc$crit * mc$se, 0), 0)
  for (i in seq_len(nrow(cr))) {
    k <- which(mc$site == cr$site[i])
    j <- k[which.max(gap[k])]
    if (length(j) && gap[j] > cr$credible_bias[i]) {
      cr$credible_bias[i] <- gap[j]
      cr$t[i] <- mc$t[j]
    }
  }
  cr
}

credible_bias <- function(b, gap) {
  do.call(rbind, lapply(unique(b$site), function(s) {
    i <- which(b$site == s)
    k <- i[which.max(gap[i])]
    data.frame(site = s, t = b$t[k], credible_bias = gap[k], stringsAsFactors = FALSE)
  }))
}

# where_fails()'s tolerance as a named vector by site.
site_tolerance <- function(tolerance, sites, call = rlang::caller_env()) {
  if (!is.numeric(tolerance) || length(tolerance) == 0L || anyNA(tolerance) ||
      any(!is.finite(tolerance)) ||
      any(tolerance < 0)) {
    wv_abort("{.arg tolerance} must hold non-negative finite numbers.", call = call)
  }
  if (length(tolerance) == 1L && is.null(names(tolerance))) {
    return(stats::setNames(rep(tolerance, length(sites)), sites))
  }
  nm <- names(tolerance)
  if (is.null(nm) || anyDuplicated(nm) || !setequal(nm, sites)) {
    wv_abort(c(
      "{.arg tolerance} must be one number or a vector named by site, one value per site.",
      "i" = "The fit's sites are {.val {sites}}."
    ), call = call)
  }
  tolerance[sites]
}

# Bias energy (posterior mean of the squared bias coefficients) by site and
# level, with the number of coefficients whose interval excludes zero.
bias_by_level <- function(fit, level) {
  a <- (1 - level) / 2
  do.call(rbind, lapply(fit_sites(fit), function(s) {
    wb <- fit_get(fit, "wb")[[s]]
    e <- colMeans(wb^2)
    q <- pointwise_quantiles(wb, c(a, 1 - a))
    lo <- q[1, ]
    hi <- q[2, ]
    lev <- fit_get(fit, "basis")$level
    out <- data.frame(
      site = s,
      level = sort(unique(lev)),
      n_coef = as.vector(table(lev)),
      energy = as.vector(tapply(e, lev, sum)),
      significant = as.vector(tapply(lo > 0 | hi < 0, lev, sum)),
      stringsAsFactors = FALSE
    )
    out$share <- out$energy / sum(out$energy)
    out
  }))
}

#' How much of a known effect does where_fails() flag?
#'
#' The share of the grid points where a known effect acts (its absolute value
#' above `threshold` times its peak) that lie in an interval flagged by
#' [where_fails()] (its rows of kind `"interval"`), by site. On a test bed,
#' with the effect of the hidden mechanism at the true inputs (from [testbed_signatures()]), it says
#' whether the diagnosis looks in the right place.
#'
#' Flags that cover the whole record cover the effect too. `of = "flags"`
#' gives the other side: the share of the flagged points where the effect
#' acts. Flags thrown at random would score the share of the grid where it
#' acts (attribute `acting`); flags that lie where the effect acts score
#' well above it.
#'
#' @param fails A `wv_fails` result of [where_fails()].
#' @param effect A named list by site of curves on the fit's grid.
#' @param threshold Share of the effect's peak above which it counts as acting.
#' @param of `"effect"` (default): the share of the points where the effect
#'   acts that are flagged; `"flags"`: the share of the flagged points where
#'   the effect acts (`NA` at a site with no flag).
#' @return A named numeric vector by site (`NA` where the effect is zero),
#'   with attribute `acting`: the share of the grid where the effect acts.
#' @export
#' @examples
#' fit <- example_fit()
#' t <- fit$field$t
#' # the field data of the example carry a bump near t = 0.25 that the model lacks
#' bump <- list(site1 = 0.3 * exp(-((t - 0.25) / 0.05)^2))
#' flagged_share(where_fails(fit), bump)
#' # how much of what is flagged lies on the bump
#' flagged_share(where_fails(fit), bump, of = "flags")
flagged_share <- function(fails, effect, threshold = 0.1, of = c("effect", "flags")) {
  check_class(fails, "wv_fails")
  check_number(threshold, min = 0, max = 1)
  of <- check_choice(of)
  b <- attr(fails, "bias")
  intervals <- finding_rows(fails, "interval")
  sites <- unique(b$site)
  if (!is.list(effect) || is.null(names(effect)) || !all(names(effect) %in% sites)) {
    wv_abort(c("{.arg effect} must be a list of curves named by site.",
               "i" = "The fit's sites are {.val {sites}}."))
  }
  out <- vapply(names(effect), function(s) {
    t <- b$t[b$site == s]
    y <- effect[[s]]
    if (!is.numeric(y) || length(y) != length(t) || anyNA(y)) {
      wv_abort(c("The effect at site {.val {s}} is not a curve on the fit's grid.",
                 "x" = "It has {length(y)} value{?s}; the grid has {length(t)} points."))
    }
    peak <- max(abs(y))
    if (peak == 0) return(c(NA_real_, 0))
    acts <- abs(y) > threshold * peak
    w <- intervals[intervals$site == s, , drop = FALSE]
    flagged <- Reduce(`|`, lapply(seq_len(nrow(w)), function(k) t >= w$start[k] & t < w$end[k]),
                      rep(FALSE, length(t)))
    share <- if (of == "effect") mean(flagged[acts]) else
      if (any(flagged)) mean(acts[flagged]) else NA_real_
    c(share, mean(acts))
  }, numeric(2))
  structure(out[1L, ], acting = out[2L, ])
}

# Root mean square over sites and time of the posterior mean of the part of
# the bias carried by the coefficients `keep`.
part_rms <- function(fit, keep) {
  Psi <- fit_get(fit, "basis")$Psi[, keep, drop = FALSE]
  sq <- vapply(fit_sites(fit), function(s) {
    m <- drop(Psi %*% colMeans(fit_get(fit, "wb")[[s]][, keep, drop = FALSE]))
    sum(m^2)
  }, numeric(1))
  sqrt(sum(sq) / (nrow(Psi) * length(sq)))
}

#' The first finding, in a sentence
#'
#' The sentence with which the print of [where_fails()], `summary()` of a fit
#' and [validation_report()] begin: the largest finding (the first row of
#' the `where_fails()` table), with its kind, site, place, size, credible
#' size and the inputs that covered it, or, with no finding, that the bias
#' band holds zero everywhere and no input is in conflict with its prior.
#'
#' @param x A `wv_fails` table ([where_fails()]) or a `wv_fit` (whose
#'   `where_fails()` is read with its defaults).
#' @param ... Must be empty: an unknown argument is an error.
#' @return One string.
#' @export
#' @examples
#' fit <- example_fit()
#' top_finding(where_fails(fit))
#' # a tolerance above every credible bias leaves no finding
#' top_finding(where_fails(fit, tolerance = 1))
top_finding <- function(x, ...) {
  check_dots_none(...)
  if (inherits(x, "wv_fit")) x <- where_fails(x)
  check_class(x, "wv_fails")
  f <- function(v, d = 3) format(signif(v, d))
  if (is.null(x$kind) || !nrow(x)) return(no_finding_text(x))
  r <- x[1L, ]
  n <- nrow(x)
  place <- sprintf("%s [%s, %s]", r$site, f(r$start, 4), f(r$end, 4))
  what <- switch(r$kind,
    interval = sprintf("an interval, %s: the localised bias peaks at |bias| %s and is credibly at least %s (%s)",
                       place, f(r$size), f(r$credible), r$sign),
    `record-wide` = sprintf("a record-wide bias (an offset or a slow trend), %s: it peaks at |bias| %s and is credibly at least %s (%s)",
                            r$site, f(r$size), f(r$credible), r$sign),
    covered = sprintf("a misfit covered by %s, %s: with %s held to the prior the localised bias peaks at |bias| %s and is credibly at least %s (%s)",
                      r$inputs, place, r$inputs, f(r$size), f(r$credible), r$sign),
    term = sprintf("a proposed term, %s (propose_terms()): its effect peaks at %s, %s",
                   r$inputs, f(r$size), place),
    timing = timing_finding_text(r, attr(x, "timing"), f),
    misfit = sprintf("a misfit that the shrinkage of the bias left out, %s: the field mean lies beyond the model at the calibrated inputs by up to %s, credibly at least %s, beyond the %g%% simultaneous band of its own pointwise error (%s; see misfit_check())",
                     place, f(r$size), f(r$credible), 100 * (attr(x, "level") %||% 0.9), r$sign),
    input = if (is.na(r$site)) {
      sprintf("an input in conflict with its prior, %s, not read again held to it (where_fails(fit, hold = TRUE) places what it covers)",
              r$inputs)
    } else {
      sprintf("an input in conflict with its prior, %s: its pull moves the model most at %s, by %s; %s",
              r$inputs, place, f(r$size),
              if (any(x$kind == "covered")) "held to its prior, the bias band excludes zero where the findings of kind \"covered\" lie"
              else "held to its prior, the bias band still holds zero")
    })
  sprintf("Top finding (1 of %d), %s", n, what)
}
