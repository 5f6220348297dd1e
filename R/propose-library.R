# The library of candidate terms of propose_terms(): functions of the model's
# output channels and states, each a family ("effect") of versions that differ
# by a threshold or a power.

#' A library of candidate terms for the missing physics
#'
#' Builds the functions of the model's own channels from which
#' [propose_terms()] proposes the term the model lacks. A channel is a curve
#' the model computes at the calibrated inputs, one per site: its output (the
#' emulated model at the posterior mean inputs, `"output"`) and the output's
#' time derivative (`"d/dt output"`), and any state history the simulator
#' exposes (`states`). Each channel `x` gives these families of terms, each
#' with a few versions:
#'
#' | family | term | versions |
#' | --- | --- | --- |
#' | `linear` | `x` | one |
#' | `power` | `x^2`, `x abs(x)`, `x^3` | three |
#' | `abs` | `abs(x - c)` | `c` = 0 (when `x` changes sign) and its quartiles |
#' | `sign` | `tanh((x - c) / e)`, smoothed sign | `c` = 0 (when `x` changes sign) and its median |
#' | `hinge_above` | `(x - c)_+^k` | `k` = 1, 2; `c` = 0 and the quantiles 0.5 to 0.997 |
#' | `hinge_below` | `(c - x)_+^k` | `k` = 1, 2; `c` = 0 and the quantiles 0.003 to 0.5 |
#' | `saturating` | `x abs(x) / (c + abs(x))` | `c` the quantiles 0.1, 0.5, 0.9 of `abs(x)` |
#' | `product` | `x y`, two channels | one per pair |
#' | `filter` | `z' = x - b z`, `z = 0` at the start | time constants `1/b` of 1/16, 1/4, 1 of the record |
#' | `delay` | `x(t - d)`, `x` held at its start before it | `d` of 1/32, 1/8, 1/4 of the record |
#' | `integral` | the integral of `x` from the start | one |
#' | `product` | a filter or the integral of `x` times `x` (and, for a state, times the output) | as the filter's |
#'
#' The last four have memory (a compartment, a lag, an exposure): computed on
#' the fit's grid (exact for `x` linear between its points), for every
#' channel but `"d/dt output"`; each acts on the output as it is.
#'
#' A stop or a clearance is a hinge, a friction a sign, a saturation a
#' saturating function, a stiffening a power. A family is weighed once, as a
#' mixture of its versions (as the versions of an effect in
#' [explain_bias()]). The thresholds `c` are taken from the channel's values
#' at every site together; `e` is a hundredth of the spread of its central
#' 90\%. The term acts at every site with that site's channel (a strut
#' force at each axle, with each axle's compression). Channels that are the
#' same curve up to scale as an earlier one (a concentration and the amount
#' it is proportional to) are kept once, the states first.
#'
#' @param fit A `wv_fit` from [calibrate()] or [validate()].
#' @param states `NULL` or a named list of the model's state histories at
#'   the calibrated inputs (`coef(fit)`): each a curve (used at every site)
#'   or a named list with one curve per site, on the fit's grid or on `t`.
#'   Give states whose functions could enter the model's equations: a
#'   displacement, a velocity, a force, an amount.
#' @param outputs Include the channels `"output"` and `"d/dt output"`.
#' @param products Include the products of two channels.
#' @param memory Include the terms with memory.
#' @param t The times of state curves not on the fit's grid (as in
#'   [explain_bias()]).
#' @param ... Must be empty.
#' @return A `wv_term_library`: a list with `terms` (a data frame with one
#'   row per term: `term`, `effect` (the family on its channel), `family`,
#'   `channel`, `version`, `memory`, `label` (a readable name)), `values`
#'   (each term's curve by site on the fit's grid), `funs` (each term as a
#'   function of its channel's value; `NULL` for a product or a term with
#'   memory), `ops` (a term with memory of one channel as a function of the
#'   channel's curve and its times) and `channels` (the channels' curves by
#'   site and whether each is a state).
#' @seealso [propose_terms()]
#' @export
#' @examples
#' fit <- example_fit()
#' lib <- term_library(fit)
#' lib
term_library <- function(fit, states = NULL, outputs = TRUE, products = TRUE, memory = TRUE,
                         t = NULL, ...) {
  check_dots_none(...)
  check_class(fit, "wv_fit")
  check_flag(outputs)
  check_flag(products)
  check_flag(memory)
  channels <- list()
  kind <- character()
  if (!is.null(states)) {
    if (!is.list(states) || !length(states)) {
      wv_abort("{.arg states} must be a named list of state curves, or NULL.")
    }
    nm <- names(states)
    if (is.null(nm) || anyNA(nm) || any(!nzchar(nm)) || anyDuplicated(nm)) {
      wv_abort("{.arg states} must be a list with a unique name for every state.")
    }
    if (!is.null(t)) t <- check_candidate_grid(t, fit_get(fit, "basis")$t)
    channels <- channel_curves_from(fit, states, t)
    kind <- rep("state", length(channels))
  }
  if (outputs) {
    out <- output_channels(fit)
    channels <- c(channels, out)
    kind <- c(kind, rep("output", length(out)))
  }
  if (!length(channels)) {
    wv_abort("No channel: give {.arg states} or set {.code outputs = TRUE}.")
  }
  keep <- distinct_channels(channels)
  if (any(!keep)) {
    wv_inform(c("i" = "{cli::qty(sum(!keep))}Channel{?s} {.val {names(channels)[!keep]}} {?is/are} the same curve up to scale as another: left out."))
  }
  channels <- channels[keep]
  kind <- kind[keep]
  names(kind) <- names(channels)
  rows <- unlist(lapply(names(channels), function(ch) channel_terms(ch, channels[[ch]])),
                 recursive = FALSE)
  tb <- fit_get(fit, "basis")$t
  mem <- if (memory) memory_channels(channels, kind)
  rows <- c(rows, unlist(lapply(names(mem), function(ch) {
    memory_terms(ch, channels[[ch]], tb, with = if (products) mem[[ch]] else list())
  }), recursive = FALSE))
  if (products && length(channels) > 1L) {
    pairs <- utils::combn(names(channels), 2L, simplify = FALSE)
    rows <- c(rows, lapply(pairs, function(p) product_term(p, channels)))
  }
  terms <- data.frame(term = vapply(rows, `[[`, "", "term"),
                      effect = vapply(rows, `[[`, "", "effect"),
                      family = vapply(rows, `[[`, "", "family"),
                      channel = vapply(rows, `[[`, "", "channel"),
                      version = vapply(rows, `[[`, "", "version"),
                      memory = vapply(rows, function(r) !is.null(r$label), NA),
                      stringsAsFactors = FALSE)
  terms$label <- vapply(rows, function(r) r$label %||% r$term, "")
  values <- lapply(rows, `[[`, "values")
  funs <- lapply(rows, `[[`, "fun")
  ops <- lapply(rows, `[[`, "op")
  rates <- lapply(rows, `[[`, "rate")
  names(values) <- names(funs) <- names(ops) <- names(rates) <- terms$term
  flat <- vapply(values, function(v) all(vapply(v, function(y) diff(range(y)) == 0, logical(1))),
                 logical(1))
  structure(list(terms = terms[!flat, , drop = FALSE], values = values[!flat], funs = funs[!flat],
                 ops = ops[!flat], rates = rates[!flat],
                 channels = list(curves = channels, kind = kind), sites = fit_sites(fit),
                 grid = fit_get(fit, "basis")$t, n_coef = vapply(fit_get(fit, "wb"), ncol, 1L)),
            class = "wv_term_library")
}

