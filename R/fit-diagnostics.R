# Diagnostics of a fit, computed when it is made and read by its prints and
# by where_fails(): convergence (R-hat, effective sizes), inputs piled at a
# bound, and inputs in conflict with their prior.

fit_diagnostics <- function(fit) {
  inp <- fit$inputs
  ess <- coda::effectiveSize(fit$draws)
  rhat <- stats::setNames(rep(NA_real_, length(inp)), inp)
  if (length(fit$draws) >= 2L) {
    sub <- coda::mcmc.list(lapply(fit$draws, function(m) m[, inp, drop = FALSE]))
    r <- tryCatch(coda::gelman.diag(sub, autoburnin = FALSE, multivariate = FALSE)$psrf[, 1],
                  error = function(e) rep(NA_real_, length(inp)))
    rhat[] <- r
  }
  list(rhat = rhat, ess = ess, flags = boundary_flags(fit, rhat))
}

# Inputs whose posterior piles at a bound (see piled_at_bound()), and inputs
# with R-hat above 1.1.
boundary_flags <- function(fit, rhat) {
  X <- as.matrix(fit$draws)
  pr <- fit$prior_iu
  out <- data.frame(input = character(0), bound = character(0), posterior = numeric(0),
                    prior = numeric(0), stringsAsFactors = FALSE)
  for (k in seq_along(fit$inputs)) {
    lo <- pr$lower[k]
    hi <- pr$upper[k]
    d <- 0.02 * (hi - lo)
    x <- X[, fit$inputs[k]]
    for (side in c("lower", "upper")) {
      zone <- if (side == "lower") c(lo, lo + d) else c(hi - d, hi)
      post <- mean(x >= zone[1] & x <= zone[2])
      prior <- prior_mass(pr, k, zone)
      if (piled_at_bound(post, prior)) {
        out[nrow(out) + 1L, ] <- list(fit$inputs[k], side, post, prior)
      }
    }
  }
  list(boundary = out, rhat = names(rhat)[!is.na(rhat) & rhat > 1.1])
}

# The posterior of an input piles up at a bound when at least 10% of the
# draws lie within 2% of the range from it and that share is at least four
# times the prior's share there (a uniform prior puts 2% there, so 8% or more
# of the draws flag it).
piled_at_bound <- function(post, prior, share = 0.1, ratio = 4) {
  post >= share & post >= ratio * prior
}

prior_mass <- function(pr, k, zone) {
  if (is.null(pr$prior) && pr$type[k] == "variation") {
    cdf <- function(v) stats::pnorm(v, pr$nominal[k], pr$prior_sd[k])
    return((cdf(zone[2]) - cdf(zone[1])) / (cdf(pr$upper[k]) - cdf(pr$lower[k])))
  }
  iu_prior_mass(pr, k, zone[1], zone[2])
}

warn_fit_flags <- function(fit) {
  st <- fit$stopping
  if (!is.null(st) && !isTRUE(st$met)) {
    wv_warn(c("The chains reached their ceiling of {st$draws} draws each without the targets.",
              "*" = "The slowest input, {.val {st$slowest}}, has an ESS of {round(st$ess)} (target {st$ess_target}){if (is.na(st$rhat)) '' else sprintf('; the largest R-hat is %.3f (target %s)', st$rhat, st$rhat_target)}.",
              "i" = "Raise {.arg max_draws} or {.arg n_inner} in {.fn sampler_control}."),
            class = "mixing")
  }
  f <- fit$flags
  if (length(f$rhat)) {
    wv_warn(c("The chains have not mixed: R-hat > 1.1 for {.val {f$rhat}}.",
              "i" = "Run longer chains (larger {.arg n_draws} or {.arg n_inner})."),
            class = "mixing")
  }
  if (nrow(f$boundary)) {
    msg <- sprintf("%s at its %s bound (%.0f%% of draws, prior %.0f%%)", f$boundary$input,
                   f$boundary$bound, 100 * f$boundary$posterior, 100 * f$boundary$prior)
    wv_warn(c("The posterior piles up at a bound of the range of {.val {unique(f$boundary$input)}}.",
              stats::setNames(msg, rep("*", length(msg))),
              "i" = "The input may be acting as a tuning knob for a missing effect; see {.fn where_fails}."),
            class = "boundary")
  }
  invisible(fit)
}

