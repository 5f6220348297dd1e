# iu_hold(): inputs of an I/U map held at given values.

#' Hold inputs of an I/U map at given values
#'
#' Takes inputs out of the calibration by fixing them: each input named in
#' `values` becomes a calibration input with a uniform prior on a point-like
#' range about its value (a relative width of 1e-7 of its range), its
#' nominal the value. [calibrate()] and [validate()] given the returned map
#' sample the other inputs with these held, as [hold_inputs()] does for
#' each of its strata; the emulators still take the held inputs as inputs,
#' so the model runs need not change.
#'
#' Read the result as any I/U map: the held inputs print as `calibration`
#' inputs with `uniform` priors on ranges that are their value, and their
#' posterior draws are that value. An input under a joint prior
#' ([iu_prior_joint()]) cannot be held alone; a `"condition"` input is held
#' already, at each experiment's value.
#'
#' @param iu A `wv_iu` object ([iu_map()]).
#' @param values A named numeric vector: the value of each input to hold, in
#'   its own units, inside its range `[lower, upper]`.
#' @return The `wv_iu` object with the inputs of `values` held; the other
#'   inputs as they were.
#' @seealso [hold_inputs()] to calibrate a fit again with inputs held at
#'   strata of their prior.
#' @export
#' @examples
#' ex <- example_problem()
#' held <- iu_hold(ex$iu, c(x1 = 0.5))
#' held
#' fit <- calibrate(ex$emulators, ex$field, held, chains = 1, seed = 1,
#'                  sampler = sampler_control(n_draws = 50, n_inner = 10, quiet = TRUE))
#' # x1 stays at 0.5; u1 is calibrated with it held
#' range(as.matrix(fit$draws)[, "x1"])
iu_hold <- function(iu, values) {
  check_class(iu, "wv_iu")
  if (!is.numeric(values) || !length(values) || is.null(names(values)) ||
      any(!nzchar(names(values))) ||
      anyNA(names(values)) || anyDuplicated(names(values)) || any(!is.finite(values))) {
    wv_abort(c("{.arg values} must be a named numeric vector of finite values, one per input to hold.",
               "i" = "For example {.code c(x1 = 0.5)}."))
  }
  unknown <- setdiff(names(values), iu$name)
  if (length(unknown)) {
    wv_abort(c("{.val {unknown}} {?is/are} not {?an input/inputs} of {.arg iu}.",
               "i" = "Its inputs are {.val {iu$name}}."))
  }
  k <- match(names(values), iu$name)
  cond <- names(values)[iu$type[k] == "condition"]
  if (length(cond)) {
    wv_abort(c("{.val {cond}} {?is a condition/are conditions}, held at each experiment's value already.",
               "i" = "Set the base experiment's value with {.arg nominal} of {.fn iu_map}."))
  }
  joint <- intersect(names(values), unlist(lapply(attr(iu, "joint"), `[[`, "names")))
  if (length(joint)) {
    wv_abort("{.val {joint}} {?has/have} a joint prior with other inputs and cannot be held alone.")
  }
  out <- values < iu$lower[k] | values > iu$upper[k]
  if (any(out)) {
    where <- paste0(names(values)[out], " = ", values[out], " outside [", iu$lower[k][out], ", ",
                    iu$upper[k][out], "]")
    wv_abort(c("Every value must lie in its input's range.", "x" = "{where}."))
  }
  hold_at(iu, values)
}

# The I/U map `iu` with the inputs `values` (named, in their own units)
# held: each a calibration input with a uniform prior on a point-like range
# at its value (iu_hold() once checked, hold_inputs(), and the conditions
# of calibrate()).
hold_at <- function(iu, values) {
  for (nm in names(values)) {
    k <- match(nm, iu$name)
    v <- values[[nm]]
    eps <- 1e-7 * max(iu$upper[k] - iu$lower[k], abs(v), 1e-8)
    iu$type[k] <- "calibration"
    iu$lower[k] <- v - eps
    iu$upper[k] <- v + eps
    iu$nominal[k] <- v
    if ("prior" %in% names(iu)) iu$prior[k] <- "uniform"
    if ("prior_sd" %in% names(iu)) iu$prior_sd[k] <- NA_real_
    if ("prior_mean" %in% names(iu)) iu$prior_mean[k] <- NA_real_
  }
  iu
}
