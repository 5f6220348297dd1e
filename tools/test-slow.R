# The slow tier: the test files that hold slow tests (a call of
# skip_unless_slow()) with WAVEVALID_SLOW_TESTS=true, against the installed
# package, spread over two processes. Prints one closing line with the counts
# (written also to the file named by the first argument) and fails on any
# failure.
args <- commandArgs(trailingOnly = TRUE)
Sys.setenv(WAVEVALID_SLOW_TESTS = "true", NOT_CRAN = "true")
files <- list.files("tests/testthat", "^test-.*\\.R$")
slow <- files[vapply(files, function(f) any(grepl("skip_unless_slow()", readLines(file.path("tests/testthat", f)),
                                                  fixed = TRUE)), logical(1))]
filter <- paste0("^(", paste(sub("^test-(.*)\\.R$", "\\1", slow), collapse = "|"), ")$")
cat("slow tier: ", paste(slow, collapse = ", "), "\n", sep = "")
res <- testthat::test_local(".", filter = filter, load_package = "installed", reporter = "summary",
                            stop_on_failure = FALSE)
d <- as.data.frame(res)
failed <- sum(d$failed) + sum(d$error)
line <- sprintf("testthat: %d passed, %d failed, %d skipped", sum(d$passed), failed, sum(d$skipped))
cat(line, "\n", sep = "")
if (length(args) >= 1) writeLines(line, args[1])
if (failed > 0) quit(status = 1)
