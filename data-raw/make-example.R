# The fit example_fit() returns at seed 1, stored in R/sysdata.rda so that it
# comes back at once. Run from the package's root (it loads the package's
# sources with pkgload, compute_example_fit() being internal):
#   Rscript data-raw/make-example.R
# A test checks the stored fit against a fresh computation. The chains' wall
# time depends on the machine, so the stored fit does not carry it.
pkgload::load_all(".", quiet = TRUE)
example_fit_1 <- compute_example_fit(1)
example_fit_1 <- fit_set(example_fit_1, sampling_seconds = NULL)
save(example_fit_1, file = "R/sysdata.rda", compress = "xz")
