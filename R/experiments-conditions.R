# Test conditions: inputs of type "condition" in the I/U map, known for
# every experiment. The sampler holds each at the base experiment's value;
# an experiment at another value is the base experiment's emulators at the
# inputs changed by the difference.

# The condition inputs of an I/U map.
iu_conditions <- function(iu) {
  if (is.null(iu) || is.null(iu$type)) return(character())
  iu$name[iu$type == "condition"]
}

# The base experiment's value of each condition input, named.
condition_base <- function(iu) {
  cond <- iu_conditions(iu)
  stats::setNames(iu$nominal[match(cond, iu$name)], cond)
}

# The I/U map the sampler sees: every condition held at its base value, a
# calibration input on a point-like range (as hold_inputs() holds an input).
conditions_held_iu <- function(iu) {
  cond <- iu_conditions(iu)
  if (!length(cond)) return(iu)
  hold_at(iu, condition_base(iu))
}

# `condition` of experiment(): NULL or a named numeric vector of finite values.
check_condition_values <- function(condition, arg = "condition", call = rlang::caller_env()) {
  if (is.null(condition)) return(invisible(NULL))
  if (!is.numeric(condition) || !length(condition) || is.null(names(condition)) ||
      any(names(condition) == "") ||
      anyNA(condition) || any(!is.finite(condition)) || anyDuplicated(names(condition))) {
    wv_abort(c("{.arg {arg}} must be a named numeric vector of finite values, one per condition input.",
               "x" = "It is {.code {deparse(condition)}}.",
               "i" = "For example {.code c(dose = 250)}."), class = "condition", call = call)
  }
  invisible(condition)
}

# The values `values` of the conditions of `iu` checked: every condition
# given, none other, each inside its design range. `what` names whose values
# they are in the messages.
check_condition_against_iu <- function(values, iu, what, call = rlang::caller_env()) {
  cond <- iu_conditions(iu)
  other <- setdiff(names(values), cond)
  if (length(other)) {
    wv_abort(c("The condition of {what} names {cli::qty(length(other))}input{?s} that {?is not a condition/are not conditions} of the I/U map: {.val {other}}.",
               "i" = if (length(cond)) "Its conditions: {.val {cond}}." else "The I/U map has no condition input.",
               "i" = "Declare a condition with {.code iu_map(type = \"condition\")} or {.fn iu_add}, or give a known change of another input with {.arg change}."),
             class = "condition", call = call)
  }
  miss <- setdiff(cond, names(values))
  if (length(miss)) {
    wv_abort(c("The condition of {what} lacks the value of {.val {miss}}.",
               "i" = "Give every condition input of the I/U map, e.g. {.code condition = c({miss[1]} = {signif(condition_base(iu)[[miss[1]]], 4)})}."),
             class = "condition", call = call)
  }
  k <- match(cond, iu$name)
  v <- values[cond]
  out <- v < iu$lower[k] | v > iu$upper[k]
  if (any(out)) {
    wv_abort(c("The condition of {what} lies outside the design range of the model runs.",
               "x" = "{.val {cond[out]}} = {signif(v[out], 4)}; the range is [{signif(iu$lower[k][out], 4)}, {signif(iu$upper[k][out], 4)}].",
               "i" = "Run the model over a range that holds it, and widen the range of the condition in the I/U map."),
             class = "condition", call = call)
  }
  v
}

# Experiment `x` (named `e`) with its condition turned into the change of
# the condition inputs from their base values, added to the change it gives
# of other inputs. Idempotent: the change the user gave is kept in
# `change_given`. An I/U map with conditions needs every experiment's
# condition; an experiment with a condition needs one.
resolve_experiment_condition <- function(x, e, iu, call = rlang::caller_env()) {
  cond <- iu_conditions(iu)
  if (!length(cond) && is.null(x$condition)) return(x)
  what <- sprintf("experiment \"%s\"", e)
  if (!is.null(x$emulators)) {
    wv_abort(c("Experiment {.val {e}} has its own emulators; an I/U map with conditions needs every experiment made with {.arg condition}.",
               "i" = "Run the model over the conditions in one design and give each experiment its value: {.code experiment(field, condition = )}."),
             class = "condition", call = call)
  }
  if (is.null(x$condition)) {
    wv_abort(c("Experiment {.val {e}} has no condition, and the I/U map has condition input{?s} {.val {cond}}.",
               "i" = "Give its value{?s}: {.code experiment(field, condition = c({cond[1]} = ))}."),
             class = "condition", call = call)
  }
  given <- if (isTRUE(x$condition_resolved)) x$change_given else x$change
  sets <- intersect(names(given), cond)
  if (length(sets)) {
    wv_abort(c("The change of experiment {.val {e}} sets condition input{?s} {.val {sets}}.",
               "i" = "Give a condition's value with {.arg condition}, not as a change."),
             class = "condition", call = call)
  }
  v <- check_condition_against_iu(x$condition, iu, what, call = call)
  x$change_given <- given
  x$change <- c(given, v - condition_base(iu))
  x$condition_resolved <- TRUE
  x
}

# The conditions of a fit: the condition inputs, their base values and a
# table of every experiment's values ("base" first); NULL without
# conditions.
fit_condition_table <- function(iu, experiments) {
  cond <- iu_conditions(iu)
  if (!length(cond)) return(NULL)
  base <- condition_base(iu)
  rows <- c(list(base = base), lapply(experiments, function(x) x$condition[cond]))
  values <- as.data.frame(do.call(rbind, rows), stringsAsFactors = FALSE)
  values <- cbind(data.frame(experiment = names(rows), stringsAsFactors = FALSE), values)
  rownames(values) <- NULL
  list(inputs = cond, base = base, values = values)
}

# "dose = 250, temp = 300" for each row of the conditions table.
condition_labels <- function(conditions) {
  v <- conditions$values
  out <- vapply(seq_len(nrow(v)), function(r) {
    paste(sprintf("%s = %s", conditions$inputs,
                  format(signif(unlist(v[r, conditions$inputs]), 4), trim = TRUE)),
          collapse = ", ")
  }, character(1))
  stats::setNames(out, v$experiment)
}

# --- prediction at a new condition ---------------------------------------------

