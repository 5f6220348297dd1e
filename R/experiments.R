#' One more experiment of the same unit
#'
#' Engineers test one unit in several conditions: a test course, the same
#' course with an added mass, another load. The experiments share the
#' calibration inputs `u` and the unit's manufacturing variations `delta`, so
#' calibrating on all of them at once uses all the evidence: a missing
#' mechanism that moving an input mimics under one load is rarely mimicked by
#' the same input value under another.
#'
#' An experiment holds its field data and says how the model predicts it:
#' * `change`: the known change of some inputs from the base experiment (the
#'   added mass: `c(x1 = 0.15)`, in the inputs' own units). The base
#'   experiment's emulators then serve, evaluated at the inputs plus `change`;
#'   keep the changed inputs inside the emulators' design ranges.
#' * `emulators`: the experiment's own emulators (from its own model runs), on
#'   the basis of the base experiment and with the same inputs.
#' * `condition`: the experiment's value of each test condition, the inputs
#'   of type `"condition"` of the I/U map (see [iu_map()], section
#'   Conditions): a known setting such as a dose or a temperature, spanned by
#'   the model runs' design. It stands for the change `condition - nominal`
#'   of those inputs, `nominal` being the base experiment's value; a
#'   `change` of other inputs may come with it. [experiments_at()] makes the
#'   experiments of many fields at once.
#'
#' Give the experiments to [calibrate()] or [validate()] through their
#' argument `experiments`, a named list. Each experiment has its own bias
#' (one bias function per experiment and site) and its own field noise; with
#' `level_variances = "shared"` (the default) the bias variances of a
#' resolution level are shared by the experiments, so that an experiment
#' with few replicates borrows strength from the others.
#'
#' @param field A `wv_field` ([field_runs()], registered like the base
#'   experiment's) on the grid of the base experiment's basis, its sites a
#'   subset of the base experiment's sites (with `change`) or of the sites of
#'   `emulators`. One replicate is enough: the noise is then learned.
#' @param change A named numeric vector: the change of the inputs named from
#'   the base experiment, or `NULL` with `emulators`.
#' @param emulators A `wv_emulators` object of this experiment's own runs, or
#'   `NULL` with `change` or `condition`.
#' @param reference Optional `wv_runs` of the model in this experiment's
#'   condition (the runs of the base design with the change, say):
#'   [validate()] registers the experiment's field data to their mean, as it
#'   registers the base experiment's to the mean of its runs. `NULL` (the
#'   default): to the model in this experiment's condition as the emulators
#'   predict it, never to the base condition's runs (see [validate()],
#'   argument `experiments`).
#' @param condition A named numeric vector: the experiment's value of every
#'   condition input of the I/U map (in its own units), or `NULL` when the
#'   I/U map has none. Checked by [calibrate()] and [validate()] against the
#'   I/U map: every condition given, none other, each inside its design
#'   range, and no `change` of a condition.
#' @return A `wv_experiment` object.
#' @seealso [calibrate()], [where_fails()] (which reports each experiment's
#'   sites), [experiments_at()].
#' @export
#' @examples
#' tb <- load_testbed()
#' # validate() registers its field data to the model with the change
#' experiment(tb$added_mass$field, change = tb$added_mass$delta)
#' # the same experiment with x1 a condition of the I/U map (nominal 0.5)
#' experiment(tb$added_mass$field, condition = c(x1 = 0.65))
experiment <- function(field, change = NULL, emulators = NULL, reference = NULL, condition = NULL) {
  call <- rlang::current_env()
  check_class(field, "wv_field", call = call)
  check_condition_values(condition, call = call)
  if (!is.null(condition) && !is.null(emulators)) {
    wv_abort(c("An experiment at a {.arg condition} is predicted by the base experiment's emulators; it takes no {.arg emulators}.",
               "i" = "Run the model over the conditions in the base design, with the condition as an input."),
             class = c("condition", "experiment"), call = call)
  }
  if (is.null(condition) && is.null(change) == is.null(emulators)) {
    wv_abort(c("An experiment needs either {.arg change} or {.arg emulators}, not both or neither (or a {.arg condition}).",
               "i" = "Give {.arg change} (e.g. {.code c(x1 = 0.15)}) when the base experiment's emulators serve at the changed inputs."),
             class = "experiment", call = call)
  }
  if (!is.null(change)) {
    if (!is.numeric(change) || !length(change) || is.null(names(change)) ||
        any(names(change) == "") ||
        anyNA(change) || any(!is.finite(change)) || anyDuplicated(names(change))) {
      wv_abort(c("{.arg change} must be a named numeric vector of finite changes, one per input named.",
                 "x" = "It is {.code {deparse(change)}}."), class = "experiment", call = call)
    }
  }
  if (!is.null(emulators)) check_class(emulators, "wv_emulators", call = call)
  if (!is.null(reference)) check_class(reference, "wv_runs", call = call)
  structure(list(field = field, change = change, emulators = emulators, reference = reference,
                 condition = condition),
            class = "wv_experiment")
}

