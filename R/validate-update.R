#' Validate again with new runs and the fit's own settings
#'
#' The second step of the loop "validate, see where it fails, add the missing
#' effect, validate again": [validate()] called again with the settings of
#' `object` (its [bias_control()] and [sampler_control()] objects, chains,
#' seed, and the pipeline's `windows`, `reference`, `knots_every`,
#' `features`, `basis_args`, `engine` and `experiments`), the field data it
#' was given (before registration) and the new `runs` and I/U map. With
#' `windows`, the raw field data (and each experiment's) are registered to
#' the reference `object` registered them to (the mean of its runs, or the
#' model at the base condition), not to the new runs: both fits are then
#' graded against one registered field, and what changes between them is
#' the model, not the target. Where the new effect moves the events, the
#' registration's shifts the sampler draws take it up, and the fit's errors
#' ([compare_validations()]) are taken net of them. Give `reference = runs`
#' to register to the new runs instead. The same settings and the same runs
#' give the same fit, draw for draw.
#'
#' A fit of [calibrate()] (emulators given by hand) holds no runs nor
#' pipeline settings: validate it with [validate()] first.
#'
#' @param object A `wv_fit` made by [validate()].
#' @param runs The new model runs (`wv_runs`); default: the fit's own. Runs
#'   of a model with an added effect have its strength as a further input.
#' @param iu The I/U map of `runs` (default: the fit's own); it must name
#'   the inputs of `runs`' design, the added strength included (see
#'   [iu_add()]).
#' @param ... Arguments of [validate()] that replace the fit's own: `field`,
#'   `windows`, `reference` (default: the reference `object`'s field data
#'   were registered to), `knots_every`, `features`, `basis_args`, `engine`,
#'   `experiments`, `bias`, `sampler`, `chains`, `seed`.
#' @return A `wv_fit` (see [validate()]).
#' @seealso [compare_validations()] to judge the change at a held-out
#'   condition.
#' @export
#' @examples
#' ex <- example_problem()
#' runs <- model_runs(as.data.frame(ex$emulators$design),
#'                    ex$emulators$banks$site1$y %*% t(ex$emulators$basis$Psi), ex$field$t, site = "site1")
#' fit <- validate(runs, ex$field, ex$iu, chains = 1, seed = 1,
#'                 sampler = sampler_control(n_draws = 50, n_inner = 5, quiet = TRUE))
#' # the same settings with a longer chain
#' fit2 <- update(fit, sampler = sampler_control(n_draws = 100, n_inner = 5, quiet = TRUE))
#' fit2
update.wv_fit <- function(object, runs = NULL, iu = NULL, ...) {
  check_class(object, "wv_fit")
  args <- object$call_args
  if (is.null(args)) {
    wv_abort(c(
      "{.fn update} needs a fit made by {.fn validate}; this one was made by {.fn calibrate}.",
      "i" = "It keeps neither the model runs nor the pipeline's settings.",
      "i" = "Validate with {.code validate(runs, field, iu, ...)}, then {.code update(fit, runs = , iu = )}."
    ), class = "update")
  }
  over <- list(...)
  allowed <- c("field", "windows", "reference", "knots_every", "features", "basis_args", "engine", "experiments",
               "bias", "sampler", "chains", "seed")
  if (length(over) && (is.null(names(over)) || any(names(over) == ""))) {
    wv_abort("The arguments of {.fn update} after {.arg iu} must be named.", class = "update")
  }
  bad <- setdiff(names(over), allowed)
  if (length(bad)) {
    wv_abort(c("{.fn update} does not take {.arg {bad}}.",
               "i" = "It takes {.arg runs}, {.arg iu} and {.arg {allowed}}."), class = "update")
  }
  runs <- runs %||% args$runs
  iu <- iu %||% object$iu
  check_class(runs, "wv_runs")
  check_class(iu, "wv_iu")
  check_update_inputs(runs, iu, object)
  settings <- list(field = args$field, windows = args$windows, reference = args$reference,
                   knots_every = args$knots_every, features = args$features, basis_args = args$basis_args,
                   engine = args$engine, experiments = args$experiments, bias = object$control$bias,
                   sampler = object$control$sampler, chains = args$chains, seed = object$seed)
  settings <- keep_registration(settings, args$registered_to, names(over))
  settings[names(over)] <- over
  do.call(validate, c(list(runs = runs, iu = iu), settings))
}

# The inputs of the new runs' design and of the I/U map must agree: checked
# here, before the registration, the basis and the emulators.
check_update_inputs <- function(runs, iu, fit, call = rlang::caller_env()) {
  design <- names(runs$design)
  miss_iu <- setdiff(design, iu$name)
  miss_runs <- setdiff(iu$name, design)
  if (length(miss_iu) || length(miss_runs)) {
    new <- setdiff(design, fit$inputs)
    wv_abort(c(
      "The inputs of {.arg runs} and of the I/U map {.arg iu} must be the same.",
      "x" = if (length(miss_iu)) "The runs' design has {.val {miss_iu}}, which the I/U map lacks.",
      "x" = if (length(miss_runs)) "The I/U map has {.val {miss_runs}}, which the runs' design lacks.",
      "i" = if (length(new)) {
        "Give the I/U map of the new runs with {.arg iu}, e.g. {.fn iu_add} of the fit's map with {.val {new}}."
      } else {
        "Give the I/U map of the new runs with {.arg iu}."
      }
    ), class = "update", call = call)
  }
  invisible(runs)
}

# One yardstick: the field data (and each experiment's) registered to the
# reference the former fit registered them to, unless `reference` (or
# `experiments`) is given anew, so that the two fits are graded against the
# same registered field.
keep_registration <- function(settings, registered_to, given) {
  if (is.null(registered_to)) return(settings)
  if (!"reference" %in% given && !is.null(registered_to$field)) settings$reference <- registered_to$field
  exps <- settings$experiments
  if (!"experiments" %in% given && length(exps) && length(registered_to$experiments)) {
    for (e in intersect(names(exps), names(registered_to$experiments))) {
      if (is.null(exps[[e]]$reference)) exps[[e]]$reference <- registered_to$experiments[[e]]
    }
    settings$experiments <- exps
  }
  settings
}
