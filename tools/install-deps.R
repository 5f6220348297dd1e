# Installs from CRAN whatever R package the build, tests and vignettes need and is missing.
pkgs <- commandArgs(trailingOnly = TRUE)
need <- setdiff(pkgs, rownames(utils::installed.packages()))
if (length(need)) {
  message("Installing from CRAN: ", paste(need, collapse = ", "))
  utils::install.packages(need, repos = "https://cloud.r-project.org")
}
still <- setdiff(pkgs, rownames(utils::installed.packages()))
if (length(still)) stop("Could not install: ", paste(still, collapse = ", "))
