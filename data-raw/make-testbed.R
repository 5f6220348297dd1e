# Generates the test bed instance shipped in inst/extdata and read by
# load_testbed(): seed 2007, reality with a progressive bump stop the model
# lacks. Run from the package root after installing the package:
#   Rscript data-raw/make-testbed.R
suppressPackageStartupMessages(library(wavevalid))
tb <- testbed_suspension(seed = 2007, hidden = "progressive_bumpstop")
files <- wavevalid:::write_testbed(tb, file.path("inst", "extdata"), digits = 6L)
info <- file.info(files)
print(data.frame(file = basename(files), kB = round(info$size / 1024)), row.names = FALSE)
cat(sprintf("total %.2f MB\n", sum(info$size) / 2^20))
