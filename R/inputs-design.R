#' A space-filling design for the model runs
#'
#' An approximately maximin Latin hypercube on the ranges of an I/U map: the
#' best of 50 random Latin hypercubes by their smallest inter-point distance
#' (inputs scaled to the unit cube), improved by 2000 swaps of two values
#' within a column that increase that distance. The report's designs are of
#' this kind. With `nominal = TRUE` the nominal point is added as the last
#' run, as in the test bed.
#'
#' Emulators are only as accurate as their design: with few runs per input,
#' their errors away from the runs exceed their predictive variances and the
#' calibrated inputs compensate. Adding runs is the remedy.
#'
#' With `conditions`, the tested values of test conditions (or of any
#' input) are given: for each tested value, the run of the hypercube nearest
#' to it in that input is moved onto it, so the emulators see the model at
#' every tested condition (the range's ends included) and the design stays a
#' Latin hypercube up to those moves (each to the nearest run not yet moved).
#'
#' @inheritParams calibrate
#' @param n Number of runs, including the nominal point when `nominal = TRUE`.
#' @param nominal Add the nominal point as the last run.
#' @param conditions `NULL`, or a named list: for each named input of `iu`,
#'   the values at which the field was measured (the tested conditions), each
#'   inside the input's range; at most as many values as runs.
#' @return A data frame with one column per input of `iu` and `n` rows, in the
#'   inputs' own units.
#' @export
#' @examples
#' iu <- iu_map(c("u1", "x1"), c("calibration", "variation"),
#'              lower = c(0, 10), upper = c(1, 20), nominal = c(0.5, 15))
#' d <- design_maximin(iu, 12, seed = 1)
#' d
#' plot(d)
#' # runs at the temperatures of the tests
#' iu_T <- iu_map(c("A", "T"), c("calibration", "condition"),
#'                lower = c(0, 293), upper = c(1, 1203), nominal = c(0.5, 293))
#' d_T <- design_maximin(iu_T, 20, seed = 1, conditions = list(T = c(293, 673, 1203)))
#' sort(d_T$T)
design_maximin <- function(iu, n, nominal = TRUE, seed = NULL, conditions = NULL) {
  check_class(iu, "wv_iu")
  check_number(n, min = if (isTRUE(nominal)) 3 else 2, max = 1e5, integer = TRUE)
  if (!is.logical(nominal) || length(nominal) != 1L || is.na(nominal)) {
    wv_abort("{.arg nominal} must be TRUE or FALSE.")
  }
  n_lhd <- as.integer(n) - as.integer(nominal)
  conditions <- check_design_conditions(conditions, iu, n_lhd)
  seed <- resolve_seed(seed)
  cube <- with_rng_seed(seed, maximin_lhd(n_lhd, nrow(iu)))
  d <- sweep(sweep(cube, 2L, iu$upper - iu$lower, `*`), 2L, iu$lower, `+`)
  colnames(d) <- iu$name
  for (nm in names(conditions)) d[, nm] <- runs_at_values(d[, nm], conditions[[nm]])
  if (nominal) d <- rbind(d, iu$nominal)
  colnames(d) <- iu$name
  as.data.frame(d)
}

# The tested values given to design_maximin(): a named list of inputs of the
# map, each a vector of finite values inside the input's range, at most as
# many in all per input as the hypercube has runs.
check_design_conditions <- function(conditions, iu, n_lhd, call = rlang::caller_env()) {
  if (is.null(conditions)) return(NULL)
  if (!is.list(conditions) || is.null(names(conditions)) || any(!nzchar(names(conditions)))) {
    wv_abort(c("{.arg conditions} must be a named list: for each input, its tested values.",
               "i" = "For example {.code conditions = list(T = c(293, 673, 1203))}."), call = call)
  }
  unknown <- setdiff(names(conditions), iu$name)
  if (length(unknown)) {
    wv_abort(c("{.arg conditions} names input{?s} the I/U map lacks: {.val {unknown}}.",
               "i" = "Inputs: {.val {iu$name}}."), call = call)
  }
  for (nm in names(conditions)) {
    v <- conditions[[nm]]
    k <- match(nm, iu$name)
    if (!is.numeric(v) || !length(v) || anyNA(v) || any(!is.finite(v))) {
      wv_abort("The tested values of {.val {nm}} must be finite numbers.", call = call)
    }
    out <- v < iu$lower[k] | v > iu$upper[k]
    if (any(out)) {
      wv_abort(c("Tested values of {.val {nm}} outside its range: {.val {v[out]}}.",
                 "i" = "{.val {nm}} spans {iu$lower[k]} to {iu$upper[k]} in the I/U map: widen it there."),
               call = call)
    }
    conditions[[nm]] <- sort(unique(v))
    if (length(conditions[[nm]]) > n_lhd) {
      wv_abort(c("{length(conditions[[nm]])} tested values of {.val {nm}} for {n_lhd} run{?s} of the hypercube.",
                 "i" = "Ask for at least as many runs as tested values."), call = call)
    }
  }
  conditions
}

