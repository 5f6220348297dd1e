# The slow tier: the test files matching the second argument (a regular
# expression; all of them if absent) with WAVEVALID_SLOW_TESTS=true, against
# the installed package, spread over two processes. Prints one closing line
# with the counts (written also to the file named by the first argument) and
# fails on any failure.
args <- commandArgs(trailingOnly = TRUE)
Sys.setenv(WAVEVALID_SLOW_TESTS = "true", NOT_CRAN = "true")
filter <- if (length(args) >= 2) args[2] else NULL
res <- testthat::test_local(".", filter = filter, load_package = "installed", reporter = "summary",
                            stop_on_failure = FALSE)
d <- as.data.frame(res)
failed <- sum(d$failed) + sum(d$error)
line <- sprintf("testthat: %d passed, %d failed, %d skipped", sum(d$passed), failed, sum(d$skipped))
cat(line, "\n", sep = "")
if (length(args) >= 1) writeLines(line, args[1])
if (failed > 0) quit(status = 1)