#' Experiments at many conditions at once
#'
#' Makes one [experiment()] for each field at its value of the test
#' conditions: the curves of one system measured at several settings (doses,
#' temperatures, loads). Give the result to [calibrate()] or [validate()] as
#' `experiments`, with the field of the base condition (the conditions'
#' nominal values in the I/U map) as `field`.
#'
#' @param fields A named list of `wv_field` objects ([field_runs()]), one
#'   per experiment; or a data frame of long field data with a column for
#'   each condition input, every distinct combination of their values an
#'   experiment named `"<input>=<value>"` (joined by `","`), its rows read by
#'   `field_runs(rows, ...)`.
#' @param condition With a list of fields: a data frame with one row per
#'   field, in the order of `fields`, and one numeric column per condition
#'   input. With long data: the names of its condition columns.
#' @param ... With long data: the arguments of [field_runs()] that name its
#'   columns (`t`, `y`, `site`, `replicate`) and `x_nom`.
#' @param base `NULL`, or the base condition: a named numeric vector, one
#'   value per condition input (the I/U map's nominal values). Its field (the
#'   curves measured there) is then not made an experiment but kept as the
#'   base field, so that the whole data set is given once: pass the result
#'   as `field` to [validate()] or [calibrate()] (with no `experiments`, or
#'   with further ones), and the base field and the experiments are read
#'   from it. A base condition that no field was measured at is an error.
#' @return A named list of `wv_experiment` objects. With `base`, the list has
#'   class `wv_experiments_at` and carries the base field in its attribute
#'   `"field"`.
#' @seealso [experiment()], [iu_map()] (section Conditions).
#' @export
#' @examples
#' tb <- load_testbed()
#' experiments_at(list(added_mass = tb$added_mass$field), data.frame(x1 = 0.65))
#' # long data: three doses, two replicates each, on sixteen time points
#' long <- expand.grid(t = 0:15, replicate = 1:2, dose = c(250, 400, 550))
#' long$y <- long$dose / 400 * exp(-long$t / 2) + rnorm(nrow(long), sd = 0.01)
#' experiments_at(long, "dose", t = "t", y = "y", replicate = "replicate")
#' # the whole data set, the 400 mg curves as the base field
#' all_doses <- experiments_at(long, "dose", t = "t", y = "y", replicate = "replicate",
#'                             base = c(dose = 400))
#' all_doses
experiments_at <- function(fields, condition, ..., base = NULL) {
  if (is.data.frame(fields)) {
    cols <- condition
    if (!is.character(cols) || !length(cols) || !all(cols %in% names(fields))) {
      wv_abort(c("With long field data, {.arg condition} must name its condition columns.",
                 "i" = "Its columns: {.val {names(fields)}}."), class = "condition")
    }
    bad <- cols[!vapply(fields[cols], is.numeric, logical(1))]
    if (length(bad)) wv_abort("The condition column{?s} {.val {bad}} must be numeric.",
                              class = "condition")
    key <- do.call(paste,
                   c(lapply(cols, function(p) paste0(p, "=", format(fields[[p]], trim = TRUE))),
                     sep = ","))
    keys <- unique(key)
    long <- fields
    fields <- stats::setNames(lapply(keys, function(k) {
      field_runs(long[key == k, setdiff(names(long), cols), drop = FALSE], ...)
    }), keys)
    condition <- long[match(keys, key), cols, drop = FALSE]
  } else if (...length()) {
    wv_abort("The arguments after {.arg condition} are for long field data only.",
             class = "condition")
  }
  if (inherits(fields, "wv_field") || !is.list(fields) || !length(fields) ||
      is.null(names(fields)) ||
      any(names(fields) == "") || anyDuplicated(names(fields))) {
    wv_abort(c("{.arg fields} must be a named list of {.cls wv_field}s, one per experiment, or long field data.",
               "i" = "For example {.code list(dose_250 = field_250, dose_550 = field_550)}."),
             class = "condition")
  }
  if (!is.data.frame(condition) || nrow(condition) != length(fields) || !ncol(condition) ||
      !all(vapply(condition, is.numeric, logical(1)))) {
    wv_abort(c("{.arg condition} must be a data frame of numeric columns, one row per field ({length(fields)}).",
               "x" = if (is.data.frame(condition)) "It has {nrow(condition)} row{?s}." else
                 "It is {.obj_type_friendly {condition}}."), class = "condition")
  }
  at_base <- base_condition_row(condition, base)
  out <- lapply(seq_along(fields), function(i) {
    experiment(fields[[i]], condition = unlist(condition[i, , drop = FALSE]))
  })
  out <- stats::setNames(out, names(fields))
  if (is.null(base)) return(out)
  structure(out[-at_base], field = fields[[at_base]], base = base[names(condition)],
            class = c("wv_experiments_at", "list"))
}