# One column of a hypercube with, for each tested value (in turn), the run
# nearest to it among those not yet moved set to it exactly.
runs_at_values <- function(x, values) {
  free <- rep(TRUE, length(x))
  for (v in values) {
    i <- which(free)[which.min(abs(x[free] - v))]
    x[i] <- v
    free[i] <- FALSE
  }
  x
}

#' More model runs where the posterior lies
#'
#' A design for a second wave of model runs, placed where the calibrated
#' inputs are: each point is a posterior draw of the inputs of `fit`, moved
#' by a normal step of standard deviation `spread` times the input's range and
#' kept inside the range; of 50 such random sets, the one whose smallest
#' distance between points (and to the runs the emulators already have) is
#' largest, so that no two runs nearly repeat each other.
#'
#' Emulators fitted to a space-filling design err most where they matter: the
#' field data pin the inputs down far more tightly than the runs cover them,
#' and an emulator error there looks like a bias of the model (a credible one,
#' flagged by [where_fails()]) and moves the calibrated inputs. Running the
#' model at this design, adding the runs to the first ones with `c()`,
#' fitting the emulators again on the same basis and calibrating again removes
#' most of that error.
#'
#' On the package's suspension test bed with nothing hidden and replicates
#' free of time warps, a second wave cut the error of the posterior mean
#' inputs by about an order of magnitude, and left almost no credible bias
#' where the first emulators' error had been flagged along the whole record
#' (`studies/README.md` in the package's source repository,
#' "second_wave.R"). The narrower band can then flag a small bias over longer
#' intervals: a `tolerance` in [where_fails()] says how small a bias does
#' not matter. With registered
#' replicates, the second wave shows the registration's error at the events
#' more sharply rather than hiding it: register the replicates again to the
#' mean of the new runs, whose landmarks sit near where the calibrated model
#' has them, and build the basis anew on all the runs. Nor does a second wave
#' bring back inputs that make up for a missing mechanism.
#'
#' @inheritParams bands
#' @inheritParams calibrate
#' @param n Number of runs.
#' @param spread Standard deviation of the step added to each posterior
#'   draw, as a share of each input's range (`0`: the posterior draws
#'   themselves).
#' @return A data frame with one column per input of the fit's emulators and
#'   `n` rows, in the inputs' own units: the variation inputs at their actual
#'   values (nominal plus variation), as the runs' design has them.
#' @seealso [design_maximin()] for the first wave, [c.wv_runs()] to add the
#'   new runs to the old.
#' @export
#' @examples
#' fit <- example_fit()
#' design_posterior(fit, 5, seed = 1)
design_posterior <- function(fit, n, spread = 0.05, seed = NULL) {
  check_class(fit, "wv_fit")
  check_number(n, min = 1, max = 1e5, integer = TRUE)
  check_number(spread, min = 0, max = 1)
  seed <- resolve_seed(seed)
  k <- match(fit$inputs, fit$prior_iu$name)
  lower <- fit$prior_iu$lower[k]
  width <- fit$prior_iu$upper[k] - lower
  to_cube <- function(m) sweep(sweep(as.matrix(m), 2L, lower, `-`), 2L, width, `/`)
  draws <- to_cube(as.matrix(fit$draws)[, fit$inputs, drop = FALSE])
  old <- to_cube(fit$emulators$design[, fit$inputs, drop = FALSE])
  n <- as.integer(n)
  p <- length(fit$inputs)
  one_set <- function() {
    z <- draws[sample.int(nrow(draws), n, replace = TRUE), , drop = FALSE]
    pmin(pmax(z + matrix(stats::rnorm(n * p, sd = spread), n, p), 0), 1)
  }
  mindist <- function(z) {
    d <- as.matrix(stats::dist(rbind(z, old)))[seq_len(n), , drop = FALSE]
    d[cbind(seq_len(n), seq_len(n))] <- Inf
    min(d)
  }
  best <- with_rng_seed(seed, {
    sets <- replicate(50L, one_set(), simplify = FALSE)
    sets[[which.max(vapply(sets, mindist, numeric(1)))]]
  })
  d <- sweep(sweep(best, 2L, width, `*`), 2L, lower, `+`)
  colnames(d) <- fit$inputs
  as.data.frame(d)
}

# Approximately maximin Latin hypercube in [0, 1]^p: the best of n_start
# random LHDs, improved by element swaps within a column that increase the
# smallest inter-point distance. Uses R's RNG.
maximin_lhd <- function(n, p, n_start = 50L, n_swap = 2000L) {
  random_lhd <- function() vapply(seq_len(p), function(j) (sample.int(n) - stats::runif(n)) / n,
                                  numeric(n))
  mindist <- function(x) min(stats::dist(x))
  best <- random_lhd()
  best_d <- mindist(best)
  for (i in seq_len(n_start - 1L)) {
    cand <- random_lhd()
    d <- mindist(cand)
    if (d > best_d) {
      best <- cand
      best_d <- d
    }
  }
  for (i in seq_len(n_swap)) {
    j <- sample.int(p, 1L)
    ab <- sample.int(n, 2L)
    cand <- best
    cand[ab, j] <- cand[rev(ab), j]
    d <- mindist(cand)
    if (d > best_d) {
      best <- cand
      best_d <- d
    }
  }
  best
}
