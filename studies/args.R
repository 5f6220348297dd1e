# Command-line arguments of the studies, name=value each. `defaults` is a
# named list of the known names and their values (strings); the result is
# that list with the values given on the command line. Run the studies from
# the package's root: Rscript studies/<name>.R name=value ...
study_args <- function(defaults) {
  for (a in commandArgs(trailingOnly = TRUE)) {
    kv <- strsplit(a, "=", fixed = TRUE)[[1]]
    if (length(kv) != 2L || !kv[1] %in% names(defaults)) {
      stop("unknown argument ", a, "; known: ", toString(names(defaults)), call. = FALSE)
    }
    defaults[[kv[1]]] <- kv[2]
  }
  defaults
}

# The values of the arguments: whole numbers as "1:5" or "1,3,7"; names as
# "a,b"; R values as "NULL" or "0:3"; flags as "TRUE" or "FALSE".
arg_numbers <- function(x) eval(parse(text = paste0("c(", x, ")")))
arg_names <- function(x) if (nzchar(x)) strsplit(x, ",", fixed = TRUE)[[1]] else character()
arg_value <- function(x) eval(parse(text = x))
arg_flag <- function(x) {
  v <- as.logical(x)
  if (length(v) != 1L || is.na(v)) stop("not TRUE or FALSE: ", x, call. = FALSE)
  v
}

# Test-bed cases as "hidden:seed" (comma-separated), or every pair of
# `hidden` (names) and `seeds` when `cases` is empty: a data frame.
arg_cases <- function(cases, hidden, seeds) {
  if (nzchar(cases)) {
    kv <- strsplit(arg_names(cases), ":", fixed = TRUE)
    return(data.frame(hidden = vapply(kv, `[`, "", 1L), seed = as.integer(vapply(kv, `[`, "", 2L))))
  }
  expand.grid(hidden = arg_names(hidden), seed = arg_numbers(seeds), stringsAsFactors = FALSE)
}