#' @export
print.wv_term_library <- function(x, ...) {
  tm <- x$terms
  cli::cat_line(sprintf("<wv_term_library> %d terms in %d families of %d channels", nrow(tm),
                        length(unique(tm$effect)), length(x$channels$curves)))
  kind <- x$channels$kind
  cli::cat_line("Channels: ", paste(sprintf("%s (%s)", names(kind), kind), collapse = ", "))
  fam <- table(factor(tm$family, levels = unique(tm$family)))
  cli::cat_line("Families: ", paste(sprintf("%s %d", names(fam), as.integer(fam)), collapse = ", "))
  invisible(x)
}

# The channels' curves by site on the fit's grid from user states (a curve, or
# a list by site).
channel_curves_from <- function(fit, states, t) {
  nm <- names(states)
  sites <- fit_sites(fit)
  tb <- fit_get(fit, "basis")$t
  out <- lapply(nm, function(k) {
    cur <- states[[k]]
    if (is.numeric(cur) && is.null(dim(cur))) cur <- stats::setNames(rep(list(cur), length(sites)),
                                                                     sites)
    stats::setNames(lapply(sites, function(s) candidate_on_grid(cur[[s]], k, s, tb, t)$y), sites)
  })
  stats::setNames(out, nm)
}

# The output channels: the emulated model at the posterior mean inputs,
# reconstructed from its retained coefficients, and its time derivative.
output_channels <- function(fit) {
  z <- posterior_mean_inputs(fit)
  Z <- matrix(z[fit_get(fit, "inputs")], 1L, dimnames = list(NULL, fit_get(fit, "inputs")))
  tb <- fit_get(fit, "basis")$t
  y <- lapply(fit_sites(fit), function(s) {
    w <- bank_predict(site_bank(fit_get(fit, "emulators"), s), shift_inputs(fit, s, Z))$mean
    drop(fit_get(fit, "basis")$Psi %*% drop(w))
  })
  names(y) <- fit_sites(fit)
  list(output = y, `d/dt output` = lapply(y, grid_slope, t = tb))
}

