# Prints one closing line with the testthat counts of an R CMD check run, and
# writes it to the file named by the second argument, if any.
args <- commandArgs(trailingOnly = TRUE)
l <- grep("[ FAIL", readLines(args[1]), value = TRUE, fixed = TRUE)
n <- as.integer(regmatches(l, gregexpr("[0-9]+", l))[[length(l)]])
line <- sprintf("testthat: %d passed, %d failed, %d skipped", n[4], n[1], n[3])
cat(line, "\n", sep = "")
if (length(args) >= 2) writeLines(line, args[2])
