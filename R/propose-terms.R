#' Propose the term the model is missing
#'
#' Regresses the bias on the effects of a library of candidate terms
#' ([term_library()]: functions of the model's output and states) and ranks
#' the terms by their posterior inclusion probability: the terms the user did
#' not think of, named by their family (a hinge of a compression, a sign of a
#' velocity, a saturating function of a concentration), with the strength
#' that fits the bias and where in time they act.
#'
#' **A term's effect on the output.** A term of an output channel acts on
#' the output as it is (its curve is its effect). A term of a state acts
#' through the model's equations: with `simulate`, its effect is the
#' derivative of the simulated output in the term's strength at the
#' calibrated inputs (a central difference at a strength that moves the
#' equations by a hundredth of a unit of the term), so a force term's effect
#' includes the motion it causes. Without `simulate`, a state term is taken
#' to act on the output directly, a rougher reading said in the print. A
#' term with memory (a filter, a delay, an integral of a channel) or a
#' product acts on the output directly even with `simulate`, which takes a
#' function of a state's value, not of its history.
#'
#' **The regression.** As in [explain_bias()], draw by draw: the residuals
#' of the field data from the emulated model at the draw's inputs, weighted
#' by the inverse of their field, emulator and bias variance, are regressed on
#' the terms' effects under Zellner's g-prior with `g` the number of
#' coefficients. Two kinds of direction are in every model and so can never
#' be proposed: the parameter shifts (what moving each input would do,
#' [explain_bias()]'s `shift:` candidates) and an offset of the whole record
#' at each site (its mean, which the calibrated inputs trade against the
#' events: [where_fails()] reports a record-wide bias).
#'
#' **The registration's error.** When the field was registered, an error
#' `delta(t)` of the warps (linear between their knots) moves the registered
#' mean by `-delta y'` and, through the spread of such errors, blurs it by
#' `delta^2 y'' / 2` (`y` the model at the posterior mean inputs). A shift
#' and a blur direction at each knot of the warps (the sites together when
#' one warp moves them all) enter every model as random effects, each kind
#' with a variance estimated from the bias by restricted maximum likelihood
#' (the print gives their sizes against the noise): a term must explain what
#' a plausible error of the registration does not.
#'
#' **Agreement across the record.** A term's evidence is tempered, draw by
#' draw, by the cluster jackknife of its amplitude: the record is cut into
#' `segments` time segments per site, and the power is the variance of the
#' amplitude the regression claims over the sum of squares of the changes of
#' the amplitude when each segment is left out (capped at 1). A physical
#' term has one strength wherever it acts; a term fitted to one event
#' cannot be told from an error that event alone carries, and gets almost
#' no evidence.
#'
#' **Multiplicity.** Subsets of up to `max_size` families are weighed, with
#' equal prior mass on each size (from none), shared equally among the
#' families and within a family among its versions, so that a large library
#' pays for its size: with 50 families, one family needs a Bayes factor near
#' 50 against none before its inclusion passes one half.
#'
#' **What it found on the test beds.** With the simulator's states it
#' proposed the right family for some hidden mechanisms of the suspension
#' test bed (a bump stop, a damper, a tire lift-off) and for none of the dosing bed's, and
#' with nothing hidden it made proposals at most suspension seeds, at the
#' sharp events, where the field's, the emulators' and the inputs' errors
#' leave a misfit alike at every event.
#' The terms with memory put a right family first in two of the dosing bed's
#' twelve cases (output channels), at inclusion near 0.2, and lowered every null's largest
#' inclusion (`studies/README.md` in the package's source repository,
#' "propose_terms.R"). Read a proposal beside [where_fails()] and check it by
#' adding the term to the model and validating again.
#'
#' @param fit A `wv_fit` from [calibrate()] or [validate()].
#' @param library A `wv_term_library` from [term_library()] on this fit.
#' @param simulate `NULL` or a function `function(channel, fun, strength)`
#'   returning the model's output at the calibrated inputs (`coef(fit)`) with
#'   the term `strength * fun(state)` added where the state `channel`
#'   enters the equations: a named list with one curve per site, on the fit's
#'   grid. Used for the library's state terms only (see Details). Not
#'   available when the fit holds several experiments.
#' @param max_size Largest number of families in one subset (1 or 2).
#' @param n_draws Number of posterior draws used (evenly thinned).
#' @param registration Include the registration's error among the directions
#'   in every model: `TRUE` when the field was registered.
#' @inheritParams explain_bias
#' @return A `wv_proposals` data frame, one row per family ranked by
#'   `inclusion_prob`: `term` (its most probable version), `family`,
#'   `channel`, `inclusion_prob`, `strength` with `strength_lower`,
#'   `strength_upper` (the coefficient of the term, in the units of `fun`:
#'   with `simulate`, the strength to give the term in the simulator), `share_of_bias` (the share of
#'   the bias, after the shifts and registration directions, that the term
#'   alone explains) and `site`, `from`, `to` (where its effect is largest:
#'   the stretch around its peak where it stays above a quarter of the
#'   peak). Attributes: `none` (the probability of no term), `versions`,
#'   `curves` (bias and leading effects by site, for `autoplot()`),
#'   `signatures` (each family's leading version's effect on the retained
#'   coefficients), `nuisance` and `funs`.
#' @seealso [term_library()], [proposed_candidates()] to weigh proposals with
#'   [explain_bias()].
#' @export
#' @examples
#' fit <- example_fit()
#' pr <- propose_terms(fit, term_library(fit), seed = 1)
#' pr
#' autoplot(pr)
propose_terms <- function(fit, library, simulate = NULL, max_size = 2L, n_draws = 100L, level = 0.9,
                          segments = 64L, registration = NULL, seed = NULL, ...) {
  check_dots_none(...)
  check_class(fit, "wv_fit")
  check_class(library, "wv_term_library")
  check_number(max_size, min = 1, max = 2, integer = TRUE)
  check_number(n_draws, min = 2, integer = TRUE)
  check_level(level)
  if (!is.null(segments)) check_number(segments, min = 1, integer = TRUE)
  if (!identical(library$sites, fit_sites(fit)) ||
      !identical(library$grid, fit_get(fit, "basis")$t) ||
      !identical(library$n_coef, vapply(fit_get(fit, "wb"), ncol, 1L))) {
    wv_abort(c("{.arg library} was built on another fit.",
               "i" = "Build it with {.code term_library(fit)} on this fit."))
  }
  if (!is.null(simulate) && !is.function(simulate)) {
    wv_abort("{.arg simulate} must be NULL or a function(channel, fun, strength).")
  }
  reg <- registration %||% !is.null(fit_get(fit, "field")$warps)
  check_flag(reg, "registration")
  seed <- resolve_seed(seed)
  sig <- term_signatures(fit, library, simulate)
  X <- sig$X
  if (!ncol(X)) wv_abort("No term of the library could be simulated: check {.arg simulate}.")
  library$terms <- library$terms[sig$keep, , drop = FALSE]
  library$funs <- library$funs[sig$keep]
  library$ops <- library$ops[sig$keep]
  library$rates <- library$rates[sig$keep]
  N <- proposal_nuisance(fit, reg)
  H <- nrow(fit_get(fit, "wb")[[1]])
  keep <- unique(round(seq(1, H, length.out = min(n_draws, H))))
  draws <- fit_draws_matrix(fit)[keep, , drop = FALSE]
  rs <- residual_regression_data(fit, draws, keep)
  Wt <- 1 / (rs$variance + bias_level_variances(fit, draws))
  cluster <- if (!is.null(segments)) coefficient_segments(fit, segments)
  lib <- library$terms
  usable <- outside_span(X, N$X, colMeans(Wt))
  if (!any(usable))
    wv_abort("Every term of the library is a parameter shift or a registration error here.")
  same <- equivalent_terms(X[, usable, drop = FALSE], N$X, colMeans(Wt))
  usable[usable] <- is.na(same)
  X <- X[, usable, drop = FALSE]
  lib <- lib[usable, , drop = FALSE]
  rsc <- NULL
  if (!is.null(N$R)) {
    rsc <- registration_scale(colMeans(rs$residuals), colMeans(Wt), N$X, N$R, N$kind)
    N$label <- c(N$label, sprintf(
      "the registration's error at its %d warp knots (a shift and a blur at each, random, their sizes estimated from the bias: sd %s and %s times the noise)",
      N$knots, format(signif(sqrt(rsc$by_kind[["shift"]]), 2)),
      format(signif(sqrt(rsc$by_kind[["blur"]] %||% 0), 2))))
  }
  res <- with_rng_seed(seed, proposal_regression(rs$residuals, Wt, X, N$X, lib$effect, cluster,
                                                 max_size, level,
                                                 R = rsc$R, lam = rsc$lam))
  out <- proposal_table(fit, res, lib, X, sig$kind[usable])
  lead <- X[, match(out$term, lib$term), drop = FALSE]
  colnames(lead) <- out$term
  curves_tab <- data.frame(candidate = out$term, amplitude = out$strength,
                           inclusion_prob = out$inclusion_prob)
  attr(out, "none") <- res$none
  attr(out, "curves") <- explain_curves(fit, lead, curves_tab)
  attr(out, "signatures") <- lead
  attr(out, "nuisance") <- N$label
  attr(out, "funs") <- library$funs[out$term]
  attr(out, "ops") <- library$ops[out$term]
  attr(out, "rates") <- library$rates[out$term]
  attr(out, "labels") <- stats::setNames(lib$label[match(out$term, lib$term)], out$term)
  attr(out, "memory") <- any(lib$memory)
  attr(out, "n_terms") <- c(terms = nrow(lib), families = length(unique(lib$effect)))
  attr(out, "effects_from") <- if (is.null(simulate)) "direct" else "simulated"
  attr(out, "eta") <- res$eta
  attr(out, "made_on") <- proposal_fingerprint(fit)
  eq <- same[!is.na(same)]
  attr(out, "equivalent") <- data.frame(term = unname(eq), same_as = names(eq),
                                        stringsAsFactors = FALSE)
  class(out) <- c("wv_proposals", "data.frame")
  out
}

