# Classed conditions and argument checks shared by every stage.

wv_abort <- function(message, class = "input", ..., call = rlang::caller_env(),
                     .envir = parent.frame()) {
  cli::cli_abort(
    message,
    class = c(paste0("wavevalid_error_", class), "wavevalid_error"),
    ...,
    call = call,
    .envir = .envir
  )
}

wv_warn <- function(message, class = "warning", ..., .envir = parent.frame()) {
  cli::cli_warn(message, class = c(paste0("wavevalid_warning_", class), "wavevalid_warning"), ...,
                .envir = .envir)
}

# An argument renamed from `old` to `new`. A call that still names `old`
# lands in the function's `...`: `renamed_arg()` then warns and returns the
# call with `new` in its place, for the function to evaluate instead; it
# returns NULL when the call does not name `old`. Use it as
#   if (...length()) {
#     call <- renamed_arg(sys.call(), "old", "new", "fun")
#     if (!is.null(call)) return(eval(call, parent.frame()))
#     check_dots_none(...)
#   }
renamed_arg <- function(call, old, new, fun) {
  nm <- names(call)
  if (is.null(nm) || !old %in% nm[-1L]) return(NULL)
  wv_warn(c("The argument {.arg {old}} of {.fn {fun}} is deprecated.",
            "i" = "Use {.arg {new}} instead: {.code {fun}({new} = ...)}."),
          class = "deprecated")
  names(call)[nm == old] <- new
  call
}

wv_inform <- function(message, ..., class = NULL, .envir = parent.frame()) {
  if (!isTRUE(getOption("wavevalid.quiet", FALSE))) {
    cli::cli_inform(message,
                    class = c(if (!is.null(class)) paste0("wavevalid_message_", class),
                              "wavevalid_message"),
                    ..., .envir = .envir)
  }
}

check_number <- function(x, arg = deparse(substitute(x)), min = -Inf, max = Inf,
                         integer = FALSE, call = rlang::caller_env()) {
  if (!is.numeric(x) || length(x) != 1L || !is.finite(x)) {
    wv_abort("{.arg {arg}} must be a single finite number, not {.obj_type_friendly {x}}.",
             call = call)
  }
  if (integer && x != round(x)) {
    wv_abort("{.arg {arg}} must be a whole number; it is {x}.", call = call)
  }
  if (x < min || x > max) {
    wv_abort("{.arg {arg}} must lie in [{min}, {max}]; it is {x}.", call = call)
  }
  invisible(x)
}

check_class <- function(x, class, arg = deparse(substitute(x)), call = rlang::caller_env()) {
  if (!inherits(x, class)) {
    wv_abort(
      "{.arg {arg}} must be a {.cls {class}} object, not {.obj_type_friendly {x}}.",
      call = call
    )
  }
  invisible(x)
}

check_dots_none <- function(..., call = rlang::caller_env()) {
  if (...length()) {
    nm <- names(list(...))
    nm <- if (is.null(nm)) rep("", ...length()) else nm
    wv_abort(c(
      "Unknown argument{?s} {.arg {ifelse(nzchar(nm), nm, paste0('..', seq_along(nm)))}}.",
      "i" = "Check the spelling against the function's help."
    ), call = call)
  }
  invisible()
}

check_string <- function(x, arg = deparse(substitute(x)), call = rlang::caller_env()) {
  if (!is.character(x) || length(x) != 1L || is.na(x) || !nzchar(x)) {
    wv_abort("{.arg {arg}} must be a single non-empty string.", call = call)
  }
  invisible(x)
}

check_level <- function(level, call = rlang::caller_env()) {
  if (!is.numeric(level) || length(level) != 1L || !is.finite(level) || level <= 0 || level >= 1) {
    wv_abort("{.arg level} must be a single probability strictly between 0 and 1.", call = call)
  }
  invisible(level)
}

# Seed handling: NULL draws one from R's RNG so that set.seed() works.
resolve_seed <- function(seed, call = rlang::caller_env()) {
  if (is.null(seed)) {
    return(as.integer(sample.int(.Machine$integer.max, 1L)))
  }
  if (!is.numeric(seed) || length(seed) != 1L || !is.finite(seed)) {
    wv_abort("{.arg seed} must be NULL or a single whole number.", call = call)
  }
  as.integer(seed %% .Machine$integer.max)
}

`%||%` <- function(x, y) if (is.null(x)) y else x

