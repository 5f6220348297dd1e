# Every output of the two test beds, saved for a bit-for-bit comparison
# between two builds of the package.
#   R_LIBS=<lib> Rscript studies/testbed_identity.R out.rds
# builds testbed_suspension() and testbed_dosing() for seeds 1 and 2 with
# nothing hidden and with each mechanism hidden, the simulators on a small
# design (every mechanism at half strength, and with other nominals), the
# signatures at off-centre inputs, the shipped test bed (load_testbed()) and
# the prints and summaries, and writes them to out.rds.
#   Rscript studies/testbed_identity.R compare before.rds after.rds
# compares two such files with identical(); with the class vectors taken
# off (unclass()) if only they differ, and says so.
args <- commandArgs(trailingOnly = TRUE)

collect <- function() {
  suppressPackageStartupMessages(library(wavevalid))
  out <- list()
  for (s in 1:2) {
    for (h in c("none", testbed_mechanisms())) {
      out[[sprintf("suspension/%d/%s", s, h)]] <- testbed_suspension(seed = s, hidden = h)
    }
    for (h in c("none", dosing_mechanisms())) {
      out[[sprintf("dosing/%d/%s", s, h)]] <- testbed_dosing(seed = s, hidden = h)
    }
  }
  out[["suspension/1/added_mass_3"]] <- testbed_suspension(seed = 1, n_added_mass = 3)
  half <- function(mechs) as.data.frame(as.list(stats::setNames(rep(0.5, length(mechs)), paste0("s_", mechs))))
  d <- data.frame(u1 = c(0.3, 0.5, 0.7), u2 = c(0.6, 0.5, 0.4))
  out[["simulate_suspension/plain"]] <- simulate_suspension(d)
  out[["simulate_suspension/mechanisms"]] <- simulate_suspension(cbind(d, half(testbed_mechanisms())),
                                                                 mechanism = testbed_mechanisms())
  out[["simulate_suspension/nominal"]] <- simulate_suspension(d, nominal = c(x1 = 0.7, x6 = 0.3))
  out[["simulate_dosing/plain"]] <- simulate_dosing(d)
  out[["simulate_dosing/mechanisms"]] <- simulate_dosing(cbind(d, half(dosing_mechanisms())),
                                                         mechanism = dosing_mechanisms())
  out[["simulate_dosing/nominal"]] <- simulate_dosing(d, nominal = c(x1 = 0.7, x3 = 0.3))
  inputs <- c(u1 = 0.4, u2 = 0.6, x1 = 0.55)
  out[["testbed_signatures"]] <- testbed_signatures(inputs)
  out[["dosing_signatures"]] <- dosing_signatures(inputs)
  out[["load_testbed"]] <- load_testbed()
  printed <- function(x) utils::capture.output(print(x), print(summary(x)))
  out[["print/suspension"]] <- printed(out[["suspension/1/tire_liftoff"]])
  out[["print/suspension_added_mass_3"]] <- printed(out[["suspension/1/added_mass_3"]])
  out[["print/dosing"]] <- printed(out[["dosing/1/induction"]])
  out[["print/load_testbed"]] <- printed(out[["load_testbed"]])
  out
}

compare <- function(a, b) {
  if (!identical(names(a), names(b))) stop("the two files hold different items")
  res <- vapply(names(a), function(nm) {
    if (identical(a[[nm]], b[[nm]])) return("identical")
    if (identical(unclass(a[[nm]]), unclass(b[[nm]]))) {
      return(sprintf("identical but for the class (%s -> %s)", paste(class(a[[nm]]), collapse = ", "),
                     paste(class(b[[nm]]), collapse = ", ")))
    }
    "DIFFERENT"
  }, character(1))
  print(data.frame(item = names(res), result = unname(res)), row.names = FALSE, right = FALSE)
  cat(sprintf("\n%d items: %d identical, %d identical but for the class, %d different\n", length(res),
              sum(res == "identical"), sum(startsWith(res, "identical but")), sum(res == "DIFFERENT")))
  invisible(res)
}

if (length(args) == 3L && args[1] == "compare") {
  compare(readRDS(args[2]), readRDS(args[3]))
} else if (length(args) == 1L) {
  saveRDS(collect(), args[1])
} else {
  stop("usage: Rscript studies/testbed_identity.R out.rds | compare before.rds after.rds")
}