# The row of `condition` (a data frame, one row per field) at the base
# condition `base` (a named numeric, one value per column), or a classed
# error when there is none, or more than one, or `base` is malformed.
base_condition_row <- function(condition, base, call = rlang::caller_env()) {
  if (is.null(base)) return(NULL)
  cols <- names(condition)
  if (!is.numeric(base) || is.null(names(base)) || anyNA(base) || !setequal(names(base), cols)) {
    wv_abort(c("{.arg base} must be a named number for each condition: {.val {cols}}.",
               "i" = "For example {.code base = c({cols[1]} = {signif(condition[[1]][1], 4)})}."),
             class = "condition", call = call)
  }
  same <- vapply(seq_len(nrow(condition)), function(i) {
    v <- unlist(condition[i, cols, drop = FALSE])
    all(abs(v - base[cols]) <= 1e-9 * pmax(1, abs(base[cols])))
  }, logical(1))
  if (sum(same) != 1L) {
    wv_abort(c("No field was measured at the base condition {.val {paste(cols, base[cols], sep = ' = ')}}.",
               "i" = "The fields' conditions: {.val {unique(do.call(paste, c(condition, sep = ', ')))}}.",
               "i" = "Give {.arg base} the condition the base field was measured at (the I/U map's nominal values)."),
             class = "condition", call = call)
  }
  which(same)
}

#' @export
print.wv_experiments_at <- function(x, ...) {
  fld <- attr(x, "field")
  reps <- vapply(fld$curves, nrow, integer(1))
  base <- attr(x, "base")
  cli::cat_line(sprintf("<wv_experiments_at> the base field at %s (%s) and %d experiment%s at other conditions:",
                        paste(sprintf("%s = %g", names(base), base), collapse = ", "),
                        paste(sprintf("%s: %d replicate%s", names(reps), reps,
                                      ifelse(reps == 1, "", "s")),
                              collapse = ", "),
                        length(x), if (length(x) == 1L) "" else "s"))
  for (e in names(x)) {
    cli::cat_line("  ", e, ": ", paste(utils::capture.output(print(x[[e]])), collapse = " "))
  }
  cli::cat_line("Give it as `field` to validate() or calibrate(): the base field and the experiments are read from it.")
  invisible(x)
}

