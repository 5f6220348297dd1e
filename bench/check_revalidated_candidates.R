# explain_bias() with re-validated models as candidates, over test-bed cases.
# For each case (hidden mechanism, seed): the model without any mechanism is
# validated on condition A (66 runs, the tests' settings); for each mechanism m
# of the test bed, the model with m (its strength s_m a calibration input on
# [0, 1]) is simulated at a 66-point maximin design, its emulators fitted on
# the same basis and calibrated on the same registered field data; then
# explain_bias(base, fits) weighs each by its Savage-Dickey Bayes factor
# against itself with s_m = 0. Prints, per case, the leading candidate, the
# inclusion probability of the hidden one, the largest of the others, the
# probability of "(none)", the log Bayes factors and the seconds taken.
#   Rscript bench/check_revalidated_candidates.R [hidden:seed ...] (default: all 25 cases)
suppressPackageStartupMessages(library(wavevalid))
options(wavevalid.quiet = TRUE)
args <- commandArgs(trailingOnly = TRUE)
if (!length(args)) args <- as.vector(outer(c("none", testbed_mechanisms()), 1:5, paste, sep = ":"))
clock <- function() as.numeric(proc.time()[["elapsed"]])

out <- NULL
for (a in args) {
  hidden <- sub(":.*", "", a)
  seed <- as.integer(sub(".*:", "", a))
  t0 <- clock()
  v <- wavevalid:::testbed_validation(hidden, seed)
  base <- v$fit
  fits <- wavevalid:::testbed_revalidation(v$tb, base)
  ex <- explain_bias(base, fits)
  lbf <- attr(ex, "log_bf")
  sub <- attr(ex, "subsets")
  row <- data.frame(hidden = hidden, seed = seed, first = ex$candidate[1],
                    p_hidden = if (hidden == "none") NA else ex$inclusion_prob[ex$candidate == hidden],
                    p_other = max(ex$inclusion_prob[ex$candidate != hidden]),
                    p_none = sub$probability[sub$subset == "(none)"],
                    log_bf = paste(sprintf("%s %.1f", names(lbf), lbf), collapse = ", "),
                    seconds = round(clock() - t0))
  print(row, digits = 3, row.names = FALSE)
  out <- rbind(out, row)
}
cat("\n")
print(out, digits = 3, row.names = FALSE)
