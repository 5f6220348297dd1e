# The controls of validate() in use: printed, their settings as text,
# merged with settings given through `...`, read back from a fit, and
# written as the call that makes them (the constructors are in
# calibrate-control.R).

#' @export
print.wv_bias_control <- function(x, ...) {
  cli::cat_line("<", class(x)[1], ">")
  for (nm in names(x)) cli::cat_line("  ", nm, ": ", control_value_text(x[[nm]]))
  invisible(x)
}

#' @export
print.wv_sampler_control <- print.wv_bias_control

#' @export
print.wv_registration_control <- print.wv_bias_control

#' @export
print.wv_emulation_control <- print.wv_bias_control

# A setting of a control object as text: a run of whole numbers as `a:b`, a
# noise prior by its constructor, named values as `name = value`.
control_value_text <- function(v) {
  if (is.null(v)) return("NULL")
  if (inherits(v, "wv_noise_prior")) return("noise_prior()")
  if (inherits(v, c("wv_runs", "wv_field"))) return(paste0("<", class(v)[1], ">"))
  if (is.list(v) && is.null(names(v))) {
    each <- function(e) paste0("(", if (is.numeric(e)) toString(trimws(format(e, digits = 3))) else
                                 control_value_text(e), ")")
    return(paste(vapply(v, each, ""), collapse = ", "))
  }
  if (is.list(v)) return(paste(sprintf("%s = %s", names(v), vapply(v, control_value_text, "")),
                               collapse = ", "))
  if (is.numeric(v) && length(v) > 1L && all(v == round(v)) && all(diff(v) == 1))
    return(paste0(v[1], ":", v[length(v)]))
  if (!is.null(names(v))) return(paste(sprintf("%s = %s", names(v), format(v, digits = 3)),
                                       collapse = ", "))
  paste(format(v, digits = 3), collapse = ", ")
}

# The control objects by kind, and the settings each holds: the arguments
# of its constructor, read from it (never typed again).
control_kinds <- function() {
  list(registration = registration_control, emulation = emulation_control, bias = bias_control,
       sampler = sampler_control)
}

control_fields <- function(kinds = names(control_kinds())) {
  lapply(control_kinds()[kinds], function(f) names(formals(f)))
}

# A control object with the settings in `values` (a named list) replaced,
# checked again by its constructor. A control made before a setting existed
# gets that setting's default.
modify_control <- function(x, values = list()) {
  kind <- sub("^wv_(.*)_control$", "\\1", class(x)[1])
  args <- unclass(x)[intersect(names(x), names(formals(control_kinds()[[kind]])))]
  args[names(values)] <- values
  do.call(control_kinds()[[kind]], args)
}

# The control objects `controls` (a named list by kind) of a call of `fun`,
# with the settings named directly in the call (in `...`, `dots`) moved into
# their control. A name no control takes is an error of class `class`.
resolve_controls <- function(controls, dots, fun, class = "input", call = rlang::caller_env()) {
  fields <- control_fields(names(controls))
  for (kind in names(controls)) {
    x <- controls[[kind]]
    check_class(x, paste0("wv_", kind, "_control"), arg = kind, call = call)
    if (!identical(names(x), fields[[kind]])) controls[[kind]] <- modify_control(x)
  }
  if (!length(dots)) return(controls)
  nm <- names(dots) %||% rep("", length(dots))
  unknown <- ifelse(nzchar(nm), nm, paste0("..", seq_along(nm)))[!nm %in% unlist(fields)]
  if (length(unknown)) {
    ctors <- paste0(names(controls), "_control")
    wv_abort(c("{.fn {fun}} does not take {.arg {unknown}}.",
               "i" = "Besides its own arguments, it takes those of {.fn {ctors}}, by name."),
             class = class, call = call)
  }
  for (kind in names(controls)) {
    mine <- nm %in% fields[[kind]]
    if (any(mine)) controls[[kind]] <- modify_control(controls[[kind]], dots[mine])
  }
  controls
}

# The control objects a fit was made with (`registration` and `emulation`
# NULL for a fit of calibrate()); for a fit made before they were stored,
# rebuilt from its settings.
fit_controls <- function(fit) {
  ctl <- fit_get(fit, "control")
  if (is.null(ctl)) ctl <- old_fit_controls(fit)
  if (is.null(ctl$sampler$chains)) {
    ctl$sampler <- modify_control(ctl$sampler,
                                  list(chains = fit_get(fit, "settings")$chains %||% 2))
  }
  old <- fit_get(fit, "call_args")
  if (is.null(ctl$registration) && !is.null(old)) {
    ctl$registration <- registration_control(old$windows, old$reference, old$knots_every,
                                             old$features %||% c("min", "max"))
    ctl$emulation <- emulation_control(old$basis_args %||% list(), old$engine %||% "gasp_level")
  }
  ctl
}

old_fit_controls <- function(fit) {
  st <- fit_get(fit, "settings")
  args <- fit$calibrate_args %||% list()
  bias <- bias_control(sigma2 = args$sigma2, pool_levels = st$pool_levels,
                       inform_levels = st$inform_levels,
                       input_likelihood = st$input_likelihood %||% "independent",
                       temper = st$temper %||% 1,
                       registration_variance = st$registration_variance %||% FALSE,
                       fix_tau2 = args$fix_tau2,
                       level_variances = st$level_variances %||% "shared",
                       experiment_bias = st$experiment_bias %||% "own")
  sampler <- sampler_control(n_draws = st$n_draws, n_inner = st$n_inner, step = st$step,
                             proposal = st$proposal %||% "report",
                             global_moves = st$global_moves %||% 0,
                             burnin = st$burnin, n_search = st$n_search %||% 200L,
                             chains = st$chains %||% 2)
  list(bias = bias, sampler = sampler)
}

# A control object as the call that makes it, naming only the settings away
# from the defaults (and `always`, even at its default).
control_call <- function(x, always = character(0)) {
  name <- sub("^wv_", "", class(x)[1])
  defaults <- unclass(do.call(name, list()))
  show <- function(v) {
    if (inherits(v, "wv_noise_prior")) return("noise_prior(...)")
    if (is.numeric(v) && length(v) > 1L && all(v == round(v)) && all(diff(v) == 1))
      return(paste0(v[1], ":", v[length(v)]))
    out <- paste(deparse(v, width.cutoff = 500L), collapse = "")
    if (nchar(out) > 60L) "..." else out
  }
  keep <- vapply(names(x), function(nm) nm %in% always || !identical(x[[nm]], defaults[[nm]]),
                 logical(1))
  keep[names(x) %in% c("quiet", "threads", "chains", "together")] <- FALSE
  args <- vapply(names(x)[keep], function(nm) paste(nm, "=", show(x[[nm]])), "")
  paste0(name, "(", paste(args, collapse = ", "), ")")
}
