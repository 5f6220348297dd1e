# Does propose_terms() name the missing mechanism's family, and nothing when
# nothing is missing? Both test beds, each mechanism hidden at seeds 1-3 and
# nothing hidden at seeds 1-5: the model validated with validate() (one chain
# of n_draws x n_inner, seed 1, the beds' windows), then propose_terms() on
# term_library(fit) (every default: max_size 2, 100 draws, the parameter
# shifts and the registration's shift and blur in every model).
#   mode = "outputs": the library of the output channels only (a term's curve
#          its effect on the output);
#   mode = "states": the states of the bed's simulator at coef(fit)
#          (simulate_*(states = TRUE)) as channels too, their effects
#          simulated through the equations (simulate_*(term = testbed_term()))
# Per case: the top proposal (term, family, channel, inclusion), whether its
# family is one the mechanism can be written as (`right`, below), and the
# probability of no term.
#   Rscript studies/propose_terms.R [mode=outputs] [seeds=1:3] [null_seeds=1:5] [n_draws=150] [n_inner=20]
#                                   [beds=suspension,dosing] [memory=TRUE] (FALSE: the library without the terms with memory)
suppressPackageStartupMessages(library(wavevalid))
source("studies/args.R")
source("studies/propose_beds.R")
a <- study_args(list(mode = "outputs", seeds = "1:3", null_seeds = "1:5", n_draws = "150", n_inner = "20",
                     beds = "suspension,dosing", memory = "TRUE"))
options(wavevalid.quiet = TRUE, width = 250)

# The families each mechanism can be written as, on a state or on the output
right <- list(
  progressive_bumpstop = c("hinge_above", "power"),
  strut_friction = "sign",
  digressive_damper = c("hinge_above", "hinge_below", "saturating", "abs"),
  tire_liftoff = c("hinge_below", "hinge_above"),
  saturable_elimination = c("saturating", "power"),
  enterohepatic_recycling = c("filter", "delay"),
  absorption_lag = "delay",
  induction = "product"
)
# induction: the elimination times a filter or the integral of the concentration
right_term <- list(induction = "^product\\((filter|integral)\\(")
is_right <- function(hidden, term, family) {
  family %in% right[[hidden]] && (is.null(right_term[[hidden]]) || grepl(right_term[[hidden]], term))
}

one_case <- function(bed, hidden, seed) {
  t0 <- proc.time()[["elapsed"]]
  tb <- if (bed == "suspension") testbed_suspension(seed = seed, hidden = hidden) else
    testbed_dosing(seed = seed, hidden = hidden)
  fit <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, chains = 1, seed = 1,
                                   sampler = sampler_control(n_draws = as.integer(a$n_draws),
                                                             n_inner = as.integer(a$n_inner), quiet = TRUE)))
  if (a$mode == "states") {
    lib <- suppressMessages(term_library(fit, states = bed_states(bed, fit), memory = as.logical(a$memory)))
    pr <- propose_terms(fit, lib, simulate = bed_simulator(bed, fit), seed = 1)
  } else {
    lib <- term_library(fit, memory = as.logical(a$memory))
    pr <- propose_terms(fit, lib, seed = 1)
  }
  top <- pr[1, ]
  data.frame(bed = bed, hidden = hidden, seed = seed, top = top$term, family = top$family,
             channel = top$channel, inclusion = round(top$inclusion_prob, 3),
             right = if (hidden == "none") NA else is_right(hidden, top$term, top$family),
             proposed = top$inclusion_prob >= 0.5, none = round(attr(pr, "none"), 3),
             acts = sprintf("%s [%.2f, %.2f]", top$site, top$from, top$to),
             secs = round(proc.time()[["elapsed"]] - t0))
}

rows <- list()
for (bed in arg_names(a$beds)) {
  mechs <- if (bed == "suspension") testbed_mechanisms() else dosing_mechanisms()
  cases <- rbind(expand.grid(hidden = "none", seed = arg_numbers(a$null_seeds), stringsAsFactors = FALSE),
                 expand.grid(hidden = mechs, seed = arg_numbers(a$seeds), stringsAsFactors = FALSE))
  for (i in seq_len(nrow(cases))) {
    r <- one_case(bed, cases$hidden[i], cases$seed[i])
    print(r, row.names = FALSE)
    rows[[length(rows) + 1L]] <- r
  }
}
out <- do.call(rbind, rows)
cat("\n")
print(out, row.names = FALSE)
cat("\nNothing hidden, a proposal at inclusion >= 0.5, by bed:\n")
print(with(out[out$hidden == "none", ], tapply(proposed, bed, sum)))
cat("\nHidden: the top proposal of a right family and at inclusion >= 0.5, by mechanism (of the seeds):\n")
h <- out[out$hidden != "none", ]
print(with(h, tapply(right & proposed, hidden, sum)))
