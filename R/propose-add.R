# The loop from a proposal: the proposed term added to the model, its
# strength a new calibration input, the runs made and the model validated
# again with update().

#' Add a proposed term to the model and validate again
#'
#' The loop from a proposal in one call: the term that [propose_terms()]
#' ranked `which`-th is added to the model, its strength a new calibration
#' input `s_term` on the range from 0 (the term switched off) to twice the
#' strength proposed, the runs of the model with the term are made, and the
#' model is validated again with [update()] (the settings of `fit`, its
#' field registered to the same reference). Judge the result with
#' [compare_validations()] at a held-out condition.
#'
#' A term of the output (channels `"output"` and `"d/dt output"`) needs no
#' simulator: it is added to the model's own runs, each run's output plus
#' its strength times the term's function of that run's output (or of its
#' time derivative), at strengths drawn evenly over the range; the model
#' then has the term on its output, not in its equations. A term with memory
#' of the output is added so, on each run's curve; a filter's time constant
#' (`tau_term`) or a delay's lag (`lag_term`) is then calibrated too, over
#' the range of the library's versions, each run at its own value (the
#' versions that differ only in it are one effect). A term of a state
#' acts through the model's equations, so it needs `simulate`: a function
#' `function(design, channel, fun)` that runs the simulator at the rows of
#' `design` (the inputs of `fit` and `s_term`) with the term
#' `s_term * fun(channel)` added where that state acts, and returns a
#' `wv_runs` on the grid and sites of `fit` (for the test beds,
#' `simulate_suspension(design, term = testbed_term(channel, fun))`). With
#' `simulate`, the runs are a maximin design of `n_runs` points over the
#' inputs and the strength, joined by the model's own runs with the strength
#' at 0 (the model without the term, which the emulators must know).
#'
#' @param fit A `wv_fit` made by [validate()] (it keeps its runs).
#' @param proposals A `wv_proposals` from [propose_terms()] on `fit`.
#' @param simulate `NULL`, or for a term of a state (or any term to be put
#'   in the equations) the simulator hook described above.
#' @param which The row of `proposals` to add (the first: the most probable
#'   family's most probable version).
#' @param n_runs With `simulate`: the number of runs of the model with the
#'   term (default: as many as `fit` has).
#' @param seed Seed of the design and of the strengths (the caller's random
#'   stream is left as it was).
#' @return The `wv_fit` of the model with the term, as [update()] gives it,
#'   with an attribute `added_term`: `term`, `channel`, `strength` (the
#'   proposal's), `range` of `s_term`, `runs` (how many were made) and
#'   `simulated` (whether through `simulate`), and `rate` (the calibrated
#'   time constant or lag: `name`, `lower`, `upper`, the proposal's `value`;
#'   `NULL` for other terms).
#' @seealso [propose_terms()], [update()], [compare_validations()].
#' @export
#' @examples
#' \donttest{
#' t <- seq(0, 1, length.out = 128)
#' model <- function(u, x) (1 + 0.5 * x) * sin(2 * pi * t) + u * exp(-((t - 0.6) / 0.08)^2)
#' design <- data.frame(u1 = (0:29 + runif(30)) / 30, x1 = (sample(30) - runif(30)) / 30)
#' runs <- model_runs(design, t(mapply(model, design$u1, design$x1)), t)
#' truth <- model(0.4, 0.5)
#' reality <- truth + 0.5 * pmax(truth - quantile(truth, 0.9), 0)
#' field <- field_runs(t(replicate(3, reality + rnorm(128, sd = 0.01))), t, x_nom = c(x1 = 0.5))
#' iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), c(0, 0), c(1, 1))
#' fit <- validate(runs, field, iu, chains = 1, seed = 1,
#'                 sampler = sampler_control(n_draws = 60, n_inner = 10))
#' pr <- propose_terms(fit, term_library(fit), n_draws = 40, seed = 1)
#' fit2 <- add_term(fit, pr)
#' attr(fit2, "added_term")
#' coef(fit2)
#' }
add_term <- function(fit, proposals, simulate = NULL, which = 1L, n_runs = NULL, seed = 1L) {
  check_class(fit, "wv_fit")
  check_class(proposals, "wv_proposals", "proposals")
  check_number(which, "which", min = 1, integer = TRUE)
  check_number(seed, "seed", integer = TRUE)
  if (!is.null(simulate) && !is.function(simulate)) {
    wv_abort(c("{.arg simulate} must be a function {.code function(design, channel, fun)} or NULL.",
               "x" = "It is {.obj_type_friendly {simulate}}."), class = "input")
  }
  if (!is.null(n_runs)) check_number(n_runs, "n_runs", min = 2, integer = TRUE)
  given <- fit_pipeline(fit)
  if (is.null(given$runs)) {
    wv_abort(c("{.fn add_term} needs a fit made by {.fn validate}: it keeps the model runs.",
               "i" = "Validate with {.code validate(runs, field, iu, ...)} first."), class = "update")
  }
  if (which > nrow(proposals)) {
    wv_abort("{.arg which} is {which}; {.arg proposals} has {nrow(proposals)} row{?s}.",
             class = "input")
  }
  top <- proposals[which, , drop = FALSE]
  fun <- attr(proposals, "funs")[[top$term]]
  op <- attr(proposals, "ops")[[top$term]]
  output <- top$channel %in% c("output", "d/dt output")
  if (!is.null(op) && (!output || !is.null(simulate))) {
    wv_abort(c("Proposal {.val {top$term}} has memory: only a term of the output can be added, to the runs, without {.arg simulate}.",
               "i" = "{.arg simulate} takes a function of a state's value, not of its history."),
             class = "input")
  }
  if (is.null(fun) && is.null(op)) {
    wv_abort(c("Proposal {.val {top$term}} is a product of two terms: it cannot be added as one.",
               "i" = "Add its factors one at a time, or choose another row with {.arg which}."),
             class = "input")
  }
  if (!output && is.null(simulate)) {
    wv_abort(c("Proposal {.val {top$term}} is a term of the state {.val {top$channel}}: it acts through the model's equations.",
               "i" = "Give {.arg simulate}, {.code function(design, channel, fun)} running the simulator with the term added (see {.fn add_term})."),
             class = "input")
  }
  if ("s_term" %in% fit_get(fit, "inputs")) {
    wv_abort("The fit already has an input {.val s_term}: add one term at a time to a fit without it.",
             class = "input")
  }
  strength <- top$strength
  if (!is.finite(strength) || strength == 0) {
    wv_abort("Proposal {.val {top$term}} has no strength to add (it is {strength}).", class = "input")
  }
  ends <- sort(c(0, 2 * strength))
  iu <- iu_add(fit_get(fit, "iu"), "s_term", lower = ends[1], upper = ends[2],
               nominal = mean(ends), off = 0)
  # a filter's time constant or a delay's lag: calibrated beside the strength
  rate <- if (is.null(simulate)) attr(proposals, "rates")[[top$term]]
  if (!is.null(rate)) {
    if (rate$name %in% fit_get(fit, "inputs")) {
      wv_abort("The fit already has an input {.val {rate$name}}: add one term at a time.", class = "input")
    }
    iu <- iu_add(iu, rate$name, lower = rate$lower, upper = rate$upper, nominal = rate$value, off = NA)
  }
  runs <- given$runs
  if (is.null(simulate)) {
    n <- nrow(runs$design)
    strata <- function() (sample(n) - stats::runif(n)) / n
    s <- with_rng_seed(seed, ends[1] + diff(ends) * strata())
    design <- runs$design
    design$s_term <- s
    if (!is.null(rate)) {
      r <- with_rng_seed(seed + 1L, rate$lower + (rate$upper - rate$lower) * strata())
      design[[rate$name]] <- r
    }
    curves <- lapply(runs$curves, function(Y) {
      X <- if (top$channel == "output") Y else t(apply(Y, 1L, grid_slope, t = runs$t))
      if (is.null(op)) return(Y + s * matrix(fun(X), nrow(X)))
      if (!is.null(rate)) {
        return(Y + s * t(vapply(seq_len(nrow(X)), function(i) rate$op(X[i, ], runs$t, r[i]),
                                numeric(ncol(X)))))
      }
      Y + s * t(apply(X, 1L, op, t = runs$t))
    })
    off <- runs$design
    off$s_term <- 0
    if (!is.null(rate)) off[[rate$name]] <- rate$value
    new_runs <- c(model_runs(off, runs$curves, runs$t), model_runs(design, curves, runs$t))
    made <- nrow(design)
  } else {
    n <- n_runs %||% nrow(runs$design)
    design <- design_maximin(iu, n, seed = seed)
    made_runs <- simulate(design, top$channel, fun)
    if (!inherits(made_runs, "wv_runs")) {
      wv_abort(c("{.arg simulate} must return a {.cls wv_runs} (see {.fn model_runs}).",
                 "x" = "It returned {.obj_type_friendly {made_runs}}."), class = "input")
    }
    off <- runs$design
    off$s_term <- 0
    new_runs <- c(model_runs(off, runs$curves, runs$t), made_runs)
    made <- nrow(made_runs$design)
  }
  wv_inform(c("i" = "Added {.val {top$term}} as {.code s_term} on [{signif(ends[1], 3)}, {signif(ends[2], 3)}]{if (is.null(rate)) '' else sprintf(', its %s as %s on [%s, %s]', rate$what, rate$name, signif(rate$lower, 3), signif(rate$upper, 3))}, {made} run{?s} {if (is.null(simulate)) 'of the term on the output' else 'simulated'}; validating again with {.fn update}."))
  out <- stats::update(fit, runs = new_runs, iu = iu)
  attr(out, "added_term") <- list(term = top$term, channel = top$channel, strength = strength,
                                  range = ends, runs = made, simulated = !is.null(simulate),
                                  rate = if (!is.null(rate)) rate[c("name", "lower", "upper", "value")])
  out
}
