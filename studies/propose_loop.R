# Does the top proposal fix the model as well as the true mechanism? Each
# bed (`bed`), each mechanism hidden at `seeds`: the model validated
# (validate(), one chain of n_draws x n_inner, seed 1), the terms proposed
# from the simulator's states and output (propose_terms(), states simulated
# through testbed_term()), then two models validated again with update() and
# judged at the held-out condition (compare_validations(), seed 1): the
# suspension's added-mass run, the dosing bed's condition B (another patient):
#   proposal  the top proposal added: a state term through the simulator
#             (simulate_*(term = testbed_term())), an output term
#             added to each run's curves; its strength a calibration input
#             over [0, 2 s] (s the proposal's strength, the range's ends
#             swapped when it is negative), 66 runs on a maximin design and
#             the model's own runs at strength 0
#   true      the hidden mechanism added, its strength over [0, 1.5] (the
#             lift-off's [0, 1]), the same design size
# Per case: the proposal, and for each model the held-out error of the model
# alone and bias-corrected over before's (ratio_*), and the verdict; `rel`
# the proposal's model-alone ratio over the true mechanism's (target <= 1.2).
#   Rscript studies/propose_loop.R [bed=suspension] [seeds=1] [hidden=all] [n_draws=150] [n_inner=20]
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
source("studies/propose_beds.R")
a <- study_args(list(bed = "suspension", seeds = "1", hidden = "all", n_draws = "150", n_inner = "20"))
susp <- a$bed == "suspension"
simulate_bed <- if (susp) simulate_suspension else simulate_dosing
options(wavevalid.quiet = TRUE, width = 250)
hidden <- if (a$hidden == "all") (if (susp) testbed_mechanisms() else dosing_mechanisms()) else arg_names(a$hidden)
sampler <- sampler_control(n_draws = as.integer(a$n_draws), n_inner = as.integer(a$n_inner), quiet = TRUE)

# Runs of the model with the term `fun` of `channel` at the strengths of the
# design's column s_term.
runs_with_term <- function(design, channel, fun) {
  if (channel %in% c("output", "d/dt output")) {
    base <- simulate_bed(design[setdiff(names(design), "s_term")])
    curves <- lapply(base$curves, function(Y) {
      X <- if (channel == "output") Y else t(apply(Y, 1, function(y) c(diff(y)[1], (y[-(1:2)] - y[1:(length(y) - 2)]) / 2,
                                                                       diff(y)[length(y) - 1]) / diff(base$t[1:2])))
      Y + design$s_term * matrix(fun(X), nrow(X))
    })
    return(model_runs(design, curves, base$t))
  }
  simulate_bed(design, term = testbed_term(channel, fun))
}

one <- function(hd, seed) {
  t0 <- clock()
  tb <- if (susp) testbed_suspension(seed = seed, hidden = hd) else testbed_dosing(seed = seed, hidden = hd)
  fit <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, chains = 1, seed = 1,
                                   sampler = sampler))
  z <- as.data.frame(as.list(coef(fit)))
  sim <- bed_simulator_at(a$bed, z)
  pr <- propose_terms(fit, suppressMessages(term_library(fit, states = bed_states_at(a$bed, z))), simulate = sim,
                      seed = 1)
  top <- pr[1, ]
  fun <- attr(pr, "funs")[[top$term]]
  ex <- if (susp) experiment(tb$added_mass$field, change = tb$added_mass$delta) else
    experiment(tb$B$field, change = tb$B$x_nom - tb$iu$nominal[match(names(tb$B$x_nom), tb$iu$name)])
  judge <- function(runs2, iu2) {
    fit2 <- suppressWarnings(update(fit, runs = runs2, iu = iu2))
    cmp <- suppressWarnings(compare_validations(fit, fit2, holdout = ex, seed = 1))
    get <- function(m) cmp$after[cmp$metric == m] / cmp$before[cmp$metric == m]
    c(model = get("holdout_rmse_model"), corrected = get("holdout_rmse"), verdict = attr(cmp, "verdict"))
  }
  off <- tb$A$runs$design
  with_off <- function(runs, name) {
    off[[name]] <- 0
    c(model_runs(off, tb$A$runs$curves, tb$A$runs$t), runs)
  }
  prop <- if (is.null(fun)) c(model = NA, corrected = NA, verdict = "a product: not added") else {
    ends <- sort(c(0, 2 * top$strength))
    iu_p <- iu_add(tb$iu, "s_term", lower = ends[1], upper = ends[2], nominal = mean(ends))
    judge(with_off(runs_with_term(design_maximin(iu_p, 66L, seed = 2), top$channel, fun), "s_term"), iu_p)
  }
  s_name <- paste0("s_", hd)
  up <- if (hd == "tire_liftoff") 1 else 1.5
  iu_t <- iu_add(tb$iu, s_name, lower = 0, upper = up, nominal = up / 2)
  runs_t <- with_off(simulate_bed(design_maximin(iu_t, 66L, seed = 2), mechanism = hd), s_name)
  true <- judge(runs_t, iu_t)
  data.frame(bed = a$bed, hidden = hd, seed = seed, proposal = top$term, inclusion = round(top$inclusion_prob, 2),
             ratio_model_proposal = round(as.numeric(prop[["model"]]), 3),
             ratio_corrected_proposal = round(as.numeric(prop[["corrected"]]), 3), verdict_proposal = prop[["verdict"]],
             ratio_model_true = round(as.numeric(true[["model"]]), 3),
             ratio_corrected_true = round(as.numeric(true[["corrected"]]), 3), verdict_true = true[["verdict"]],
             rel = round(as.numeric(prop[["model"]]) / as.numeric(true[["model"]]), 3), secs = round(clock() - t0))
}

rows <- list()
for (seed in arg_numbers(a$seeds)) for (hd in hidden) {
  r <- one(hd, seed)
  print(r, row.names = FALSE)
  rows[[length(rows) + 1L]] <- r
}
out <- do.call(rbind, rows)
cat("\n")
print(out, row.names = FALSE)
cat(sprintf("\nThe proposal's model-alone ratio within 1.2x the true mechanism's: %d of %d\n",
            sum(out$rel <= 1.2, na.rm = TRUE), nrow(out)))
