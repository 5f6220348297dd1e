# Adds up the closing lines of the test tiers (files written by
# tools/test-summary.R and tools/test-slow.R) into one closing line.
n <- vapply(commandArgs(trailingOnly = TRUE), function(f) {
  as.integer(regmatches(readLines(f)[1], gregexpr("[0-9]+", readLines(f)[1]))[[1]])
}, integer(3))
cat(sprintf("testthat: %d passed, %d failed, %d skipped\n", sum(n[1, ]), sum(n[2, ]), sum(n[3, ])))
