# The fit example_fit() returns at seed 1, stored in R/sysdata.rda so that it
# comes back at once. Run from the package's root after installing it:
#   Rscript data-raw/make-example.R
# A test checks the stored fit against a fresh computation. The chains' wall
# time depends on the machine, so the stored fit does not carry it.
example_fit_1 <- wavevalid:::compute_example_fit(1)
example_fit_1 <- wavevalid:::fit_set(example_fit_1, sampling_seconds = NULL)
save(example_fit_1, file = "R/sysdata.rda", compress = "xz")
