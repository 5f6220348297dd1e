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
    if (!is.numeric(change) || !length(change) || is.null(names(change)) || any(names(change) == "") ||
        anyNA(change) || any(!is.finite(change)) || anyDuplicated(names(change))) {
      wv_abort(c("{.arg change} must be a named numeric vector of finite changes, one per input named.",
                 "x" = "It is {.code {deparse(change)}}."), class = "experiment", call = call)
    }
  }
  if (!is.null(emulators)) check_class(emulators, "wv_emulators", call = call)
  if (!is.null(reference)) check_class(reference, "wv_runs", call = call)
  structure(list(field = field, change = change, emulators = emulators, reference = reference, condition = condition),
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
#' @return A named list of `wv_experiment` objects.
#' @seealso [experiment()], [iu_map()] (section Conditions).
#' @export
#' @examples
#' tb <- load_testbed()
#' experiments_at(list(added_mass = tb$added_mass$field), data.frame(x1 = 0.65))
#' # long data: two doses, two replicates each, on sixteen time points
#' long <- expand.grid(t = 0:15, replicate = 1:2, dose = c(250, 550))
#' long$y <- long$dose / 400 * exp(-long$t / 2) + rnorm(nrow(long), sd = 0.01)
#' experiments_at(long, "dose", t = "t", y = "y", replicate = "replicate")
experiments_at <- function(fields, condition, ...) {
  if (is.data.frame(fields)) {
    cols <- condition
    if (!is.character(cols) || !length(cols) || !all(cols %in% names(fields))) {
      wv_abort(c("With long field data, {.arg condition} must name its condition columns.",
                 "i" = "Its columns: {.val {names(fields)}}."), class = "condition")
    }
    bad <- cols[!vapply(fields[cols], is.numeric, logical(1))]
    if (length(bad)) wv_abort("The condition column{?s} {.val {bad}} must be numeric.", class = "condition")
    key <- do.call(paste, c(lapply(cols, function(p) paste0(p, "=", format(fields[[p]], trim = TRUE))), sep = ","))
    keys <- unique(key)
    long <- fields
    fields <- stats::setNames(lapply(keys, function(k) {
      field_runs(long[key == k, setdiff(names(long), cols), drop = FALSE], ...)
    }), keys)
    condition <- long[match(keys, key), cols, drop = FALSE]
  } else if (...length()) {
    wv_abort("The arguments after {.arg condition} are for long field data only.", class = "condition")
  }
  if (inherits(fields, "wv_field") || !is.list(fields) || !length(fields) || is.null(names(fields)) ||
      any(names(fields) == "") || anyDuplicated(names(fields))) {
    wv_abort(c("{.arg fields} must be a named list of {.cls wv_field}s, one per experiment, or long field data.",
               "i" = "For example {.code list(dose_250 = field_250, dose_550 = field_550)}."), class = "condition")
  }
  if (!is.data.frame(condition) || nrow(condition) != length(fields) || !ncol(condition) ||
      !all(vapply(condition, is.numeric, logical(1)))) {
    wv_abort(c("{.arg condition} must be a data frame of numeric columns, one row per field ({length(fields)}).",
               "x" = if (is.data.frame(condition)) "It has {nrow(condition)} row{?s}." else
                 "It is {.obj_type_friendly {condition}}."), class = "condition")
  }
  out <- lapply(seq_along(fields), function(i) {
    experiment(fields[[i]], condition = unlist(condition[i, , drop = FALSE]))
  })
  stats::setNames(out, names(fields))
}

#' @export
print.wv_experiment <- function(x, ...) {
  reps <- vapply(x$field$curves, nrow, integer(1))
  how <- if (!is.null(x$condition)) {
    ch <- if (isTRUE(x$condition_resolved)) x$change_given else x$change
    paste0("at the condition ", paste(sprintf("%s = %g", names(x$condition), x$condition), collapse = ", "),
           if (length(ch)) paste0(", inputs changed by ", paste(sprintf("%s %+g", names(ch), ch), collapse = ", ")))
  } else if (!is.null(x$change)) {
    paste0("the base emulators at the inputs changed by ",
           paste(sprintf("%s %+g", names(x$change), x$change), collapse = ", "))
  } else {
    paste0("its own emulators (", nrow(x$emulators$design), " runs)")
  }
  cli::cat_line(sprintf("<wv_experiment> %d site%s (%s), %s", length(reps), if (length(reps) == 1) "" else "s",
                        paste(sprintf("%s: %d replicate%s", names(reps), reps, ifelse(reps == 1, "", "s")),
                              collapse = ", "), how))
  invisible(x)
}

# `experiments` a non-empty list with unique names (validate() checks this
# before it registers their field data).
check_experiment_list <- function(experiments, call = rlang::caller_env()) {
  if (!is.list(experiments) || inherits(experiments, "wv_experiment") || !length(experiments) ||
      is.null(names(experiments)) || any(names(experiments) == "") || anyDuplicated(names(experiments))) {
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
    wv_abort("Experiment {.val {e}} must be made with {.fn experiment}.", class = "experiment", call = call)
  }
  experiment(x$field, change = x$change, emulators = x$emulators, reference = x$reference, condition = x$condition)
}

# The experiments as a named list of wv_experiment objects, checked against
# the base experiment before any sampling: their emulators' inputs, basis and
# sites, the inputs their change names, and, given the nominal inputs `x_nom`
# (from calibration_spec()), that the change keeps them inside the emulators'
# design. With the I/U map `iu`, an experiment's condition becomes its
# change of the condition inputs (resolve_experiment_condition()).
check_experiments <- function(experiments, emulators, field, x_nom = NULL, iu = NULL, call = rlang::caller_env()) {
  if (is.null(experiments)) return(NULL)
  check_experiment_list(experiments, call = call)
  bad <- grepl("/", names(experiments), fixed = TRUE) | names(experiments) %in% names(field$curves)
  if (any(bad)) {
    wv_abort(c("Experiment names must not contain {.val /} nor repeat a site's name.",
               "x" = "{.val {names(experiments)[bad]}}."), class = "experiment", call = call)
  }
  out <- lapply(names(experiments), function(e) {
    x <- as_experiment(experiments[[e]], e, call = call)
    if (!is.null(iu) || !is.null(x$condition)) x <- resolve_experiment_condition(x, e, iu, call = call)
    em <- x$emulators %||% emulators
    if (!identical(em$inputs, emulators$inputs)) {
      wv_abort(c("The emulators of experiment {.val {e}} must have the base emulators' inputs.",
                 "x" = "They have {.val {em$inputs}}; the base has {.val {emulators$inputs}}."),
               class = "experiment", call = call)
    }
    if (!identical(em$basis$index, emulators$basis$index) || !identical(em$basis$level, emulators$basis$level) ||
        length(em$basis$t) != length(emulators$basis$t)) {
      wv_abort(c("The emulators of experiment {.val {e}} must be on the base experiment's basis.",
                 "i" = "Fit them with {.code fit_emulators(runs, base_emulators$basis)}."),
               class = "experiment", call = call)
    }
    miss <- setdiff(names(x$field$curves), names(em$banks))
    if (length(miss)) {
      wv_abort(c("Experiment {.val {e}} has field data at site{?s} {.val {miss}} without emulators.",
                 "i" = "Emulated sites: {.val {names(em$banks)}}."), class = "experiment", call = call)
    }
    if (!is.null(x$change)) {
      unknown <- setdiff(names(x$change), emulators$inputs)
      if (length(unknown)) {
        wv_abort(c("The change of experiment {.val {e}} names input{?s} the emulators lack: {.val {unknown}}.",
                   "i" = "Inputs: {.val {emulators$inputs}}."), class = "experiment", call = call)
      }
    }
    if (!is.null(x$change) && !is.null(x_nom)) {
      rng <- apply(emulators$design[, names(x$change), drop = FALSE], 2L, range)
      at <- x_nom[names(x$change)] + x$change
      out_rng <- at < rng[1L, ] | at > rng[2L, ]
      if (any(out_rng)) {
        wv_abort(c("The change of experiment {.val {e}} takes the nominal inputs outside the emulators' design.",
                   "x" = "{.val {names(at)[out_rng]}} at {signif(at[out_rng], 4)}; the runs span {signif(rng[1L, out_rng], 4)} to {signif(rng[2L, out_rng], 4)}.",
                   "i" = "Run the model for this experiment and give its emulators: {.code experiment(field, emulators = )}."),
                 class = "experiment", call = call)
      }
    }
    x
  })
  stats::setNames(out, names(experiments))
}

# --- registration of the experiments' field data -------------------------------

# The model runs whose mean the field data of experiment `x` are registered
# to: its own `reference` when given, else the model in its condition as the
# emulators predict it. With `change`: every run of `runs` (the base
# experiment's, to which `emulators` were fitted) with its retained wavelet
# coefficients replaced by the emulators' means at its inputs plus the change
# (with a condition: its condition inputs set to the experiment's values),
# so that the mean of these runs stands to the experiment as the mean of
# `runs` stands to the base experiment. With a condition, the part the basis
# leaves out is the mean of the runs nearest the condition
# (condition_neighbours()). Every run is kept, those the change
# moves outside the range of the design too (the emulators extrapolate
# there): on the suspension test bed, leaving them out or moving them to the
# edge of the range took the reference farther from the true runs with the
# change. The part of a run the basis does not retain (fine detail the
# change hardly alters, to which the warp knots between the events are
# fitted) is kept from the run itself. With `emulators` of its own: their
# means at their own design, plus the base runs' mean part outside the basis
# at the sites of `runs`.
experiment_reference <- function(x, emulators, runs) {
  if (!is.null(x$reference)) return(x$reference)
  sites <- names(x$field$curves)
  if (!is.null(x$change)) {
    design <- runs$design
    for (p in names(x$change)) design[[p]] <- design[[p]] + x$change[[p]]
    # a condition is known: every run at the experiment's value
    for (p in intersect(names(x$condition), names(design))) design[[p]] <- x$condition[[p]]
    near <- condition_neighbours(runs$design, x$condition)
    curves <- lapply(sites, function(s) {
      rest <- basis_remainder(emulators$basis, runs$curves[[s]])
      if (!is.null(near)) rest <- matrix(colMeans(rest[near, , drop = FALSE]), nrow(rest), ncol(rest), byrow = TRUE)
      basis_curves(emulators$basis, stats::predict(emulators, design, site = s)$mean) + rest
    })
  } else {
    em <- x$emulators
    design <- as.data.frame(em$design)
    curves <- lapply(sites, function(s) {
      y <- basis_curves(em$basis, stats::predict(em, em$design, site = s)$mean)
      if (s %in% names(runs$curves)) y <- sweep(y, 2L, colMeans(basis_remainder(em$basis, runs$curves[[s]])), `+`)
      y
    })
  }
  validate_wv_runs(new_wv_runs(design, runs$t, stats::setNames(curves, sites)))
}

# The experiments (checked by check_experiments()) with their field data
# registered like the base experiment's (the arguments of register_curves()
# in `...`), each to experiment_reference(); says once which reference each
# one was registered to.
register_experiments <- function(experiments, emulators, runs, windows, ..., quiet = FALSE) {
  how <- character(0)
  for (e in names(experiments)) {
    x <- experiments[[e]]
    ref <- experiment_reference(x, emulators, runs)
    x$field <- register_curves(x$field, ref, windows, ...)
    experiments[[e]] <- x
    how[[e]] <- if (!is.null(x$reference)) {
      sprintf("its reference (%d run%s)", nrow(ref$design), if (nrow(ref$design) == 1L) "" else "s")
    } else if (!is.null(x$condition)) {
      paste0("the emulators at the runs' inputs at the condition ",
             paste(sprintf("%s = %g", names(x$condition), x$condition), collapse = ", "))
    } else if (!is.null(x$change)) {
      n_out <- sum(outside_design(ref$design, runs$design, names(x$change)))
      paste0("the emulators at the runs' inputs changed by ",
             paste(sprintf("%s %+g", names(x$change), x$change), collapse = ", "),
             if (n_out) sprintf(" (%d of %d runs moved outside their range, extrapolated)", n_out,
                                nrow(ref$design)))
    } else {
      sprintf("its emulators at their %d runs' inputs", nrow(ref$design))
    }
  }
  if (!quiet) {
    names_e <- names(how)
    bullets <- sprintf("{.val {names_e[%d]}}: {how[%d]}", seq_along(how), seq_along(how))
    wv_inform(c("i" = "The field data of the experiments were registered to the model in their own condition:",
                stats::setNames(bullets, rep("*", length(bullets)))))
  }
  experiments
}

# The runs nearest an experiment's condition (NULL without one): the
# max(5, 10%) of them closest to `condition` in the condition inputs, each
# scaled by its range in the design. A condition can change the fine detail
# the basis leaves out (a dose scales the kink where it is given), so an
# experiment's reference takes that detail from these runs, not from all.
condition_neighbours <- function(design, condition) {
  cond <- intersect(names(condition), names(design))
  if (!length(cond)) return(NULL)
  d2 <- 0
  for (p in cond) {
    w <- diff(range(design[[p]]))
    d2 <- d2 + ((design[[p]] - condition[[p]]) / if (w > 0) w else 1)^2
  }
  k <- min(nrow(design), max(5L, ceiling(nrow(design) / 10)))
  order(d2)[seq_len(k)]
}

# Which rows of `design` lie outside the range of `runs_design` in the
# columns `inputs`.
outside_design <- function(design, runs_design, inputs) {
  out <- rep(FALSE, nrow(design))
  for (p in inputs) {
    r <- range(runs_design[[p]])
    out <- out | design[[p]] < r[1] | design[[p]] > r[2]
  }
  out
}

# Adds the experiments' sites to the base experiment's sampler spec. Site `s`
# of experiment `e` becomes site "e/s"; its coefficients' bias variances are
# the base site's groups (level_variances "shared", needs the base experiment
# to hold the site) or its own ("per_experiment").
add_experiments <- function(spec, experiments, emulators, iu, pool_levels, registration_variance,
                            level_variances, experiment_bias = "own", call = rlang::caller_env()) {
  base_sites <- names(spec$sites)
  p <- length(spec$inputs)
  site_experiment <- stats::setNames(rep("base", length(base_sites)), base_sites)
  base_site <- stats::setNames(base_sites, base_sites)
  shift <- list()
  banks <- list()
  # the registration's own error: measured on each experiment's field when
  # it carries a check, else the base experiment's at the same site (the
  # same registration of the same kind of curve)
  measured <- isTRUE(registration_variance %in% c("auto", "check"))
  if (measured && !is.null(spec$reg_shift_var) && experiment_bias == "shared") {
    # the sampler's shifts need each site's own bias: one variance per site
    for (s in base_sites) {
      spec$sites[[s]]$reg_U <- NULL
      spec$sites[[s]]$extra <- spec$extra_diag[[s]]
    }
    spec$extra <- spec$extra_diag
    spec$reg_shift_var <- NULL
  }
  for (e in names(experiments)) {
    x <- experiments[[e]]
    em <- x$emulators %||% emulators
    sub <- calibration_spec(em, x$field, iu, NULL, pool_levels = pool_levels,
                            registration_variance = if (measured) "diagonal" else registration_variance, call = call)
    if (measured && is.null(sub$extra) && !is.null(spec$extra)) {
      sub$extra <- (spec$extra_diag %||% spec$extra)[names(sub$sites)]
    }
    sh <- stats::setNames(numeric(p), spec$inputs)
    if (!is.null(x$change)) sh[names(x$change)] <- x$change
    for (s in names(sub$sites)) {
      name <- paste0(e, "/", s)
      d <- sub$sites[[s]]
      d$extra <- sub$extra[[s]]
      lab <- sub$bias_group[[s]]
      if (level_variances == "shared") {
        if (!s %in% base_sites) {
          wv_abort(c("With {.code level_variances = \"shared\"} every experiment's site must be a site of the base experiment.",
                     "x" = "Experiment {.val {e}} has site {.val {s}}; the base has {.val {base_sites}}.",
                     "i" = "Use {.code level_variances = \"per_experiment\"}."), class = "experiment", call = call)
        }
        d$group <- match(lab, spec$groups$name) - 1L
      } else {
        own <- sub$groups[sub$groups$site == s, , drop = FALSE]
        own$name <- paste0(e, "/", own$name)
        own$site <- name
        spec$groups <- rbind(spec$groups, own)
        lab <- paste0(e, "/", lab)
        d$group <- match(lab, spec$groups$name) - 1L
      }
      if (any(sh != 0)) d$shift <- unname(sh)
      if (experiment_bias == "shared") d$bias_of <- match(s, base_sites) - 1L
      spec$sites[[name]] <- d
      spec$bias_group[[name]] <- lab
      spec$wbar[[name]] <- sub$wbar[[s]]
      spec$s2[[name]] <- sub$s2[[s]]
      spec$n_rep[[name]] <- sub$n_rep[[s]]
      if (!is.null(sub$extra)) spec$extra[[name]] <- sub$extra[[s]]
      spec$noise_setting[[name]] <- sub$noise_setting[[s]]
      if (!is.null(sub$noise_evidence[[s]])) spec$noise_evidence[[name]] <- sub$noise_evidence[[s]]
      if (!is.null(sub$noise_prior) && !is.null(sub$noise_prior$scale[s]) && !is.na(sub$noise_prior$scale[s])) {
        if (is.null(spec$noise_prior)) {
          spec$noise_prior <- sub$noise_prior
          spec$noise_prior$scale <- numeric(0)
        }
        spec$noise_prior$scale <- c(spec$noise_prior$scale, stats::setNames(unname(sub$noise_prior$scale[s]), name))
      }
      site_experiment[[name]] <- e
      base_site[[name]] <- s
      shift[[name]] <- sh
      banks[[name]] <- em$banks[[s]]
    }
  }
  spec$experiments <- data.frame(site = names(site_experiment), experiment = unname(site_experiment),
                                 field_site = unname(base_site), stringsAsFactors = FALSE)
  spec$shift <- shift
  spec$experiment_banks <- banks
  spec
}

# The fit's emulators with a bank for every experiment's site, and its field
# with every site's curves.
experiment_fit_parts <- function(spec, emulators, field, experiments) {
  if (is.null(spec$experiments)) return(list(emulators = emulators, field = field))
  for (s in names(spec$experiment_banks)) {
    emulators$banks[[s]] <- spec$experiment_banks[[s]]
    e <- spec$experiments$experiment[spec$experiments$site == s]
    fs <- spec$experiments$field_site[spec$experiments$site == s]
    em <- experiments[[e]]$emulators %||% emulators
    rows <- em$params[em$params$site == fs, , drop = FALSE]
    rows$site <- s
    emulators$params <- rbind(emulators$params, rows[, names(emulators$params), drop = FALSE])
    field$curves[[s]] <- experiments[[e]]$field$curves[[fs]]
  }
  list(emulators = emulators, field = field)
}

# The change of the inputs at which site s's emulators are evaluated (zeros
# for the base experiment's sites), named by input.
site_shift <- function(fit, s) {
  sh <- fit$shift[[s]]
  if (is.null(sh)) sh <- stats::setNames(numeric(length(fit$inputs)), fit$inputs)
  sh
}

# The inputs Z (rows, own units) moved to site s's experiment.
shift_inputs <- function(fit, s, Z) {
  sh <- fit$shift[[s]]
  if (is.null(sh) || all(sh == 0)) return(Z)
  sweep(Z, 2L, sh[colnames(Z) %||% fit$inputs], `+`)
}

# The experiment of each site of a fit ("base" for all with one experiment).
fit_experiments <- function(fit) {
  sites <- names(fit$wb)
  fit$experiments %||% data.frame(site = sites, experiment = "base", field_site = sites, stringsAsFactors = FALSE)
}

# Share of draws whose inputs, moved by an experiment's change, leave the
# range of the emulators' runs: a classed warning when above 1%.
warn_experiment_extrapolation <- function(fit) {
  if (is.null(fit$shift)) return(invisible())
  X <- as.matrix(fit$draws)[, fit$inputs, drop = FALSE]
  for (s in names(fit$shift)) {
    sh <- fit$shift[[s]]
    if (all(sh == 0)) next
    moved <- names(sh)[sh != 0]
    rng <- apply(fit$emulators$design[, moved, drop = FALSE], 2L, range)
    Z <- sweep(X[, moved, drop = FALSE], 2L, sh[moved], `+`)
    out <- rowSums(sweep(Z, 2L, rng[1L, ] - 1e-12, `<`) | sweep(Z, 2L, rng[2L, ] + 1e-12, `>`)) > 0
    if (mean(out) > 0.01) {
      wv_warn(c("At site {.val {s}}, {round(100 * mean(out))}% of the draws' changed inputs leave the range of the model runs.",
                "i" = "The emulators extrapolate there; give the experiment its own runs ({.code experiment(field, emulators = )})."),
              class = "extrapolation")
    }
  }
  invisible()
}

# The sites of the base experiment (every site with one experiment).
base_sites <- function(fit) {
  ex <- fit_experiments(fit)
  ex$site[ex$experiment == "base"]
}