# The prior sd of each input (by simulation from the prior, prior_sample()).
prior_sds <- function(iu, n = 20000L) {
  apply(prior_sample(iu, n), 2L, stats::sd)
}

# Share of the posterior within 2% of the range from each bound, against the
# prior's share there; flagged when the posterior piles up at a bound.
boundary_check <- function(fit, margin = 0.02) {
  d <- as.matrix(fit$draws)
  iu <- fit$iu
  inputs <- intersect(fit$emulators$inputs, iu$name)
  do.call(rbind, lapply(inputs, function(p) {
    k <- match(p, iu$name)
    lo <- iu$lower[k]
    hi <- iu$upper[k]
    if (iu$type[k] == "condition") {
      # known, held at its value: never at a bound by the data's pull
      return(data.frame(input = p, lower = lo, upper = hi, near_lower = 0, near_upper = 0,
                        prior_near_lower = 0,
                        prior_near_upper = 0, flagged = FALSE, stringsAsFactors = FALSE))
    }
    nom <- iu$nominal[k]
    if (iu$type[k] == "variation" && !is.null(fit$x_nom) && p %in% names(fit$x_nom)) {
      shift <- fit$x_nom[[p]] - nom
      lo <- lo + shift
      hi <- hi + shift
    }
    w <- hi - lo
    x <- d[, p]
    near_lo <- mean(x < lo + margin * w)
    near_hi <- mean(x > hi - margin * w)
    v <- seq(lo, hi, length.out = 2001)
    dens <- iu_prior_density(iu, k, v - (lo - iu$lower[k]))
    dens <- dens / sum(dens)
    prior_lo <- sum(dens[v < lo + margin * w])
    prior_hi <- sum(dens[v > hi - margin * w])
    data.frame(
      input = p, lower = lo, upper = hi,
      near_lower = near_lo, near_upper = near_hi,
      prior_near_lower = prior_lo, prior_near_upper = prior_hi,
      flagged = piled_at_bound(near_lo, prior_lo) || piled_at_bound(near_hi, prior_hi),
      stringsAsFactors = FALSE
    )
  }))
}

# Each input's posterior against its prior (`prior`: a sample of it from
# prior_sample(), drawn here when NULL): a data frame with one row per
# input. An input is in conflict when the data pull it where its prior says it
# hardly is:
# * `far`: the posterior median lies in the prior's tail beyond alpha / (2 p)
#   on its side (p inputs: when the model is right and the posterior sits at a
#   truth drawn from the prior, some input is flagged with probability about
#   alpha); or
# * `piled`: the posterior presses on a bound: at least half of it lies
#   within `margin` of the range from the bound (at least four times the
#   prior's share there), and its draws fall away from the bound as a normal
#   centred beyond it, truncated there, would with its centre at least
#   z = qnorm(1 - alpha / (2 p)) of its sd beyond (bound_overshoot()). A
#   right model whose true input lies near a bound gives a posterior centred
#   inside or at most a chance z sd beyond, so the pile is held to the same
#   family error as `far`.
# Inputs already held (hold_inputs()) and inputs whose range is a point are
# not judged.
input_conflicts <- function(fit, alpha = 0.05, margin = 0.02, majority = 0.5, prior = NULL) {
  X <- as.matrix(fit$draws)[, fit$inputs, drop = FALSE]
  P <- prior %||% prior_sample(fit$prior_iu)
  colnames(P) <- fit$inputs
  bd <- boundary_check(fit, margin)
  p <- length(fit$inputs)
  held <- fit$held$inputs %||% character()
  out <- do.call(rbind, lapply(seq_len(p), function(k) {
    nm <- fit$inputs[k]
    x <- X[, nm]
    q <- P[, nm]
    med <- stats::median(x)
    mu <- mean(q)
    s <- stats::sd(q)
    side <- if (med >= stats::median(q)) "upper" else "lower"
    tail <- if (side == "upper") mean(q >= med) else mean(q <= med)
    b <- bd[bd$input == nm, ]
    share <- if (side == "upper") b$near_upper else b$near_lower
    prior_share <- if (side == "upper") b$prior_near_upper else b$prior_near_lower
    condition <- nm %in% iu_conditions(fit$iu)
    judged <- s > 0 && !(nm %in% held) && !condition &&
      (fit$prior_iu$upper[k] - fit$prior_iu$lower[k]) > 1e-4 * max(abs(fit$prior_iu$upper[k]), 1)
    far <- judged && tail < alpha / (2 * p)
    beyond <- bound_overshoot(if (side == "upper") b$upper - x else x - b$lower)
    piled <- judged && share >= majority && share >= 4 * prior_share &&
      beyond >= stats::qnorm(1 - alpha / (2 * p))
    # a test condition is known, held at its value: no prior to be far from
    data.frame(input = nm, type = if (condition) "condition" else fit$prior_iu$type[k],
               median = med,
               prior_mean = mu, prior_sd = if (condition) NA_real_ else s,
               prior_sds = if (condition) NA_real_ else if (s > 0) (med - mu) / s else 0,
               side = side, prior_tail = tail,
               share_at_bound = share, prior_share_at_bound = prior_share, beyond_bound_sd = beyond,
               far = far,
               piled = piled, conflict = far || piled, stringsAsFactors = FALSE)
  }))
  attr(out, "alpha") <- alpha
  out
}

