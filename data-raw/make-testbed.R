# Generates the test bed instance shipped in inst/extdata and read by
# load_testbed(): seed 2007, reality with a progressive bump stop the model
# lacks. Run from the package root (it loads the package's sources with
# pkgload, write_testbed() being internal):
#   Rscript data-raw/make-testbed.R
pkgload::load_all(".", quiet = TRUE)
tb <- testbed_suspension(seed = 2007, hidden = "progressive_bumpstop")
files <- write_testbed(tb, file.path("inst", "extdata"), digits = 6L)
info <- file.info(files)
print(data.frame(file = basename(files), kB = round(info$size / 1024)), row.names = FALSE)
cat(sprintf("total %.2f MB\n", sum(info$size) / 2^20))
