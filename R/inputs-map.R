#' The Input/Uncertainty map
#'
#' Declares the inputs of a computer model: which are calibration parameters
#' (unknown constants of the model), which are physical inputs subject to
#' manufacturing variation (`x = x_nom + delta`, `delta` normal with standard
#' deviation `prior_sd`, truncated so that `x` stays in its range), and which
#' are test conditions.
#'
#' @section Conditions:
#' A `"condition"` input is a known setting of a test (a temperature, a
#' load, a dose): it has no prior and is never sampled. `lower` and `upper`
#' give the range the model runs' design spans (the emulators take the
#' condition as an input like any other), `nominal` its value in the base
#' experiment (the `field` of [calibrate()] or [validate()]). Every further
#' experiment gives its own value, `experiment(field, condition = c(dose =
#' 250))`, which stands for the change `condition - nominal` of the input;
#' the calibration holds the input at the base experiment's value, as
#' [hold_inputs()] holds an input. A new condition is predicted with
#' `predict(fit, type = "new_condition", condition = )`.
#'
#' @section Priors of calibration inputs:
#' Every prior is truncated to `[lower, upper]`:
#' * `"uniform"` (default): uniform on `[lower, upper]`.
#' * `"normal"`: `x ~ N(prior_mean, prior_sd^2)`; `prior_mean` defaults to the
#'   nominal, `prior_sd` to a sixth of the range.
#' * `"lognormal"`: `log(x) ~ N(log(prior_mean), prior_sd^2)`: `prior_mean` is
#'   the median of the untruncated log-normal, in the input's own units
#'   (default the nominal), and `prior_sd` the standard deviation of `log(x)`
#'   (default a sixth of `log(upper) - log(lower)`). Its density on `x` is
#'   `dnorm(log(x), log(prior_mean), prior_sd) / x` (that is `dlnorm()`), and
#'   `lower` must be positive.
#'
#' A Gaussian with a full covariance over several calibration inputs is set
#' afterwards with [iu_prior_joint()]. Inputs with manufacturing variation
#' always have the normal prior about their nominal.
#'
#' @param name Input names; they must match the columns of the design of
#'   [model_runs()].
#' @param type For each input, `"calibration"`, `"variation"` or
#'   `"condition"` (see the section Conditions).
#' @param lower,upper Uncertainty range of each input (of a condition: the
#'   range of the model runs' design).
#' @param nominal Nominal value of each input (default the centre of its range).
#'   For calibration inputs it is the value used for nominal runs; for a
#'   condition, its value in the base experiment.
#' @param prior_sd Prior standard deviation: of the manufacturing variation
#'   (default a sixth of the range), of a `"normal"` calibration input (default
#'   a sixth of the range), or of `log(x)` for a `"lognormal"` one (default a
#'   sixth of the range of `log(x)`). `NULL` or `NA` entries take the default;
#'   unused for `"uniform"` inputs.
#' @param prior Prior of each calibration input: `"uniform"`, `"normal"` or
#'   `"lognormal"` (see the section Priors of calibration inputs). One value
#'   applies to every calibration input; with one value per input, those of
#'   inputs with manufacturing variation must be `"normal"`. `NULL`: uniform.
#'   Conditions have none: their `prior` is `"none"`, whatever is given.
#' @param prior_mean Mean of a `"normal"` prior, median of a `"lognormal"` one
#'   (in the input's own units); `NULL` or `NA` entries take the nominal.
#'   Unused for the other inputs.
#' @return A `wv_iu` object: a data frame with one row per input and columns
#'   `name`, `type`, `lower`, `upper`, `nominal`, `prior_sd`, `prior` and
#'   `prior_mean` (`NA` where unused; `prior` is `"joint"` for inputs under a
#'   joint Gaussian of [iu_prior_joint()], whose blocks are kept in the
#'   attribute `"joint"`).
#' @seealso [iu_prior_joint()], [iu_add()].
#' @export
#' @examples
#' iu <- iu_map(
#'   name = c("u1", "u2", "x1"),
#'   type = c("calibration", "calibration", "variation"),
#'   lower = c(0.125, 0.125, 0.1667), upper = c(0.875, 0.875, 0.8333)
#' )
#' iu
#' # a normal prior on u1 and a log-normal one (median 0.3, sd of log 0.4) on u2
#' iu_map(c("u1", "u2"), "calibration", lower = c(0, 0.01), upper = c(1, 1),
#'        prior = c("normal", "lognormal"), prior_mean = c(0.6, 0.3), prior_sd = c(0.1, 0.4))
#' # a test condition: the dose, run from 200 to 600 mg, 400 mg in the base experiment
#' iu_map(c("u1", "dose"), c("calibration", "condition"), lower = c(0, 200), upper = c(1, 600),
#'        nominal = c(0.5, 400))
iu_map <- function(name, type, lower, upper, nominal = (lower + upper) / 2,
                   prior_sd = NULL, prior = NULL, prior_mean = NULL) {
  if (!is.character(name) || length(name) == 0L) {
    wv_abort("{.arg name} must be a non-empty character vector of input names.")
  }
  n <- length(name)
  for (arg in c("lower", "upper")) {
    v <- get(arg)
    if (!is.numeric(v)) wv_abort("{.arg {arg}} must be numeric, not {.obj_type_friendly {v}}.")
  }
  if (is.null(prior_sd)) prior_sd <- rep(NA_real_, n)
  if (is.null(prior_mean)) prior_mean <- rep(NA_real_, n)
  for (arg in c("nominal", "prior_sd", "prior_mean")) {
    v <- get(arg)
    if (!is.numeric(v) && !(arg != "nominal" && all(is.na(v)))) {
      wv_abort("{.arg {arg}} must be numeric, not {.obj_type_friendly {v}}.")
    }
  }
  if (!is.character(type)) {
    wv_abort("{.arg type} must be a character vector of {.val calibration}, {.val variation} or {.val condition}.")
  }
  type <- rep_len(type, n)
  if (is.null(prior)) prior <- "uniform"
  if (!is.character(prior) || anyNA(prior)) {
    wv_abort("{.arg prior} must be a character vector of {.val uniform}, {.val normal} or {.val lognormal}.")
  }
  if (length(prior) == 1L) prior <- rep(prior, n)
  lens <- c(type = length(type), lower = length(lower), upper = length(upper),
            nominal = length(nominal), prior_sd = length(prior_sd), prior = length(prior),
            prior_mean = length(prior_mean))
  bad <- lens[lens != n & !(names(lens) %in% c("prior_sd", "prior_mean") & lens == 1L)]
  if (length(bad)) {
    wv_abort(c(
      "Every argument must have one value per input ({n} input{?s}).",
      "x" = "{.arg {names(bad)}} {cli::qty(length(bad))}ha{?s/ve} length{?s} {bad}."
    ))
  }
  var <- type == "variation"
  cond <- type == "condition"
  prior[cond] <- "none"
  if (n > 1L && !all(prior[!cond] == prior[!cond][1]) && any(prior[var] != "normal")) {
    wv_abort(c(
      "Inputs with manufacturing variation have a normal prior about their nominal.",
      "x" = "{.arg prior} gives {.val {unique(prior[var & prior != 'normal'])}} for {.val {name[var & prior != 'normal']}}."
    ))
  }
  prior[var] <- "normal"
  x <- new_wv_iu(data.frame(
    name = name, type = type,
    lower = as.numeric(lower), upper = as.numeric(upper),
    nominal = as.numeric(nominal), prior_sd = rep_len(as.numeric(prior_sd), n),
    prior = prior, prior_mean = rep_len(as.numeric(prior_mean), n),
    stringsAsFactors = FALSE
  ))
  fill_prior_defaults(x)
}

