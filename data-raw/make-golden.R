# Writes tests/testthat/fixtures/golden.rds: the numbers a fit draws on the
# shipped example and both test beds (tests/testthat/helper-golden.R). Run
# from the package's root with the package installed, only when a change is
# meant to move the draws:  Rscript data-raw/make-golden.R
library(wavevalid)
source("tests/testthat/helper-golden.R")
saveRDS(golden_record(), "tests/testthat/fixtures/golden.rds", version = 2)
