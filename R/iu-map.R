#' The Input/Uncertainty map
#'
#' Declares the inputs of a computer model: which are calibration parameters
#' (unknown constants of the model, uniform prior on their range) and which
#' are physical inputs subject to manufacturing variation (`x = x_nom + delta`,
#' `delta` normal with standard deviation `prior_sd`, truncated so that `x`
#' stays in its range).
#'
#' @param name Input names; they must match the columns of the design of
#'   [model_runs()].
#' @param type For each input, `"calibration"` or `"variation"`.
#' @param lower,upper Uncertainty range of each input.
#' @param nominal Nominal value of each input (default the centre of its range).
#'   For calibration inputs it is the value used for nominal runs.
#' @param prior_sd Prior standard deviation of the manufacturing variation
#'   (default a sixth of the range); ignored for calibration inputs.
#' @return A `wv_iu` object: a data frame with one row per input and columns
#'   `name`, `type`, `lower`, `upper`, `nominal`, `prior_sd`.
#' @export
#' @examples
#' iu <- iu_map(
#'   name = c("u1", "u2", "x1"),
#'   type = c("calibration", "calibration", "variation"),
#'   lower = c(0.125, 0.125, 0.1667), upper = c(0.875, 0.875, 0.8333)
#' )
#' iu
iu_map <- function(name, type, lower, upper, nominal = (lower + upper) / 2,
                   prior_sd = (upper - lower) / 6) {
  if (!is.character(name) || length(name) == 0L) {
    wv_abort("{.arg name} must be a non-empty character vector of input names.")
  }
  n <- length(name)
  for (arg in c("lower", "upper")) {
    v <- get(arg)
    if (!is.numeric(v)) wv_abort("{.arg {arg}} must be numeric, not {.obj_type_friendly {v}}.")
  }
  for (arg in c("nominal", "prior_sd")) {
    v <- get(arg)
    if (!is.numeric(v) && !(arg == "prior_sd" && all(is.na(v)))) {
      wv_abort("{.arg {arg}} must be numeric, not {.obj_type_friendly {v}}.")
    }
  }
  if (!is.character(type)) {
    wv_abort("{.arg type} must be a character vector of {.val calibration} or {.val variation}.")
  }
  type <- rep_len(type, n)
  lens <- c(type = length(type), lower = length(lower), upper = length(upper),
            nominal = length(nominal), prior_sd = length(prior_sd))
  bad <- lens[lens != n]
  if (length(bad)) {
    wv_abort(c(
      "Every argument must have one value per input ({n} input{?s}).",
      "x" = "{.arg {names(bad)}} {cli::qty(length(bad))}ha{?s/ve} length{?s} {bad}."
    ))
  }
  x <- new_wv_iu(data.frame(
    name = name, type = type,
    lower = as.numeric(lower), upper = as.numeric(upper),
    nominal = as.numeric(nominal), prior_sd = as.numeric(prior_sd),
    stringsAsFactors = FALSE
  ))
  x$prior_sd[x$type == "calibration"] <- NA_real_
  validate_wv_iu(x)
}

