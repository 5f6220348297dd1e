# The validation report read in a real browser: renders validation_report()
# of example_fit() (with two candidate effects and a tolerance), opens it in
# headless Chromium at 1280 x 900, takes a screenshot of the first screen,
# dumps the page's DOM after its scripts ran and reads Chromium's console
# log. Checks that the verdict section and its first sentences are in the
# rendered page, that the verdict starts within the first screen's height
# (measured by the browser with a script in the page), and that the page
# logged no JavaScript error. Without Chromium it says so and stops without
# failing (`make report-check` installs Debian's chromium first).
# Run: Rscript bench/bench_report_browser.R [out_dir] [report.html]
# With a report already rendered (the demo's: out/validation-report.html), it
# reads that one instead and prints the verdict's text as the browser shows it.
# (WAVEVALID_LOAD_ALL=true loads the package from the sources instead of the
# installed one.)
if (identical(Sys.getenv("WAVEVALID_LOAD_ALL"), "true")) {
  pkgload::load_all(".", compile = FALSE, quiet = TRUE)
} else {
  library(wavevalid)
}
args <- commandArgs(trailingOnly = TRUE)
out_dir <- if (length(args) >= 1) args[1] else tempfile("wv-report-browser")
dir.create(out_dir, showWarnings = FALSE, recursive = TRUE)
out_dir <- normalizePath(out_dir)

chromium <- Sys.which(c("chromium", "chromium-browser", "google-chrome"))
chromium <- chromium[nzchar(chromium)][1]
if (is.na(chromium) && file.exists("/usr/bin/chromium")) chromium <- "/usr/bin/chromium"
if (is.na(chromium)) {
  cat("No Chromium found: the browser check did not run (make report-check installs Debian's chromium).\n")
  quit(status = 0)
}

given <- length(args) >= 2
if (given) {
  html <- normalizePath(args[2], mustWork = TRUE)
  cat(sprintf("Report given: %s (%.0f KB)\n", html, file.size(html) / 1024))
} else {
  fit <- example_fit()
  t <- fit$field$t
  candidates <- list(bump_early = exp(-((t - 0.25) / 0.05)^2), bump_late = exp(-((t - 0.75) / 0.05)^2))
  html <- file.path(out_dir, "validation-report.html")
  elapsed <- system.time(validation_report(fit, html, candidates = candidates, tolerance = 0.001))[["elapsed"]]
  cat(sprintf("Report rendered in %.1f s: %s (%.0f KB)\n", elapsed, html, file.size(html) / 1024))
}

# The browser measures where the verdict starts: a script added to a copy of
# the page writes it into the page's title, which the dumped DOM holds.
probe <- file.path(dirname(html), "validation-report-probe.html")
page <- readLines(html, warn = FALSE)
script <- paste0("<script>window.addEventListener('load', function() {",
                 "var v = document.getElementById('verdict');",
                 "document.title = 'verdict-top:' + (v ? Math.round(v.getBoundingClientRect().top) : -1);});</script>")
end_body <- max(grep("</body>", page, fixed = TRUE))
page[end_body] <- sub("</body>", paste0(script, "</body>"), page[end_body], fixed = TRUE)
writeLines(page, probe)

flags <- c("--headless", "--disable-gpu", "--no-sandbox", "--window-size=1280,900", "--hide-scrollbars")
url <- function(f) paste0("file://", f)
shot <- file.path(out_dir, "verdict-first-screen.png")
log_file <- file.path(out_dir, "chromium.log")
run <- function(extra, target, stdout = TRUE) {
  system2(chromium, c(flags, extra, url(target)), stdout = stdout, stderr = log_file)
}
run(paste0("--screenshot=", shot), html, stdout = FALSE)
dom <- run(c("--enable-logging=stderr", "--v=0", "--virtual-time-budget=5000", "--dump-dom"), probe)
dom <- paste(dom, collapse = "\n")
log <- readLines(log_file, warn = FALSE)

text <- gsub("\\s+", " ", gsub("<[^>]+>", " ", dom))
checks <- c(
  verdict_section = grepl("id=\"verdict\"", dom, fixed = TRUE),
  verdict_sentence = given || grepl("adequate for the tolerance 0.001", text, ignore.case = TRUE),
  assumptions = grepl("Assumptions that change the answer", text, fixed = TRUE),
  no_js_error = !any(grepl("Uncaught|CONSOLE\\(.*\\).*Error", log))
)
top <- suppressWarnings(as.numeric(sub(".*verdict-top:(-?[0-9]+).*", "\\1", regmatches(dom, regexpr("verdict-top:-?[0-9]+", dom)))))
checks["verdict_in_first_screen"] <- length(top) == 1L && !is.na(top) && top >= 0 && top < 900
cat(sprintf("Chromium: %s\n", system2(chromium, "--version", stdout = TRUE, stderr = FALSE)[1]))
cat(sprintf("Screenshot of the first 1280 x 900 screen: %s (%.0f KB)\n", shot,
            if (file.exists(shot)) file.size(shot) / 1024 else NA))
cat(sprintf("Verdict section starts %s px from the top of the page\n", if (length(top)) top else "?"))
cat(sprintf("JavaScript errors in the console log: %d\n", sum(grepl("Uncaught|CONSOLE\\(.*\\).*Error", log))))
if (given) {
  verdict <- sub("^.*?\\bVerdict\\b(.*?)\\bAssumptions that change the answer\\b.*$", "\\1", text, perl = TRUE)
  cat("The verdict as the browser shows it:\n", strwrap(verdict, 100, prefix = "  "), sep = "\n")
}
for (nm in names(checks)) cat(sprintf("  %-24s %s\n", nm, if (checks[[nm]]) "ok" else "FAILED"))
if (!all(checks)) quit(status = 1)
