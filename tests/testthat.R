library(testthat)
library(wavevalid)

test_check("wavevalid")
