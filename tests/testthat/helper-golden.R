# What a fit draws, as numbers only, on the shipped example and both test
# beds: the suspension with its added-mass experiment and the hidden bump
# stop, the dosing bed with nothing hidden. The record is compared to the bit
# with tests/testthat/fixtures/golden.rds (made by data-raw/make-golden.R):
# a change that moves a draw, a finding or a band fails it.
golden_numbers <- function(fit) {
  num <- function(x) if (is.list(x)) lapply(x, num) else if (is.numeric(x)) unname(as.numeric(x)) else NULL
  wf <- where_fails(fit)
  list(
    draws = lapply(fit$draws, function(d) unname(as.matrix(d))),
    wb = golden_md5(num(fit$wb)), wM = golden_md5(num(fit$wM)), sigma2 = golden_md5(num(fit$sigma2)),
    findings = list(kind = as.character(wf$kind), site = as.character(wf$site),
                    numbers = num(as.list(wf[vapply(wf, is.numeric, logical(1))])))
  )
}

# The md5 of a list of numbers' bits, for the parts too large to keep whole.
golden_md5 <- function(x) {
  f <- tempfile()
  on.exit(unlink(f))
  writeBin(as.numeric(unlist(x)), f)
  unname(tools::md5sum(f))
}

golden_record <- function() {
  old <- options(wavevalid.quiet = TRUE)
  on.exit(options(old), add = TRUE)
  sampler <- sampler_control(n_draws = 20, n_inner = 5, burnin = 100, n_search = 10, quiet = TRUE)
  tb <- testbed_suspension(seed = 1, hidden = "progressive_bumpstop", n_added_mass = 2)
  exps <- list(added_mass = experiment(tb$added_mass$field, change = tb$added_mass$delta))
  suspension <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, chains = 1,
                                          seed = 1, experiments = exps, sampler = sampler))
  td <- testbed_dosing(seed = 1)
  dosing <- suppressWarnings(validate(td$A$runs, td$A$field, td$iu, windows = td$windows, features = "rise",
                                      chains = 1, seed = 1, sampler = sampler))
  list(example = golden_numbers(example_fit(1)), suspension = golden_numbers(suspension),
       dosing = golden_numbers(dosing))
}
