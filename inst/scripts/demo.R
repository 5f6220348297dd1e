# Validation demo on the shipped suspension test bed: writes figures and a
# summary to the folder given as the first argument (default "out").
args <- commandArgs(trailingOnly = TRUE)
out <- if (length(args)) args[1] else "out"
dir.create(out, showWarnings = FALSE, recursive = TRUE)
suppressPackageStartupMessages(library(wavevalid))
message("wavevalid ", utils::packageVersion("wavevalid"), ": writing the demo to ", normalizePath(out))