#' Add inputs to an I/U map
#'
#' Extends an I/U map by further inputs. The usual one is the strength of a
#' mechanism added to the model: a calibration input whose lower bound
#' switches the mechanism off, so that the model with the mechanism can be
#' run at a design, emulated and validated again (see [compare_validations()]
#' and the re-validated candidates of [explain_bias()]).
#'
#' @inheritParams calibrate
#' @param name Names of the new inputs, none of them already in `iu`.
#' @param type For each new input, `"calibration"` (default) or
#'   `"variation"`.
#' @param lower,upper Uncertainty range of each new input.
#' @inheritParams iu_map
#' @return The `wv_iu` object with the new inputs after those of `iu`.
#' @seealso [iu_map()].
#' @export
#' @examples
#' iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), lower = c(0, 0), upper = c(1, 1))
#' # the strength of a bump stop, 0 for none
#' iu_add(iu, "s_bumpstop", lower = 0, upper = 1, nominal = 0.5)
iu_add <- function(iu, name, type = "calibration", lower, upper, nominal = (lower + upper) / 2,
                   prior_sd = (upper - lower) / 6) {
  check_class(iu, "wv_iu")
  if (!is.character(name) || length(name) == 0L) {
    wv_abort("{.arg name} must be a non-empty character vector of input names.")
  }
  if (missing(lower) || missing(upper)) {
    wv_abort("Give the range of each new input with {.arg lower} and {.arg upper}.")
  }
  old <- intersect(name, iu$name)
  if (length(old)) {
    wv_abort(c("{.val {old}} {?is/are} already in {.arg iu}.",
               "i" = "Give each new input a name of its own."))
  }
  n <- length(name)
  lens <- c(type = length(type), lower = length(lower), upper = length(upper), nominal = length(nominal),
            prior_sd = length(prior_sd))
  bad <- lens[lens != n & !(names(lens) == "type" & lens == 1L)]
  if (length(bad)) {
    wv_abort(c(
      "Every argument must have one value per new input ({n} input{?s}).",
      "x" = "{.arg {names(bad)}} {cli::qty(length(bad))}ha{?s/ve} length{?s} {bad}."
    ))
  }
  iu_map(c(iu$name, name), c(iu$type, rep_len(type, n)), c(iu$lower, lower), c(iu$upper, upper),
         nominal = c(iu$nominal, nominal), prior_sd = c(iu$prior_sd, prior_sd))
}

new_wv_iu <- function(x) {
  structure(x, class = c("wv_iu", "data.frame"))
}

validate_wv_iu <- function(x, call = rlang::caller_env()) {
  if (anyNA(x$name) || any(!nzchar(x$name))) {
    wv_abort("Every input needs a name.", call = call)
  }
  dup <- unique(x$name[duplicated(x$name)])
  if (length(dup)) {
    wv_abort("Input names must be unique; {.val {dup}} appear{?s/} more than once.", call = call)
  }
  badtype <- !x$type %in% c("calibration", "variation")
  if (any(badtype)) {
    wv_abort(c(
      "{.arg type} must be {.val calibration} or {.val variation}.",
      "x" = "{cli::qty(sum(badtype))}Input{?s} {.val {x$name[badtype]}} {?has/have} type {.val {unique(x$type[badtype])}}."
    ), call = call)
  }
  num <- c("lower", "upper", "nominal")
  for (col in num) {
    if (any(!is.finite(x[[col]]))) {
      wv_abort("{.arg {col}} must be finite for every input; see {.val {x$name[!is.finite(x[[col]])]}}.",
               call = call)
    }
  }
  bad <- x$lower >= x$upper
  if (any(bad)) {
    wv_abort(c(
      "{.arg lower} must be smaller than {.arg upper} for every input.",
      "x" = "Not so for {.val {x$name[bad]}}."
    ), call = call)
  }
  out <- x$nominal < x$lower | x$nominal > x$upper
  if (any(out)) {
    wv_abort(c(
      "{.arg nominal} must lie inside [lower, upper].",
      "x" = "{cli::qty(sum(out))}Input{?s} {.val {x$name[out]}} {?has a nominal/have nominals} outside {?its/their} range."
    ), call = call)
  }
  var <- x$type == "variation"
  badsd <- var & (!is.finite(x$prior_sd) | x$prior_sd <= 0)
  if (any(badsd)) {
    wv_abort("{.arg prior_sd} must be positive for inputs with manufacturing variation; see {.val {x$name[badsd]}}.",
             call = call)
  }
  x
}