# Each term's effect on the retained coefficients (all sites stacked): its
# curve's coefficients, or for a state term with `simulate`, the derivative
# of the simulated output in its strength.
term_signatures <- function(fit, library, simulate) {
  lib <- library$terms
  sites <- fit_sites(fit)
  Psi <- fit_get(fit, "basis")$Psi
  # a term with memory (or a product) is no function of a state's value that
  # the hook could put in the equations: it acts on the output as it is
  state <- library$channels$kind[lib$channel] %in% "state" & !is.null(simulate) &
    !vapply(library$funs, is.null, NA)
  if (any(state) && any(grepl("/", sites, fixed = TRUE))) {
    wv_abort(c("{.arg simulate} is not available for a fit of several experiments.",
               "i" = "Drop {.arg simulate}: the state terms then act on the output directly."))
  }
  X <- matrix(0, sum(vapply(fit_get(fit, "wb"), ncol, 1L)), nrow(lib),
              dimnames = list(NULL, lib$term))
  failed <- rep(FALSE, nrow(lib))
  # a bar while the state terms are simulated (cli shows it only after two
  # seconds)
  bar <- any(state) && !isTRUE(getOption("wavevalid.quiet", FALSE))
  if (bar) cli::cli_progress_bar("Simulating the terms' effects", total = sum(state),
                                 .envir = environment())
  env <- environment()
  for (j in seq_len(nrow(lib))) {
    v <- library$values[[j]]
    if (state[j]) {
      if (bar) cli::cli_progress_update(.envir = env)
      v <- simulated_effect(simulate, lib$channel[j], library$funs[[j]], v, sites)
      if (is.null(v)) {
        failed[j] <- TRUE
        next
      }
    }
    X[, j] <- unlist(lapply(sites, function(s) drop(v[[s]] %*% Psi)))
  }
  if (any(failed)) {
    wv_inform(c("!" = "{cli::qty(sum(failed))}The simulation with {?the term/each of the terms} {.val {lib$term[failed]}} failed or was not finite: left out."))
  }
  list(X = X[, !failed, drop = FALSE], kind = ifelse(state, "simulated", "direct")[!failed],
       keep = !failed)
}