# The defaults of prior_sd and prior_mean where NA, and NA where unused.
fill_prior_defaults <- function(x, call = rlang::caller_env()) {
  norm <- x$prior == "normal"
  logn <- x$prior == "lognormal"
  if (any(logn & x$lower <= 0)) {
    wv_abort(c(
      "A {.val lognormal} prior needs a positive {.arg lower} bound.",
      "x" = "Not so for {.val {x$name[logn & x$lower <= 0]}}."
    ), call = call)
  }
  x$prior_sd[norm & is.na(x$prior_sd)] <- ((x$upper - x$lower) / 6)[norm & is.na(x$prior_sd)]
  k <- which(logn & is.na(x$prior_sd))
  x$prior_sd[k] <- (log(x$upper[k]) - log(x$lower[k])) / 6
  x$prior_mean[x$type == "variation"] <- x$nominal[x$type == "variation"]
  use <- (norm | logn) & is.na(x$prior_mean)
  x$prior_mean[use] <- x$nominal[use]
  x$prior_sd[!(norm | logn)] <- NA_real_
  x$prior_mean[!(norm | logn)] <- NA_real_
  validate_wv_iu(x, call = call)
}

#' Add inputs to an I/U map
#'
#' Extends an I/U map by further inputs. The usual one is the strength of a
#' mechanism added to the model: a calibration input whose lower bound
#' switches the mechanism off, so that the model with the mechanism can be
#' run at a design, emulated and validated again (see [compare_validations()]
#' and the re-validated candidates of [explain_bias()]). A mechanism may add
#' several inputs (a strength and a rate): `off` gives each its no-effect
#' value.
#'
#' @inheritParams calibrate
#' @param name Names of the new inputs, none of them already in `iu`.
#' @param type For each new input, `"calibration"` (default),
#'   `"variation"` or `"condition"` (a known setting of each experiment; see
#'   [iu_map()], section Conditions).
#' @param lower,upper Uncertainty range of each new input.
#' @inheritParams iu_map
#' @param off `NULL` or, for each new input, the value at which it switches
#'   the mechanism off (its no-effect value, inside its range), or `NA` for an
#'   input that acts only while others are on (a rate or time constant of the
#'   mechanism). Kept as the attribute `off` of the map.
#' @return The `wv_iu` object with the new inputs after those of `iu`.
#' @seealso [iu_map()].
#' @export
#' @examples
#' iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), lower = c(0, 0), upper = c(1, 1))
#' # the strength of a bump stop, 0 for none
#' iu_add(iu, "s_bumpstop", lower = 0, upper = 1, nominal = 0.5)
#' # an exchange (off at 0) and its return rate
#' attr(iu_add(iu, c("s_ex", "k_ret"), lower = c(0, 1), upper = c(1, 5), off = c(0, NA)), "off")
iu_add <- function(iu, name, type = "calibration", lower, upper, nominal = (lower + upper) / 2,
                   prior_sd = NULL, prior = NULL, prior_mean = NULL, off = NULL) {
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
  lens <- c(type = length(type), lower = length(lower), upper = length(upper),
            nominal = length(nominal),
            prior_sd = length(prior_sd %||% NA), prior = length(prior %||% NA),
            prior_mean = length(prior_mean %||% NA), off = length(off %||% NA))
  bad <-
    lens[lens != n & !(names(lens) %in% c("type", "prior_sd", "prior", "prior_mean") & lens == 1L) &
           !(names(lens) == "off" & is.null(off))]
  if (length(bad)) {
    wv_abort(c(
      "Every argument must have one value per new input ({n} input{?s}).",
      "x" = "{.arg {names(bad)}} {cli::qty(length(bad))}ha{?s/ve} length{?s} {bad}."
    ))
  }
  iu <- iu_upgrade(iu)
  new <- iu_map(name, rep_len(type, n), lower, upper, nominal = nominal, prior_sd = prior_sd,
                prior = prior,
                prior_mean = prior_mean)
  out <- new_wv_iu(rbind(as.data.frame(iu), as.data.frame(new)))
  attr(out, "joint") <- attr(iu, "joint")
  if (!is.null(off)) {
    if (!is.numeric(off) && !all(is.na(off))) {
      wv_abort("{.arg off} must be numeric (NA for an input without a no-effect value of its own).",
               class = "input")
    }
    off <- stats::setNames(as.numeric(off), name)
    outside <- !is.na(off) & (off < lower | off > upper)
    if (any(outside)) {
      wv_abort("The no-effect value {.arg off} of {.val {name[outside]}} must lie inside its range.",
               class = "input")
    }
  }
  attr(out, "off") <- c(attr(iu, "off"), off)
  validate_wv_iu(out)
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
  badtype <- !x$type %in% c("calibration", "variation", "condition")
  if (any(badtype)) {
    wv_abort(c(
      "{.arg type} must be {.val calibration}, {.val variation} or {.val condition}.",
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
  if (is.null(x$prior)) return(x)
  badp <- !x$prior %in% c("uniform", "normal", "lognormal", "joint") |
    (x$type == "variation" & x$prior != "normal")
  badp[x$type == "condition"] <- x$prior[x$type == "condition"] != "none"
  if (any(badp)) {
    wv_abort(c(
      "{.arg prior} must be {.val uniform}, {.val normal} or {.val lognormal} for calibration inputs.",
      "x" = "Not so for {.val {x$name[badp]}}."
    ), call = call)
  }
  norm <- x$prior %in% c("normal", "lognormal")
  badsd <- norm & (!is.finite(x$prior_sd) | x$prior_sd <= 0)
  if (any(badsd)) {
    wv_abort("{.arg prior_sd} must be positive for inputs with a normal or log-normal prior; see {.val {x$name[badsd]}}.",
             class = "prior", call = call)
  }
  badm <- norm & (!is.finite(x$prior_mean) | (x$prior == "lognormal" & x$prior_mean <= 0))
  if (any(badm)) {
    wv_abort(c(
      "{.arg prior_mean} must be finite (positive for a log-normal prior: it is the median).",
      "x" = "Not so for {.val {x$name[badm]}}."
    ), class = "prior", call = call)
  }
  cal <- norm & x$type == "calibration"
  if (any(cal)) {
    mass <- vapply(which(cal), function(k) univariate_prior_mass(x, k, x$lower[k], x$upper[k]),
                   numeric(1))
    tiny <- mass < min_prior_mass
    if (any(tiny)) {
      wv_abort(c(
        "The prior puts almost no mass in the range of {.val {x$name[which(cal)[tiny]]}}.",
        "x" = "Before truncation to [lower, upper] it gives the range probability {signif(mass[tiny], 2)}.",
        "i" = "Centre the prior in the range (or widen the range) so that the truncated prior is what you mean."
      ), class = "prior", call = call)
    }
  }
  validate_joint_blocks(x, attr(x, "joint"), call = call)
  x
}

# Below this prior probability of its box an input's prior is refused, and
# rejection sampling from the untruncated prior would be too slow.
min_prior_mass <- 1e-4

#' @export
`[.wv_iu` <- function(x, i, j, ..., drop = TRUE) {
  out <- NextMethod()
  if (!is.data.frame(out) || !missing(j)) return(out)
  blocks <- attr(x, "joint")
  if (length(blocks) && !is.null(out$name)) {
    blocks <- lapply(blocks, function(b) {
      keep <- b$names %in% out$name
      if (!any(keep)) return(NULL)
      list(names = b$names[keep], mean = b$mean[keep], cov = b$cov[keep, keep, drop = FALSE],
           scale = b$scale[keep])
    })
    blocks <- Filter(Negate(is.null), blocks)
    attr(out, "joint") <- if (length(blocks)) blocks else NULL
  }
  off <- attr(x, "off")
  if (!is.null(out$name)) {
    off <- off[names(off) %in% out$name]
    attr(out, "off") <- if (length(off)) off
  }
  out
}

#' A joint Gaussian prior over calibration inputs
#'
#' Replaces the priors of several calibration inputs of an I/U map by one
#' Gaussian with a full covariance, for instance a posterior from an earlier
#' calibration. Each input enters on its own scale (`"identity"`: the input
#' `x`; `"log"`: `log(x)`), and the Gaussian on those scales is truncated to
#' the inputs' ranges `[lower, upper]`. With `y` the inputs on their scales,
#' the prior density on the inputs in their own units is
#' `exp(-(y - mean)' cov^-1 (y - mean) / 2) / prod(x[log scale])` inside the
#' box, up to a constant: the factor `1 / x` of each log-scale input is the
#' Jacobian of `log`.
#'
#' A Gaussian given on the scale `-log(x)` (as GPMSA's flyer-plate example
#' does for the strength parameter `gamma`) is the Gaussian on `log(x)` with
#' the sign of that entry of `mean` flipped, and the signs of that row and
#' column of `cov` flipped (the diagonal entry keeps its sign).
#'
#' The prior must put at least a probability of 1e-4 in the box before
#' truncation: draws of it (the sampler's start search, [testbed_suspension()]
#' truths) are taken by rejection from the untruncated Gaussian.
#'
#' @param iu A `wv_iu` object ([iu_map()]).
#' @param names Names of two or more calibration inputs of `iu` (one is
#'   allowed too), none already under a joint prior.
#' @param mean Mean of the Gaussian, one value per input of `names`, each on
#'   the input's scale.
#' @param cov Covariance matrix of the Gaussian (symmetric positive definite,
#'   one row and column per input of `names`, in that order), on the inputs'
#'   scales.
#' @param scale `"identity"` or `"log"`: one value for every input, or one per
#'   input of `names`. `"log"` needs a positive lower bound.
#' @return `iu` with the joint prior: the inputs' column `prior` becomes
#'   `"joint"` and the Gaussian is kept in the attribute `"joint"` (a list of
#'   blocks with `names`, `mean`, `cov`, `scale`), which [iu_add()], printing
#'   and saving keep.
#' @seealso [iu_map()] for the priors of single inputs.
#' @export
#' @examples
#' iu <- iu_map(c("a", "b", "x1"), c("calibration", "calibration", "variation"),
#'              lower = c(0, 1e-6, 0), upper = c(1, 1e-3, 1))
#' # a and log(b) jointly Gaussian, correlation 0.5
#' iu <- iu_prior_joint(iu, c("a", "b"), mean = c(0.4, log(3e-5)),
#'                      cov = matrix(c(0.01, 0.025, 0.025, 0.25), 2), scale = c("identity", "log"))
#' iu
iu_prior_joint <- function(iu, names, mean, cov, scale = "identity") {
  check_class(iu, "wv_iu")
  iu <- iu_upgrade(iu)
  if (!is.character(names) || !length(names) || anyNA(names) || anyDuplicated(names)) {
    wv_abort("{.arg names} must be distinct input names of {.arg iu}.", class = c("prior", "input"))
  }
  miss <- setdiff(names, iu$name)
  if (length(miss)) {
    wv_abort(c("{.arg names} must be inputs of {.arg iu}.",
               "x" = "{.val {miss}} {?is/are} not in it; its inputs are {.val {iu$name}}."),
             class = c("prior", "input"))
  }
  k <- match(names, iu$name)
  notcal <- names[iu$type[k] != "calibration"]
  if (length(notcal)) {
    wv_abort(c("A joint prior is for calibration inputs only.",
               "x" = "{.val {notcal}} {?has/have} manufacturing variation."),
             class = c("prior", "input"))
  }
  taken <- names[iu$prior[k] == "joint"]
  if (length(taken)) {
    wv_abort(c("{.val {taken}} {?is/are} already under a joint prior.",
               "i" = "Give all inputs of one Gaussian in one call."), class = c("prior", "input"))
  }
  d <- length(names)
  if (!is.numeric(mean) || length(mean) != d || any(!is.finite(mean))) {
    wv_abort(c("{.arg mean} must hold {d} finite number{?s}, one per input of {.arg names}.",
               "x" = "It has length {length(mean)}."), class = c("prior", "input"))
  }
  if (is.numeric(cov) && length(cov) == 1L && d == 1L) cov <- matrix(cov, 1, 1)
  if (!is.matrix(cov) || !is.numeric(cov) || any(dim(cov) != d)) {
    wv_abort(c("{.arg cov} must be a {d} x {d} numeric matrix, one row and column per input of {.arg names}.",
               "x" = "It is {if (is.matrix(cov)) paste(dim(cov), collapse = ' x ') else 'not a matrix'}."),
             class = c("prior", "input"))
  }
  if (any(!is.finite(cov))) wv_abort("{.arg cov} must be finite.", class = c("prior", "input"))
  if (!is.character(scale) || !length(scale) %in% c(1L, d) ||
      !all(scale %in% c("identity", "log"))) {
    wv_abort("{.arg scale} must be {.val identity} or {.val log}, one value or one per input ({d}).",
             class = c("prior", "input"))
  }
  scale <- rep_len(scale, d)
  badlog <- names[scale == "log" & iu$lower[k] <= 0]
  if (length(badlog)) {
    wv_abort(c("A prior on the log scale needs a positive lower bound.",
               "x" = "{.val {badlog}} {cli::qty(length(badlog))}{?has a lower bound/have lower bounds} of zero or less.",
               "i" = "Raise the lower bound, or use {.code scale = \"identity\"} for {cli::qty(length(badlog))}{?it/them}."),
             class = c("prior", "input"))
  }
  cov <- unname(cov)
  joint_chol(cov)
  blocks <- c(attr(iu, "joint"), list(list(names = names, mean = unname(as.numeric(mean)),
                                           cov = cov,
                                           scale = scale)))
  iu$prior[k] <- "joint"
  iu$prior_sd[k] <- NA_real_
  iu$prior_mean[k] <- NA_real_
  attr(iu, "joint") <- blocks
  validate_wv_iu(iu)
}
