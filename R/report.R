#' An HTML validation report
#'
#' Renders every figure and table of a validation into one HTML file,
#' headed by the largest finding of [where_fails()] ([top_finding()]): the
#' inputs and their posteriors, emulator quality, the bias and the
#' bias-corrected prediction with their bands, where the model fails, and,
#' when given, the ranking of candidate effects, predictions in new settings
#' and a before/after comparison.
#'
#' @inheritParams bands
#' @inheritParams autoplot.wv_fit
#' @param file Path of the HTML file to write.
#' @param runs Optional `wv_runs` the fit was built from (for the figure of
#'   runs and field data).
#' @param candidates Optional candidate effects for [explain_bias()].
#' @param predictions Optional named list of `wv_prediction` objects.
#' @param comparison Optional `wv_comparison` from [compare_validations()].
#' @param title Title of the report.
#' @param quiet Silence the rendering.
#' @return The path of the report, invisibly.
#' @export
#' @examples
#' \dontrun{
#' tb <- load_testbed()
#' fit <- validate(tb$A$runs, tb$A$field, tb$iu, windows = list(c(6, 11), c(37, 41)))
#' validation_report(fit, tempfile(fileext = ".html"), runs = tb$A$runs)
#' }
validation_report <- function(fit, file = "validation-report.html", runs = NULL, candidates = NULL,
                              predictions = NULL, comparison = NULL, windows = NULL,
                              title = "Validation report", quiet = TRUE) {
  check_class(fit, "wv_fit")
  check_string(file)
  if (!is.null(runs)) check_class(runs, "wv_runs")
  if (!is.null(comparison)) check_class(comparison, "wv_comparison")
  if (!is.null(predictions)) {
    ok <- is.list(predictions) && !is.null(names(predictions)) &&
      all(vapply(predictions, inherits, logical(1), "wv_prediction"))
    if (!ok) wv_abort("{.arg predictions} must be a named list of {.cls wv_prediction} objects.")
  }
  if (!requireNamespace("rmarkdown", quietly = TRUE) || !rmarkdown::pandoc_available()) {
    wv_abort("The report needs the {.pkg rmarkdown} package and pandoc.", class = "dependency")
  }
  template <- system.file("report", "validation-report.Rmd", package = "wavevalid", mustWork = TRUE)
  dir <- tempfile("wv-report")
  dir.create(dir)
  on.exit(unlink(dir, recursive = TRUE), add = TRUE)
  rmd <- file.path(dir, "validation-report.Rmd")
  file.copy(template, rmd)
  env <- new.env(parent = globalenv())
  env$fit <- fit
  env$fails <- where_fails(fit)
  env$headline <- top_finding(env$fails)
  prior_iu <- fit$prior_iu %||% fit$iu
  iu_table <- signif_table(as.data.frame(prior_iu)[c("name", "type", "lower", "upper", "nominal")])
  iu_table$prior <- prior_labels(prior_iu)
  env$iu_table <- iu_table
  env$runs <- runs
  env$candidates <- candidates
  env$predictions <- predictions
  env$comparison <- comparison
  env$windows <- windows
  env$report_title <- title
  old_options <- options(width = 110, knitr.kable.NA = "")
  on.exit(options(old_options), add = TRUE)
  out_file <- normalizePath(file, mustWork = FALSE)
  dir.create(dirname(out_file), showWarnings = FALSE, recursive = TRUE)
  rmarkdown::render(rmd, output_file = basename(out_file), output_dir = dirname(out_file),
                    intermediates_dir = dir, envir = env, quiet = quiet)
  wv_inform(c("v" = "Validation report written to {.file {out_file}}."))
  invisible(out_file)
}

# A data frame for a report table: numeric columns as text with `digits`
# significant digits (ranges of 1e-7 and of 300 side by side keep their
# figures, which fixed decimals would round to zero), missing values empty.
signif_table <- function(d, digits = 4) {
  d[] <- lapply(d, function(v) {
    if (!is.numeric(v)) return(v)
    out <- trimws(formatC(v, digits = digits, format = "g"))
    out[is.na(v)] <- ""
    out
  })
  d
}