simulated_effect <- function(simulate, channel, fun, values, sites) {
  e <- 0.01 / max(abs(unlist(values)))
  run <- function(s) {
    y <- tryCatch(suppressWarnings(simulate(channel, fun, s)), error = function(e) NULL)
    if (is.null(y)) return(NULL)
    if (!is.list(y) || !all(sites %in% names(y))) {
      wv_abort(c("{.arg simulate} must return a named list with one curve per site.",
                 "i" = "The fit's sites are {.val {sites}}."))
    }
    y
  }
  up <- run(e)
  down <- run(-e)
  if (is.null(up) || is.null(down)) return(NULL)
  out <- stats::setNames(lapply(sites, function(s) (up[[s]] - down[[s]]) / (2 * e)), sites)
  if (any(!is.finite(unlist(out)))) return(NULL)
  out
}

# The directions in every model: the parameter shifts and a constant at each
# site (the record's mean, whose bias the calibrated inputs trade against the
# events), fixed (`X`); and, with `registration`, the registration's error
# (`R`, see registration_directions()), random.
proposal_nuisance <- function(fit, registration) {
  sh <- shift_candidates(fit, posterior_mean_inputs(fit))
  sites <- fit_sites(fit)
  n <- vapply(fit_get(fit, "wb"), ncol, 1L)
  offs <- c(0L, cumsum(n))
  level0 <- vapply(seq_along(sites), function(i) {
    x <- numeric(sum(n))
    x[(offs[i] + 1L):offs[i + 1L]] <- colSums(fit_get(fit, "basis")$Psi)
    x
  }, numeric(sum(n)))
  sh <- cbind(sh, level0)
  label <- c(if (ncol(sh) > length(sites)) "parameter shifts",
             "an offset of the record at each site")
  reg <- if (registration) registration_directions(fit)
  list(X = sh, R = reg$R, kind = reg$kind, label = label, knots = reg$knots)
}

