# Curves of their own extent: each field curve of a test bed cut at its own
# end (uniform on [frac, 1] of the record; the first curve of a site whole,
# the longest record), given on its own times, put on
# the runs' grid by field_runs(grid = runs$t) and validated; against the
# same data uncut. Per seed, bed and case:
#   covered    share of the true inputs (calibration inputs) inside their 95%
#              intervals
#   width      the calibration inputs' 95% intervals' mean width
#   found      where_fails() has a finding (none hidden: a false one)
#   misfit_p   misfit_check()'s p-value
#   kept       share of the uncut data's points kept (the shortest curve's
#              share: what a common range would keep)
# Beds: "cooling" (testbed_units(), six units of four tests, unregistered)
# and "dosing" (testbed_dosing(), six replicates, registered on its windows).
#   whole=FALSE cuts every curve: no curve reaches the grid's end.
#   Rscript studies/own_extent.R [seeds=1:3] [beds=cooling,dosing] [hidden=none] [whole=TRUE]
#                                [frac=0.4] [out=studies/own_extent.csv]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(seeds = "1:3", beds = "cooling,dosing", hidden = "none", frac = "0.4", whole = "TRUE",
                       out = "studies/own_extent.csv"))
options(wavevalid.quiet = TRUE)
sampler <- sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE)
frac <- as.numeric(opt$frac)

cut_field <- function(field, seed) {
  t <- field$t
  set.seed(seed)
  lst <- lapply(field$curves, function(m) {
    ends <- stats::runif(nrow(m), frac, 1) * (max(t) - min(t)) + min(t)
    if (arg_flag(opt$whole)) ends[1] <- max(t)
    list(t = lapply(ends, function(e) t[t <= e]),
         y = lapply(seq_len(nrow(m)), function(r) m[r, t <= ends[r]]),
         kept = min(ends - min(t)) / (max(t) - min(t)))
  })
  f <- suppressMessages(field_runs(lapply(lst, `[[`, "y"), t = lapply(lst, `[[`, "t"), grid = t,
                                   x_nom = field$x_nom, units = field$units))
  attr(f, "kept") <- min(vapply(lst, `[[`, numeric(1), "kept"))
  f
}

row_of <- function(fit, truth, bed, seed, case, hidden, ref = NULL) {
  ci <- summary(fit)$inputs
  u <- names(truth)
  ci <- ci[match(u, ci$input), ]
  wf <- where_fails(fit)
  mc <- misfit_check(fit)
  data.frame(bed = bed, seed = seed, hidden = hidden, case = case,
             covered = mean(truth >= ci$q2.5 & truth <= ci$q97.5),
             width = mean(ci$q97.5 - ci$q2.5), found = nrow(as.data.frame(wf)) > 0, misfit_p = attr(mc, "p_value"))
}

rows <- list()
for (seed in arg_numbers(opt$seeds)) for (bed in arg_names(opt$beds)) for (hd in arg_names(opt$hidden)) {
  tb <- if (bed == "cooling") testbed_units(seed, hd) else testbed_dosing(seed, hd)
  truth <- tb$truth$u
  full <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, sampler = sampler,
                                    chains = 1, seed = 1))
  fc <- cut_field(tb$A$field, seed)
  cut <- suppressWarnings(validate(tb$A$runs, fc, tb$iu, windows = tb$windows, sampler = sampler,
                                   chains = 1, seed = 1))
  a <- row_of(full, truth, bed, seed, "uncut", hd)
  b <- row_of(cut, truth, bed, seed, "own extent", hd)
  b$kept <- attr(fc, "kept")
  a$kept <- 1
  rows[[length(rows) + 1L]] <- rbind(a, b)
  print(utils::tail(do.call(rbind, rows), 2), digits = 3)
}
out <- do.call(rbind, rows)
utils::write.csv(out, opt$out, row.names = FALSE)
print(out, digits = 3)