# FALSE for a channel whose curves (all sites together) are, up to an affine
# map, those of an earlier channel (correlation above 0.9999).
distinct_channels <- function(channels) {
  flat <- vapply(channels, function(ch) unlist(ch, use.names = FALSE),
                 numeric(length(unlist(channels[[1]]))))
  if (is.null(dim(flat))) flat <- matrix(flat, ncol = length(channels))
  sdv <- apply(flat, 2, stats::sd)
  keep <- sdv > 0
  for (j in seq_len(ncol(flat))[-1]) {
    if (!keep[j]) next
    prev <- which(keep[seq_len(j - 1L)])
    if (length(prev) && any(abs(suppressWarnings(stats::cor(flat[, j], flat[, prev]))) > 0.9999))
      keep[j] <- FALSE
  }
  keep
}

# The terms of one channel (curves `x` by site): a list of rows, each with
# its name, family, version, curves by site and function.
channel_terms <- function(ch, x) {
  v <- unlist(x, use.names = FALSE)
  q <- function(p) unname(stats::quantile(v, p, type = 7))
  crosses <- q(0.01) < 0 && q(0.99) > 0
  spread <- q(0.95) - q(0.05)
  if (!(spread > 0)) spread <- diff(range(v))
  e <- spread / 100
  fmt <- function(c) format(signif(c, 3))
  make <- function(family, version, f) {
    list(term = sprintf("%s(%s%s)", family, ch, if (nzchar(version)) paste0("; ", version) else ""),
         effect = sprintf("%s(%s)", family, ch), family = family, channel = ch, version = version,
         values = lapply(x, f), fun = f)
  }
  zero_or <- function(cs) unique(c(if (crosses) 0, cs))
  out <- list(make("linear", "", function(x) x))
  out <- c(out, list(make("power", "x^2", function(x) x^2),
                     make("power", "x|x|", function(x) x * abs(x)),
                     make("power", "x^3", function(x) x^3)))
  # thresholds within a thousandth of the spread of the channel's extreme
  # would make terms that are zero to rounding
  lo <- min(v)
  hi <- max(v)
  above <- unique(c(if (q(0.003) < 0 && q(0.997) > 0) 0, q(c(0.5, 0.75, 0.9, 0.97, 0.99, 0.997))))
  above <- above[hi - above > 1e-3 * spread]
  below <- unique(c(if (q(0.003) < 0 && q(0.997) > 0) 0, q(c(0.003, 0.01, 0.03, 0.1, 0.25, 0.5))))
  below <- below[below - lo > 1e-3 * spread]
  hinge <- function(family, cs, k, f) {
    lapply(cs, function(c) {
      force(c)
      make(family, sprintf("c = %s, k = %d", fmt(c), k), function(x) f(x, c)^k)
    })
  }
  for (k in 1:2) {
    out <- c(out, hinge("hinge_above", above, k, function(x, c) pmax(x - c, 0)),
             hinge("hinge_below", below, k, function(x, c) pmax(c - x, 0)))
  }
  out <- c(out, lapply(zero_or(q(0.5)), function(c) {
    force(c)
    make("sign", paste0("c = ", fmt(c)), function(x) tanh((x - c) / e))
  }))
  sat <- unique(stats::quantile(abs(v), c(0.1, 0.5, 0.9), names = FALSE))
  sat <- sat[sat > 0]
  out <- c(out, lapply(sat, function(c) {
    force(c)
    make("saturating", paste0("c = ", fmt(c)), function(x) x * abs(x) / (c + abs(x)))
  }))
  out <- c(out, lapply(zero_or(q(c(0.25, 0.5, 0.75))), function(c) {
    force(c)
    make("abs", paste0("c = ", fmt(c)), function(x) abs(x - c))
  }))
  out
}

# The product of two channels `p` (names).
product_term <- function(p, channels) {
  a <- channels[[p[1]]]
  b <- channels[[p[2]]]
  list(term = sprintf("product(%s, %s)", p[1], p[2]),
       effect = sprintf("product(%s, %s)", p[1], p[2]),
       family = "product", channel = paste(p, collapse = " x "), version = "",
       values = Map(`*`, a, b), fun = NULL)
}
