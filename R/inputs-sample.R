#' Draws from the prior of an I/U map
#'
#' Draws every input of an I/U map from its prior: the calibration inputs
#' from theirs (uniform on the range, or normal or log-normal truncated to
#' it, or a joint Gaussian, [iu_prior_joint()]), the manufacturing variations
#' from the normal about their nominal value truncated to their range. With
#' `nominal`, variations are drawn about other nominal values, their ranges
#' shifted with them: a new vehicle of another specification, as
#' `predict(type = "new_nominal")` takes it.
#'
#' The draws come from R's random number generator: seed it (`set.seed()`)
#' for the same draws.
#'
#' @param iu A `wv_iu` object ([iu_map()]).
#' @param n The number of draws.
#' @param nominal `NULL` or named values of manufacturing variation inputs
#'   of `iu`: their nominal values for these draws.
#' @return A matrix of `n` rows and a column per input of `iu`, in its units.
#' @export
#' @examples
#' iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), lower = c(0, 0), upper = c(1, 1))
#' set.seed(1)
#' z <- iu_prior_sample(iu, 1000)
#' summary(z)
#' # a vehicle whose nominal x1 is 0.7
#' summary(iu_prior_sample(iu, 1000, nominal = c(x1 = 0.7)))
iu_prior_sample <- function(iu, n, nominal = NULL) {
  check_class(iu, "wv_iu")
  check_number(n, "n", min = 1, integer = TRUE)
  if (!is.null(nominal)) {
    variation <- iu$name[iu$type == "variation"]
    ok <- is.numeric(nominal) && !is.null(names(nominal)) && all(is.finite(nominal)) &&
      all(names(nominal) %in% variation)
    if (!ok) {
      wv_abort(c("{.arg nominal} must be finite values named by manufacturing variation inputs of {.arg iu}.",
                 "i" = "The variation inputs: {.val {variation}}."))
    }
  }
  iu_prior_draws(iu, as.integer(n), nominal = nominal)
}
