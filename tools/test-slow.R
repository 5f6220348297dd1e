# The slow tier: the whole test suite with WAVEVALID_SLOW_TESTS=true, against
# the installed package, its files spread over two processes. Prints one
# closing line with the counts (written also to the file named by the first
# argument, if any) and fails on any failure.
args <- commandArgs(trailingOnly = TRUE)
Sys.setenv(WAVEVALID_SLOW_TESTS = "true", NOT_CRAN = "true")
res <- testthat::test_local(".", load_package = "installed", reporter = "summary", stop_on_failure = FALSE)
d <- as.data.frame(res)
failed <- sum(d$failed) + sum(d$error)
line <- sprintf("testthat: %d passed, %d failed, %d skipped", sum(d$passed), failed, sum(d$skipped))
cat(line, "\n", sep = "")
if (length(args) >= 1) writeLines(line, args[1])
if (failed > 0) quit(status = 1)
