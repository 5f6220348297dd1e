# Prints one closing line with the testthat counts of an R CMD check run.
rout <- commandArgs(trailingOnly = TRUE)[1]
l <- grep("[ FAIL", readLines(rout), value = TRUE, fixed = TRUE)
n <- as.integer(regmatches(l, gregexpr("[0-9]+", l))[[length(l)]])
cat(sprintf("testthat: %d passed, %d failed, %d skipped\n", n[4], n[1], n[3]))