# Evaluates code with R's RNG (default kinds) seeded by seed, restoring the
# caller's RNG state and kind.
with_rng_seed <- function(seed, code) {
  old_kind <- RNGkind()
  had_seed <- exists(".Random.seed", envir = globalenv(), inherits = FALSE)
  if (had_seed) old_seed <- get(".Random.seed", envir = globalenv(), inherits = FALSE)
  on.exit({
    if (had_seed) {
      assign(".Random.seed", old_seed, envir = globalenv())
    } else {
      RNGkind(old_kind[1], old_kind[2], old_kind[3])
      if (exists(".Random.seed", envir = globalenv(), inherits = FALSE)) {
        rm(".Random.seed", envir = globalenv())
      }
    }
  }, add = TRUE)
  set.seed(seed, kind = "Mersenne-Twister", normal.kind = "Inversion", sample.kind = "Rejection")
  force(code)
}

# The value of a choice argument (a character vector of choices as its
# default in the calling function): the first choice when left at its
# default, else the one choice that `arg` names or begins (as match.arg()),
# with a classed error that lists the choices otherwise.
check_choice <- function(arg, arg_name = deparse(substitute(arg)), call = rlang::caller_env()) {
  values <- eval(formals(sys.function(sys.parent()))[[arg_name]], envir = call)
  if (identical(arg, values)) return(values[[1L]])
  hit <- if (is.character(arg) && length(arg) == 1L && !is.na(arg)) pmatch(arg,
                                                                           values) else NA_integer_
  if (is.na(hit)) {
    wv_abort(c(
      "{.arg {arg_name}} must be one of {.or {.val {values}}}.",
      "x" = "It is {.val {format(arg)}}."
    ), call = call)
  }
  values[[hit]]
}

check_flag <- function(x, arg = deparse(substitute(x)), call = rlang::caller_env()) {
  if (!is.logical(x) || length(x) != 1L || is.na(x)) {
    wv_abort("{.arg {arg}} must be {.code TRUE} or {.code FALSE}.", call = call)
  }
  invisible(x)
}

resolve_site <- function(site, sites, arg, call = rlang::caller_env()) {
  if (is.numeric(site) && length(site) == 1L && site %in% seq_along(sites)) return(sites[site])
  if (is.character(site) && length(site) == 1L && site %in% sites) return(site)
  wv_abort(c(
    "{.arg {arg}} must name one site (or give its position).",
    "x" = "Sites are {.val {sites}}."
  ), call = call)
}

check_same_grid <- function(t1, t2, arg1, arg2, call = rlang::caller_env()) {
  if (length(t1) != length(t2)) {
    wv_abort(c(
      "{.arg {arg1}} and {.arg {arg2}} must be on the same time grid.",
      "x" = "{.arg {arg1}} has {length(t1)} time points and {.arg {arg2}} has {length(t2)}.",
      "i" = "Interpolate both to one grid first (e.g. {.fn stats::approx} onto the model-run grid)."
    ), call = call)
  }
  d <- max(abs(t1 - t2))
  if (d > 1e-8 * max(1, abs(t1), abs(t2))) {
    i <- which.max(abs(t1 - t2))
    wv_abort(c(
      "{.arg {arg1}} and {.arg {arg2}} must be on the same time grid.",
      "x" = "Both have {length(t1)} points but differ by up to {signif(d, 3)} (point {i}: {signif(t1[i], 6)} vs {signif(t2[i], 6)}); ranges [{signif(min(t1), 5)}, {signif(max(t1), 5)}] and [{signif(min(t2), 5)}, {signif(max(t2), 5)}].",
      "i" = "Interpolate both to one grid first (e.g. {.fn stats::approx} onto the model-run grid)."
    ), call = call)
  }
  invisible(TRUE)
}

# Whole wavelet levels (0 for the scaling coefficient), or NULL.
check_levels_arg <- function(x, arg, min_length = 1L, call = rlang::caller_env()) {
  if (is.null(x)) return(invisible(x))
  if (!is.numeric(x) || anyNA(x) || any(x != round(x)) || any(x < 0) ||
      length(unique(x)) < min_length) {
    wv_abort(c(
      "{.arg {arg}} must be {if (min_length > 1L) 'two or more' else 'one or more'} whole wavelet levels (0 for the scaling coefficient), or NULL.",
      "x" = "It is {.code {deparse(x)}}."
    ), call = call)
  }
  invisible(x)
}