# `field` given as the whole data set (an experiments_at() result with its
# base field): the base field, and its experiments before any others given.
split_field_set <- function(field, experiments, call = rlang::caller_env()) {
  if (!inherits(field, "wv_experiments_at")) return(list(field = field, experiments = experiments))
  exps <- unclass(field)
  attr(exps, "field") <- attr(exps, "base") <- NULL
  if (!is.null(experiments)) {
    check_experiment_list(experiments, call = call)
    dup <- intersect(names(exps), names(experiments))
    if (length(dup)) {
      wv_abort(c("{.arg experiments} repeats experiment{?s} of {.arg field}: {.val {dup}}.",
                 "i" = "{.arg field} holds the whole data set already; give only further experiments."),
               class = "experiment", call = call)
    }
  }
  list(field = attr(field, "field"), experiments = c(exps, experiments))
}

#' @export
print.wv_experiment <- function(x, ...) {
  reps <- vapply(x$field$curves, nrow, integer(1))
  how <- if (!is.null(x$condition)) {
    ch <- if (isTRUE(x$condition_resolved)) x$change_given else x$change
    paste0("at the condition ",
           paste(sprintf("%s = %g", names(x$condition), x$condition), collapse = ", "),
           if (length(ch)) paste0(", inputs changed by ",
                                  paste(sprintf("%s %+g", names(ch), ch), collapse = ", ")))
  } else if (!is.null(x$change)) {
    paste0("the base emulators at the inputs changed by ",
           paste(sprintf("%s %+g", names(x$change), x$change), collapse = ", "))
  } else {
    paste0("its own emulators (", nrow(x$emulators$design), " runs)")
  }
  cli::cat_line(sprintf("<wv_experiment> %d site%s (%s), %s", length(reps),
                        if (length(reps) == 1) "" else "s",
                        paste(sprintf("%s: %d replicate%s", names(reps), reps,
                                      ifelse(reps == 1, "", "s")),
                              collapse = ", "), how))
  invisible(x)
}

# `experiments` a non-empty list with unique names (validate() checks this
# before it registers their field data).
check_experiment_list <- function(experiments, call = rlang::caller_env()) {
  if (!is.list(experiments) || inherits(experiments, "wv_experiment") || !length(experiments) ||
      is.null(names(experiments)) || any(names(experiments) == "") ||
      anyDuplicated(names(experiments))) {
    wv_abort(c("{.arg experiments} must be a named list of {.fn experiment}s.",
               "i" = "For example {.code list(added_mass = experiment(field_m, change = c(x1 = 0.15)))}."),
             class = "experiment", call = call)
  }
  invisible(experiments)
}

# An element `x` (named `e`) of the list `experiments` as a wv_experiment
# (a plain list with `field` and `change` or `emulators` is taken too).
as_experiment <- function(x, e, call = rlang::caller_env()) {
  if (inherits(x, "wv_experiment")) return(x)
  if (!is.list(x) || is.null(x$field)) {
    wv_abort("Experiment {.val {e}} must be made with {.fn experiment}.", class = "experiment",
             call = call)
  }
  experiment(x$field, change = x$change, emulators = x$emulators, reference = x$reference,
             condition = x$condition)
}