# FALSE for a column of X that the nuisance N spans (weighted residual norm
# below 1e-6 of its own).
outside_span <- function(X, N, w) {
  sw <- sqrt(w)
  Xw <- X * sw
  if (!ncol(N)) return(colSums(Xw^2) > 0)
  r <- qr.resid(qr(N * sw), Xw)
  colSums(r^2) > 1e-6 * colSums(Xw^2)
}

# Terms the data cannot tell from an earlier term: after the nuisance N is
# projected out (weights w), their effects are the same direction (|cor| above
# 0.999). A named vector, one per column of X: NA for a term kept, else the
# name of the earlier term it duplicates (the library lists simpler families
# first), named by the term dropped.
equivalent_terms <- function(X, N, w) {
  sw <- sqrt(w)
  R <- X * sw
  if (ncol(N)) R <- qr.resid(qr(N * sw), R)
  R <- sweep(R, 2L, sqrt(colSums(R^2)), `/`)
  C <- abs(crossprod(R))
  out <- rep(NA_character_, ncol(X))
  names(out) <- colnames(X)
  for (j in seq_len(ncol(X))[-1]) {
    prev <- which(is.na(out[seq_len(j - 1L)]))
    k <- prev[C[prev, j] > 0.999]
    if (length(k)) out[j] <- colnames(X)[k[1]]
  }
  out
}

