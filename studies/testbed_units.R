# The cooling test bed of units (testbed_units()): what validate() with
# every default finds on condition A, whose field replicates are six
# specimens tested four times each. For each case (hidden mechanism, seed):
# fit <- validate(tb$A$runs, tb$A$field, tb$iu, seed = 1), no registration
# (the bed has no event windows), then where_fails(fit):
#   findings   the number of findings; kinds, their kinds (with their counts);
#   top_size   the size of the first finding (peak |posterior mean bias|, K);
#   misfit_p   the p-value of the misfit check, attr(where_fails(fit), "misfit")
#              (the field mean against the model at the calibrated inputs,
#              net of what each unit's own inputs explain);
#   seconds    the time of validate().
#   Rscript studies/testbed_units.R [seeds=1:3] [hidden=none,all]
# hidden: comma-separated, "all" for every mechanism of units_mechanisms().
suppressPackageStartupMessages(library(wavevalid))
source("studies/args.R")
args <- study_args(list(seeds = "1:3", hidden = "none,all"))
seeds <- arg_numbers(args$seeds)
hidden <- arg_names(args$hidden)
hidden <- unique(unlist(lapply(hidden, function(h) if (h == "all") units_mechanisms() else h)))
options(wavevalid.quiet = TRUE, width = 200)

one_case <- function(h, seed) {
  tb <- testbed_units(seed = seed, hidden = h)
  t0 <- Sys.time()
  fit <- suppressMessages(validate(tb$A$runs, tb$A$field, tb$iu, seed = 1))
  secs <- as.numeric(difftime(Sys.time(), t0, units = "secs"))
  wf <- where_fails(fit)
  kinds <- table(as.character(wf$kind))
  data.frame(hidden = h, seed = seed, findings = nrow(wf),
             kinds = if (length(kinds)) paste0(names(kinds), " x", kinds, collapse = ", ") else "-",
             top_size = if (nrow(wf)) signif(wf$size[1], 3) else NA_real_,
             misfit_p = signif(attr(attr(wf, "misfit"), "p_value"), 3),
             seconds = round(secs, 1))
}

cases <- expand.grid(seed = seeds, hidden = hidden, stringsAsFactors = FALSE)
out <- do.call(rbind, Map(one_case, cases$hidden, cases$seed))
rownames(out) <- NULL
print(out, row.names = FALSE)
