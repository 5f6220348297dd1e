# The fit example_fit() returns at seed 1, stored in R/sysdata.rda so that it
# comes back at once. Run from the package's root after installing it:
#   Rscript data-raw/make-example.R
# A test checks the stored fit against a fresh computation.
example_fit_1 <- wavevalid:::compute_example_fit(1)
save(example_fit_1, file = "R/sysdata.rda", compress = "xz")