# The regression of the residual draws Y (H x n) on the terms X (n x m) with
# the nuisance N always in, weights Wt; subsets of up to max_size effects.
proposal_regression <- function(Y, Wt, X, N, effect, cluster, max_size, level, R = NULL,
                                lam = NULL) {
  H <- nrow(Y)
  n <- ncol(Y)
  m <- ncol(X)
  eff <- unique(effect)
  ei <- match(effect, eff)
  n_ver <- tabulate(ei, length(eff))
  l_size <- -log(max_size + 1)
  lp1 <- l_size - log(length(eff)) - log(n_ver[ei])
  pair_ok <- outer(ei, ei, `!=`) & upper.tri(diag(m))
  lp2 <- l_size - log(choose(length(eff), 2)) - log(outer(n_ver[ei], n_ver[ei]))
  incl <- matrix(0, H, length(eff))
  ver <- numeric(m)
  none <- eta <- numeric(H)
  amp_m <- amp_s <- share <- matrix(0, H, m)
  bar <- H >= 20L && !isTRUE(getOption("wavevalid.quiet", FALSE))
  if (bar) cli::cli_progress_bar("Regressing the bias draws on the terms", total = H,
                                 .envir = environment())
  env <- environment()
  for (h in seq_len(H)) {
    if (bar) cli::cli_progress_update(.envir = env)
    sw <- sqrt(Wt[h, ])
    yt <- Y[h, ] * sw
    Xt <- X * sw
    Nt <- N * sw
    cl <- cluster
    if (!is.null(R)) {
      # the registration's error as random directions of variances lam: the
      # regression on rows augmented by one pseudo-observation per direction
      # gives the quadratic forms of the marginal covariance D + R lam R'
      r <- ncol(R)
      yt <- c(yt, numeric(r))
      Xt <- rbind(Xt, matrix(0, r, m))
      Nt <- rbind(cbind(Nt, R * sw), cbind(matrix(0, r, ncol(N)), diag(1 / sqrt(lam), r)))
      if (!is.null(cl)) cl <- c(cl, rep(max(cl) + 1L, r))
    }
    q <- 0L
    if (ncol(Nt)) {
      qn <- qr(Nt)
      q <- qn$rank - if (is.null(R)) 0L else ncol(R)
      yt <- qr.resid(qn, yt)
      Xt <- qr.resid(qn, Xt)
    }
    yy <- sum(yt^2)
    b <- drop(crossprod(Xt, yt))
    G <- crossprod(Xt)
    d <- diag(G)
    r2 <- pmin(b^2 / (d * yy), 1 - 1e-12)
    # each term's evidence tempered by the cluster jackknife of its amplitude
    et <- if (is.null(cl)) rep(1, m) else term_tempering(Xt, yt, b, d, cl)
    eta[h] <- stats::median(et)
    ne <- et * (n - q)
    g <- ne
    sh <- g / (1 + g)
    l1 <- -0.5 * log1p(g) - 0.5 * ne * log1p(-sh * r2)
    post <- c(l_size, lp1 + l1)
    l2 <- NULL
    if (max_size >= 2L && length(eff) >= 2L) {
      det <- outer(d, d) - G^2
      num <- outer(b^2, d) - 2 * outer(b, b) * G + outer(d, b^2)
      ok <- pair_ok & det > 1e-8 * outer(d, d)
      r2p <- pmin(ifelse(ok, num / (det * yy), 0), 1 - 1e-12)
      # a pair tempered as the more tempered of its terms
      ne2 <- outer(ne, ne, pmin)
      l2 <- ifelse(ok, lp2 - log1p(ne2) - 0.5 * ne2 * log1p(-ne2 / (1 + ne2) * r2p), -Inf)
      post <- c(post, l2[ok])
    }
    top <- max(post)
    tot <- top + log(sum(exp(post - top)))
    p1 <- exp(lp1 + l1 - tot)
    pj <- p1
    if (!is.null(l2)) {
      p2 <- exp(l2 - tot)
      pj <- pj + rowSums(p2) + colSums(p2)
    }
    none[h] <- exp(l_size - tot)
    ver <- ver + pj
    incl[h, ] <- vapply(seq_along(eff), function(k) sum(pj[ei == k]), numeric(1))
    phi <- (yy - sh * b^2 / d) / ne
    amp_m[h, ] <- sh * b / d
    amp_s[h, ] <- sqrt(pmax(phi, 0) * sh / d)
    share[h, ] <- r2
  }
  list(inclusion = stats::setNames(colMeans(incl), eff), version_prob = ver / H, none = mean(none),
       amp_m = amp_m, amp_s = amp_s, share = share, eta = eta, level = level)
}