#' @export
print.wv_iu <- function(x, ...) {
  n_cal <- sum(x$type == "calibration")
  n_var <- sum(x$type == "variation")
  cli::cat_line(sprintf("<wv_iu> %d input%s: %d calibration, %d with manufacturing variation",
                        nrow(x), if (nrow(x) == 1) "" else "s", n_cal, n_var))
  df <- as.data.frame(unclass(x), stringsAsFactors = FALSE)
  df[c("lower", "upper", "nominal", "prior_sd")] <- lapply(df[c("lower", "upper", "nominal", "prior_sd")],
                                                           signif, digits = 4)
  print(df, row.names = FALSE)
  invisible(x)
}

#' @export
summary.wv_iu <- function(object, ...) {
  structure(list(
    n = nrow(object),
    calibration = object$name[object$type == "calibration"],
    variation = object$name[object$type == "variation"],
    width = stats::setNames(object$upper - object$lower, object$name)
  ), class = "summary_wv_iu")
}

#' @export
print.summary_wv_iu <- function(x, ...) {
  cli::cat_line("I/U map of ", x$n, " inputs")
  cli::cat_line("  calibration: ", if (length(x$calibration)) paste(x$calibration, collapse = ", ") else "none")
  cli::cat_line("  variation:   ", if (length(x$variation)) paste(x$variation, collapse = ", ") else "none")
  invisible(x)
}

#' @export
as.data.frame.wv_iu <- function(x, ...) {
  as.data.frame(unclass(x), stringsAsFactors = FALSE)
}

#' Prior density of each input of an I/U map
#'
#' @param object A `wv_iu` object.
#' @param ... Unused.
#' @return A ggplot of the prior density of every input on its range.
#' @export
#' @examples
#' iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), c(0, 0), c(1, 1))
#' autoplot(iu)
autoplot.wv_iu <- function(object, ...) {
  grid <- do.call(rbind, lapply(seq_len(nrow(object)), function(k) {
    v <- seq(object$lower[k], object$upper[k], length.out = 201)
    data.frame(input = object$name[k], value = v, density = iu_prior_density(object, k, v))
  }))
  grid$input <- factor(grid$input, levels = object$name)
  ggplot2::ggplot(grid, ggplot2::aes(.data$value, .data$density)) +
    ggplot2::geom_line() +
    ggplot2::facet_wrap(~input, scales = "free") +
    ggplot2::labs(x = "input value", y = "prior density", title = "Prior of each input") +
    ggplot2::theme_bw()
}

#' @export
plot.wv_iu <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}

# Prior density of input k at values v (in the input's own units).
iu_prior_density <- function(iu, k, v) {
  lo <- iu$lower[k]
  hi <- iu$upper[k]
  inside <- v >= lo & v <= hi
  if (iu$type[k] == "calibration") {
    return(ifelse(inside, 1 / (hi - lo), 0))
  }
  m <- iu$nominal[k]
  s <- iu$prior_sd[k]
  z <- stats::pnorm(hi, m, s) - stats::pnorm(lo, m, s)
  ifelse(inside, stats::dnorm(v, m, s) / z, 0)
}

# Draws from the prior of every input (n x p matrix in the inputs' own units),
# with nominals optionally replaced (a new vehicle under other nominals).
iu_prior_draws <- function(iu, n, nominal = NULL) {
  nom <- iu$nominal
  if (!is.null(nominal)) nom[match(names(nominal), iu$name)] <- nominal
  out <- vapply(seq_len(nrow(iu)), function(k) {
    lo <- iu$lower[k] - iu$nominal[k] + nom[k]
    hi <- iu$upper[k] - iu$nominal[k] + nom[k]
    if (iu$type[k] == "calibration") {
      return(stats::runif(n, iu$lower[k], iu$upper[k]))
    }
    p <- stats::runif(n, stats::pnorm(lo, nom[k], iu$prior_sd[k]), stats::pnorm(hi, nom[k], iu$prior_sd[k]))
    stats::qnorm(p, nom[k], iu$prior_sd[k])
  }, numeric(n))
  if (n == 1L) out <- matrix(out, nrow = 1L)
  colnames(out) <- iu$name
  out
}
