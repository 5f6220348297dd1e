#' An HTML validation report
#'
#' Renders a validation into one HTML file that opens with a verdict: in
#' sentences with numbers, whether the model is adequate for `tolerance`,
#' the leading findings of [where_fails()] (each as [top_finding()] says
#' it), the inputs in conflict with their prior, the most probable missing
#' effect when `candidates` are given, and, with a `comparison`, whether the
#' model change helped at the held-out condition with its two ratios and
#' their 90% intervals; then the assumptions that change the answer (the
#' field noise and its source, the grouping of the bias prior's variances,
#' the inputs' likelihood). The sections that follow hold the tables (the
#' inputs with prior, posterior median and 90% interval, sd ratio, R-hat,
#' ESS and conflict; the findings; the candidates; the comparison) as HTML
#' tables, a figure of the bias and its band on each of the first three
#' findings' intervals, the figures of the fit, and, when given, the
#' predictions and the before/after figure. The console print of the fit is
#' kept at the end, folded.
#'
#' The tables are made with [knitr::kable()] (`format = "html"`): knitr
#' already renders the report, so they add no dependency.
#'
#' @inheritParams bands
#' @inheritParams autoplot.wv_fit
#' @param file Path of the HTML file to write.
#' @param runs Optional `wv_runs` the fit was built from (for the figure of
#'   runs and field data).
#' @param candidates Optional candidate effects for [explain_bias()].
#' @param predictions Optional named list of `wv_prediction` objects.
#' @param comparison Optional `wv_comparison` from [compare_validations()].
#' @param proposals Optional `wv_proposals` from [propose_terms()] on `fit`:
#'   a proposed term joins the findings (kind `"term"`) and the report gains
#'   a section with the proposals' table and figure.
#' @param tolerance The bias the intended use can accept, passed to
#'   [where_fails()]: one number or a vector named by site. With the default
#'   0 any credible bias is a finding and the verdict says the model is not
#'   shown adequate rather than judging it against a use.
#' @param title Title of the report.
#' @param quiet Silence the rendering.
#' @return The path of the report, invisibly.
#' @export
#' @examples
#' if (rmarkdown::pandoc_available()) {
#'   fit <- example_fit()
#'   t <- fit$field$t
#'   candidates <- list(bump_early = exp(-((t - 0.25) / 0.05)^2),
#'                      bump_late = exp(-((t - 0.75) / 0.05)^2))
#'   validation_report(fit, tempfile(fileext = ".html"), candidates = candidates, tolerance = 0.005)
#' }
validation_report <- function(fit, file = "validation-report.html", runs = NULL, candidates = NULL,
                              predictions = NULL, comparison = NULL, windows = NULL, tolerance = 0,
                              title = "Validation report", quiet = TRUE, proposals = NULL) {
  check_class(fit, "wv_fit")
  if (!is.null(proposals)) check_proposals_of(proposals, fit)
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
  env$fails <- where_fails(fit, tolerance = tolerance, proposals = proposals)
  env$proposals <- proposals
  env$headline <- top_finding(env$fails)
  env$expl <- if (!is.null(candidates)) explain_bias(fit, candidates, seed = fit_get(fit, "seed"))
  env$verdict <- report_verdict(fit, env$fails, tolerance, expl = env$expl, comparison = comparison)
  env$assumptions <- report_assumptions(fit)
  env$inputs_table <- report_inputs_table(fit)
  env$findings_table <- report_findings_table(env$fails)
  env$comparison_tables <- if (!is.null(comparison)) report_comparison_tables(comparison)
  env$fit_print <- html_escape(paste(utils::capture.output(print(fit)), collapse = "\n"))
  # the template's helpers, which are not exported
  env$html_table <- html_table
  env$finding_figure <- finding_figure
  env$signif_table <- signif_table
  prior_iu <- fit_get(fit, "prior_iu") %||% fit_get(fit, "iu")
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

# Text for HTML: the characters that markup reads escaped.
html_escape <- function(x) {
  x <- gsub("&", "&amp;", x, fixed = TRUE)
  x <- gsub("<", "&lt;", x, fixed = TRUE)
  gsub(">", "&gt;", x, fixed = TRUE)
}