# The tempering power of each term's single-term regression: the variance
# of its amplitude the regression claims (phi_j / d_j) over the cluster
# jackknife's (the sum over clusters c of (a_j - a_j(-c))^2, a_j(-c) the
# amplitude fitted without cluster c), capped at 1. A term whose evidence
# comes from one cluster (one event at one site) cannot be told from an error
# shared within that cluster, and gets almost none; a term whose amplitude
# every cluster agrees on keeps its evidence. Xt, yt: the weighted columns and
# data with the nuisance projected out; b = Xt'yt, d = diag(Xt'Xt).
term_tempering <- function(Xt, yt, b, d, cluster) {
  a <- b / d
  B <- rowsum(Xt * yt, cluster)
  S <- rowsum(Xt^2, cluster)
  rest <- sweep(-S, 2L, d, `+`)
  D <- (B - sweep(S, 2L, a, `*`)) / rest
  D[rest <= 1e-10 * rep(d, each = nrow(rest))] <- Inf
  vj <- colSums(D^2)
  phi <- pmax(sum(yt^2) - b^2 / d, 0) / length(yt)
  out <- phi / (d * vj)
  out[!is.finite(out) & vj == 0] <- 1
  out[!is.finite(out)] <- 0
  pmin(out, 1)
}

# One row per family: its most probable version, inclusion, strength with its
# interval (a mixture over draws of the single-term posteriors), share of the
# bias and where its effect is largest.
proposal_table <- function(fit, res, lib, X, kind) {
  eff <- names(res$inclusion)
  lead <- vapply(eff, function(e) {
    j <- which(lib$effect == e)
    j[which.max(res$version_prob[j])]
  }, 1L)
  a <- (1 - res$level) / 2
  amp <- t(vapply(lead, function(j) {
    z <- res$amp_m[, j] + outer(res$amp_s[, j], stats::qnorm(stats::ppoints(20)))
    c(mean(res$amp_m[, j]), stats::quantile(z, c(a, 1 - a), names = FALSE))
  }, numeric(3)))
  where <- do.call(rbind,
                   lapply(seq_along(lead), function(k) term_place(fit, X[, lead[k]] * amp[k, 1])))
  out <- data.frame(term = lib$term[lead], family = lib$family[lead], channel = lib$channel[lead],
                    inclusion_prob = unname(res$inclusion), strength = amp[, 1],
                    strength_lower = amp[, 2],
                    strength_upper = amp[, 3], share_of_bias = colMeans(res$share)[lead],
                    effect_of = kind[lead], where, stringsAsFactors = FALSE)
  out <- out[order(-out$inclusion_prob, -out$share_of_bias), , drop = FALSE]
  rownames(out) <- NULL
  versions <- data.frame(term = lib$term, effect = lib$effect, inclusion_prob = res$version_prob,
                         share_of_bias = colMeans(res$share), stringsAsFactors = FALSE)
  rownames(versions) <- NULL
  attr(out, "versions") <- versions[order(-versions$inclusion_prob), , drop = FALSE]
  out
}

# Where the effect `x` (coefficients, all sites stacked) is largest: its site
# and the stretch around the peak where it stays above a quarter of the peak.
term_place <- function(fit, x) {
  sites <- fit_sites(fit)
  n <- vapply(fit_get(fit, "wb"), ncol, 1L)
  offs <- c(0L, cumsum(n))
  Psi <- fit_get(fit, "basis")$Psi
  curves <- lapply(seq_along(sites), function(i) abs(drop(Psi %*% x[(offs[i] + 1L):offs[i + 1L]])))
  peaks <- vapply(curves, max, numeric(1))
  i <- which.max(peaks)
  y <- curves[[i]]
  tb <- fit_get(fit, "basis")$t
  k <- which.max(y)
  above <- y >= 0.25 * y[k]
  lo <- k
  while (lo > 1L && above[lo - 1L]) lo <- lo - 1L
  hi <- k
  while (hi < length(y) && above[hi + 1L]) hi <- hi + 1L
  data.frame(site = sites[i], from = tb[lo], to = tb[hi], peak = peaks[i], stringsAsFactors = FALSE)
}
