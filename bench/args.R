# Command-line arguments of the bench scripts, name=value each. `defaults` is a
# named list of the known names and their values (strings); the result is that
# list with the values given on the command line. Run the scripts from the
# package's root (Rscript bench/<script>.R name=value ...).
bench_args <- function(defaults) {
  for (a in commandArgs(trailingOnly = TRUE)) {
    kv <- strsplit(a, "=", fixed = TRUE)[[1]]
    if (length(kv) != 2L || !kv[1] %in% names(defaults)) {
      stop("unknown argument ", a, "; known: ", toString(names(defaults)), call. = FALSE)
    }
    defaults[[kv[1]]] <- kv[2]
  }
  defaults
}