# How far beyond a bound the posterior's centre lies, in its sd, read from
# how its draws fall away from the bound (`d`: their distances from it): the
# centre a of the standard normal truncated to [a, Inf) (its draws' distances
# from a having the same ratio of mean to sd as `d`). A normal centred at the
# bound gives a ratio of 1.32 (a = 0), one centred far beyond gives an
# exponential fall-off (ratio 1, a large), one centred inside a ratio above
# 1.32 (a < 0). Between -6 and 10; 10 when the draws sit at the bound.
bound_overshoot <- function(d) {
  d <- d[is.finite(d)]
  s <- if (length(d) > 1L) stats::sd(d) else 0
  if (s <= 1e-12 * max(abs(d), 1)) return(10)
  r <- mean(d) / s
  ratio <- function(a) {
    lam <- exp(stats::dnorm(a, log = TRUE) - stats::pnorm(a, lower.tail = FALSE, log.p = TRUE))
    (lam - a) / sqrt(max(1 + a * lam - lam^2, 1e-300))
  }
  if (r >= ratio(-6)) return(-6)
  if (r <= ratio(10)) return(10)
  stats::uniroot(function(a) ratio(a) - r, c(-6, 10), tol = 1e-6)$root
}

# Draws from the prior of the inputs (own units), with a fixed stream; R's
# random number generator is left as it was.
prior_sample <- function(iu, n = 20000L) {
  with_rng_seed(1L, iu_prior_draws(iu, n))
}

# One line per conflicting input, for the prints.
conflict_text <- function(cf) {
  cf <- cf[cf$conflict, , drop = FALSE]
  vapply(seq_len(nrow(cf)), function(i) {
    r <- cf[i, ]
    where <- if (r$piled) {
      sprintf("piled at its %s bound (%.0f%% of the draws within 2%% of the range from it, prior %.0f%%; they fall away from it as a posterior centred %s sd beyond it would)",
              r$side, 100 * r$share_at_bound, 100 * r$prior_share_at_bound,
              if (r$beyond_bound_sd >= 10) "10 or more" else format(round(r$beyond_bound_sd, 1),
                                                                    nsmall = 1))
    } else {
      sprintf("in its prior's %s tail", r$side)
    }
    sprintf("%s %s, median %s, %s prior sd from the prior's mean %s", r$input, where,
            format(signif(r$median, 3)),
            format(round(r$prior_sds, 1), nsmall = 1), format(signif(r$prior_mean, 3)))
  }, character(1))
}

# The inputs whose chains did not mix (R-hat above 1.1, as the fit's print
# flags them), by fit: a named list of the fits that have any; empty when
# all mixed (or ran one chain).
unmixed_inputs <- function(fits) {
  out <- lapply(fits, function(f) {
    r <- f$rhat
    if (is.null(r)) return(NULL)
    r <- r[is.finite(r) & r > 1.1]
    if (length(r)) r
  })
  Filter(Negate(is.null), out)
}