# The experiments as a named list of wv_experiment objects, checked against
# the base experiment before any sampling: their emulators' inputs, basis and
# sites, the inputs their change names, and, given the nominal inputs `x_nom`
# (from calibration_spec()), that the change keeps them inside the emulators'
# design. With the I/U map `iu`, an experiment's condition becomes its
# change of the condition inputs (resolve_experiment_condition()).
check_experiments <- function(experiments, emulators, field, x_nom = NULL, iu = NULL,
                              call = rlang::caller_env()) {
  if (is.null(experiments)) return(NULL)
  check_experiment_list(experiments, call = call)
  bad <- grepl("/", names(experiments), fixed = TRUE) | names(experiments) %in% names(field$curves)
  if (any(bad)) {
    wv_abort(c("Experiment names must not contain {.val /} nor repeat a site's name.",
               "x" = "{.val {names(experiments)[bad]}}."), class = "experiment", call = call)
  }
  out <- lapply(names(experiments), function(e) {
    x <- as_experiment(experiments[[e]], e, call = call)
    if (!is.null(iu) || !is.null(x$condition))
      x <- resolve_experiment_condition(x, e, iu, call = call)
    em <- x$emulators %||% emulators
    if (!identical(em$inputs, emulators$inputs)) {
      wv_abort(c("The emulators of experiment {.val {e}} must have the base emulators' inputs.",
                 "x" = "They have {.val {em$inputs}}; the base has {.val {emulators$inputs}}."),
               class = "experiment", call = call)
    }
    if (!identical(em$basis$index, emulators$basis$index) ||
        !identical(em$basis$level, emulators$basis$level) ||
        length(em$basis$t) != length(emulators$basis$t)) {
      wv_abort(c("The emulators of experiment {.val {e}} must be on the base experiment's basis.",
                 "i" = "Fit them with {.code fit_emulators(runs, base_emulators$basis)}."),
               class = "experiment", call = call)
    }
    miss <- setdiff(names(x$field$curves), emulator_sites(em))
    if (length(miss)) {
      wv_abort(c("Experiment {.val {e}} has field data at site{?s} {.val {miss}} without emulators.",
                 "i" = "Emulated sites: {.val {emulator_sites(em)}}."), class = "experiment",
               call = call)
    }
    if (!is.null(x$change)) {
      unknown <- setdiff(names(x$change), emulators$inputs)
      if (length(unknown)) {
        wv_abort(c("The change of experiment {.val {e}} names input{?s} the emulators lack: {.val {unknown}}.",
                   "i" = "Inputs: {.val {emulators$inputs}}."), class = "experiment", call = call)
      }
    }
    if (!is.null(x$change) && !is.null(x_nom)) {
      des <- emulators$design[, names(x$change), drop = FALSE]
      rng <- apply(des, 2L, range)
      reach <- apply(des, 2L, design_gap)
      at <- x_nom[names(x$change)] + x$change
      out_rng <- at < rng[1L, ] - reach | at > rng[2L, ] + reach
      if (any(out_rng)) {
        wv_abort(c("The change of experiment {.val {e}} takes the nominal inputs beyond the emulators' reach.",
                   "x" = "{.val {names(at)[out_rng]}} at {signif(at[out_rng], 4)}; the runs span {signif(rng[1L, out_rng], 4)} to {signif(rng[2L, out_rng], 4)}, and reach {signif(reach[out_rng], 3)} beyond (the widest gap between runs).",
                   "i" = "Add runs there ({.code design_maximin(iu, n, conditions = list({names(at)[out_rng][1]} = ...))} places runs at the tested values), or give the experiment's own emulators: {.code experiment(field, emulators = )}."),
                 class = "experiment", call = call)
      }
    }
    x
  })
  stats::setNames(out, names(experiments))
}

# An experiment whose field data are the base field's own curves (the same
# replicates at a site) would count the same data twice: refused, naming
# the experiments (as experiments_at() of all the data, the base condition
# among them, makes).
check_not_base_data <- function(experiments, field, call = rlang::caller_env()) {
  same <- vapply(names(experiments), function(e) {
    x <- experiments[[e]]
    xf <- if (inherits(x, "wv_field")) x else x$field
    if (!inherits(xf, "wv_field")) return(FALSE)
    any(vapply(intersect(names(xf$curves), names(field$curves)), function(s) {
      a <- xf$curves[[s]]
      b <- field$curves[[s]]
      identical(dim(a), dim(b)) && isTRUE(all.equal(a, b, tolerance = 1e-12)) &&
        isTRUE(all.equal(xf$t, field$t))
    }, logical(1)))
  }, logical(1))
  if (any(same)) {
    wv_abort(c("Experiment{?s} {.val {names(experiments)[same]}} hold{?s/} the base field's own curves: the same data would be counted twice.",
               "i" = "Leave out the experiment at the base condition (e.g. from {.fn experiments_at} of all the data) and give its curves once, as {.arg field}."),
             class = "experiment", call = call)
  }
  invisible(experiments)
}

# How far beyond its runs an input's emulators reach: the widest gap between
# consecutive distinct run values, the largest step the emulators already
# bridge between two runs inside the design.
design_gap <- function(x) {
  x <- sort(unique(x))
  if (length(x) < 2L) return(0)
  max(diff(x))
}
