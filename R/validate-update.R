#' Validate again with new runs and the fit's own settings
#'
#' The second step of the loop "validate, see where it fails, add the missing
#' effect, validate again": [validate()] called again with the settings of
#' `object` (its control objects, `control`, and its seed), the data it was
#' given (the field data before registration, the experiments) and the new
#' `runs` and I/U map. With `windows`, the raw field data (and each
#' experiment's) are registered to the reference `object` registered them to
#' (the mean of its runs, or the model at the base condition), not to the new
#' runs: both fits are then graded against one registered field, and what
#' changes between them is the model, not the target. Where the new effect
#' moves the events, the registration's shifts the sampler draws take it up,
#' and the fit's errors ([compare_validations()]) are taken net of them. Give
#' `reference = runs` to register to the new runs instead. The same settings
#' and the same runs give the same fit, draw for draw.
#'
#' A fit of [calibrate()] (emulators given by hand) holds no runs nor
#' pipeline settings: validate it with [validate()] first.
#'
#' @param object A `wv_fit` made by [validate()].
#' @param runs The new model runs (`wv_runs`); default: the fit's own. Runs
#'   of a model with an added effect have its inputs (a strength, perhaps
#'   rates) as further inputs.
#' @param iu The I/U map of `runs` (default: the fit's own); it must name
#'   the inputs of `runs`' design, the added ones included (see [iu_add()],
#'   whose `off` gives each its no-effect value).
#' @param ... Arguments of [validate()] that replace the fit's own, matched
#'   as [validate()] matches them: `field`, `experiments`, `seed`, a control
#'   object (`registration`, `emulation`, `bias`, `sampler`) or any argument
#'   of one given directly (`windows = `, `n_draws = `), which replaces that
#'   setting of the fit's control. The registration's `reference` stays the
#'   one the fit's field data were registered to unless `reference` is given,
#'   directly or in a `registration` control.
#' @return A `wv_fit` (see [validate()]).
#' @seealso [compare_validations()] to judge the change at a held-out
#'   condition.
#' @export
#' @examples
#' ex <- example_problem()
#' runs <- model_runs(as.data.frame(ex$emulators$design),
#'                    ex$emulators$banks$site1$y %*% t(ex$emulators$basis$Psi), ex$field$t,
#'                    site = "site1")
#' fit <- validate(runs, ex$field, ex$iu, seed = 1,
#'                 sampler = sampler_control(chains = 1, n_draws = 50, n_inner = 5, quiet = TRUE))
#' # the same settings with a longer chain
#' fit2 <- update(fit, n_draws = 100)
#' fit2
update.wv_fit <- function(object, runs = NULL, iu = NULL, ...) {
  check_class(object, "wv_fit")
  given <- fit_pipeline(object)
  if (is.null(given)) {
    wv_abort(c(
      "{.fn update} needs a fit made by {.fn validate}; this one was made by {.fn calibrate}.",
      "i" = "It keeps neither the model runs nor the pipeline's settings.",
      "i" = "Validate with {.code validate(runs, field, iu, ...)}, then {.code update(fit, runs = , iu = )}."
    ), class = "update")
  }
  over <- list(...)
  if (length(over) && (is.null(names(over)) || any(names(over) == ""))) {
    wv_abort("The arguments of {.fn update} after {.arg iu} must be named.", class = "update")
  }
  # validate()'s own arguments, the data and the seed, and the controls
  own <- setdiff(names(formals(validate)), c("runs", "iu", "..."))
  settings <- c(given[intersect(names(given), own)], fit_controls(object),
                list(seed = fit_get(object, "seed")))
  settings <- settings[intersect(own, names(settings))]
  bad <- setdiff(names(over), c(own, unlist(control_fields())))
  if (length(bad)) {
    wv_abort(c("{.fn update} does not take {.arg {bad}}.",
               "i" = "It takes {.arg runs}, {.arg iu}, {.arg {own}} and the arguments of their controls."),
             class = "update")
  }
  runs <- runs %||% given$runs
  iu <- iu %||% fit_get(object, "iu")
  check_class(runs, "wv_runs")
  check_class(iu, "wv_iu")
  check_update_inputs(runs, iu, object)
  mine <- names(over) %in% own
  settings[names(over)[mine]] <- over[mine]
  settings <- keep_registration(settings, given$registered_to, over)
  do.call(validate, c(list(runs = runs, iu = iu), settings, over[!mine]))
}

# The inputs of the new runs' design and of the I/U map must agree: checked
# here, before the registration, the basis and the emulators.
check_update_inputs <- function(runs, iu, fit, call = rlang::caller_env()) {
  design <- names(runs$design)
  miss_iu <- setdiff(design, iu$name)
  miss_runs <- setdiff(iu$name, design)
  if (length(miss_iu) || length(miss_runs)) {
    new <- setdiff(design, fit_get(fit, "inputs"))
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
# `experiments`) is given anew, directly or in a `registration` control, so
# that the two fits are graded against the same registered field.
keep_registration <- function(settings, registered_to, over) {
  if (is.null(registered_to)) return(settings)
  given_ref <- "reference" %in% names(over) || !is.null(over[["registration"]]$reference)
  if (!given_ref && !is.null(registered_to$field)) {
    settings$registration <- modify_control(settings$registration,
                                            list(reference = registered_to$field))
  }
  exps <- settings$experiments
  if (!"experiments" %in% names(over) && length(exps) && length(registered_to$experiments)) {
    for (e in intersect(names(exps), names(registered_to$experiments))) {
      if (is.null(exps[[e]]$reference)) exps[[e]]$reference <- registered_to$experiments[[e]]
    }
    settings$experiments <- exps
  }
  settings
}
