# The README's paragraph on the demo, written from the demo's own results:
# runs the loop of inst/scripts/demo.R on the shipped test bed (validate,
# where_fails, explain_bias, the leading effect added, update(),
# compare_validations() at the added-mass run) and the same ratios against
# the test bed's noise-free reality, and replaces the text between the
# markers <!-- demo:start --> and <!-- demo:end --> of README.md. Run from
# the package's root against the installed package (`make readme`).
suppressPackageStartupMessages(library(wavevalid))
options(wavevalid.quiet = TRUE)
f2 <- function(v) format(round(v, 2), nsmall = 2)
f3 <- function(v) format(signif(v, 3))

tb <- load_testbed()
fit <- validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, chains = 2, seed = 1,
                sampler = sampler_control(n_draws = 500, n_inner = 100, quiet = TRUE))
fails <- where_fails(fit)
expl <- explain_bias(fit, testbed_signatures(colMeans(as.matrix(fit$draws))[fit$inputs]), seed = 1)
lead <- as.character(expl$candidate[1])
s_name <- paste0("s_", lead)
iu_m <- iu_add(tb$iu, s_name, lower = 0, upper = 1, nominal = 0.5)
off <- tb$A$runs$design
off[[s_name]] <- 0
runs_m <- c(model_runs(off, tb$A$runs$curves, tb$A$runs$t),
            simulate_suspension(design_maximin(iu_m, 66L, seed = 2), mechanism = lead))
fit_m <- update(fit, runs = runs_m, iu = iu_m)
fails_m <- where_fails(fit_m)
cmp <- compare_validations(fit, fit_m, holdout = experiment(tb$added_mass$field, change = tb$added_mass$delta),
                           seed = 1)

# against noise-free reality at the added-mass run
truth <- tb$truth$reality_added_mass
pr <- attr(cmp, "holdout_predictions")
rmse_to <- function(S, cur, col) {
  sqrt(mean(unlist(lapply(names(cur), function(s) (S[S$site == s, col] - as.vector(cur[[s]]))^2))))
}
truth_model <- rmse_to(pr$after, truth, "model") / rmse_to(pr$before, truth, "model")
truth_corrected <- rmse_to(pr$after, truth, "mean") / rmse_to(pr$before, truth, "mean")
fld <- attr(cmp, "holdout_field")$before
graded <- function(curves) {
  sqrt(mean(unlist(lapply(names(truth), function(s) sweep(fld$curves[[s]], 2, as.vector(curves[[s]]))^2))))
}
before_model <- lapply(stats::setNames(names(truth), names(truth)), function(s) pr$before[pr$before$site == s, "model"])
reality_graded <- graded(truth) / graded(before_model)

first <- fails[1, ]
cf <- attr(fails, "conflicts")
cf <- cf[cf$conflict, , drop = FALSE]
X <- as.matrix(fit$draws)
conflict_text <- if (nrow(cf)) {
  q <- stats::quantile(X[, cf$input[1]], c(0.05, 0.95), names = FALSE)
  sprintf("the input `%s` is in conflict with its prior (%s [%s, %s], %s prior sd from its mean)", cf$input[1],
          f2(cf$median[1]), f2(q[1]), f2(q[2]), format(round(abs(cf$prior_sds[1]), 1), nsmall = 1))
} else {
  "no input is in conflict with its prior"
}
m <- stats::setNames(cmp$before, cmp$metric)
ma <- stats::setNames(cmp$after, cmp$metric)
hr <- attr(cmp, "holdout_ratio")
paragraph <- c(
  sprintf("Where the model fails, ranked by size (hidden mechanism: %s). %s.", paste(tb$truth$hidden, collapse = ", "),
          top_finding(fails)),
  sprintf("Among the other findings, %s. `explain_bias()` puts %s first (inclusion probability %s).", conflict_text,
          lead, f2(expl$inclusion_prob[1])),
  sprintf("With it added and the model validated again (`update()`, against the same registered field): %s;",
          sub("^No finding", "no finding", sub("^Top finding \\(1 of [0-9]+\\), ", "", top_finding(fails_m)))),
  sprintf("the pure model's error on the fitted data goes from %s to %s. At the held-out added-mass run, one field curve, the model alone errs %s [%s, %s] times as much as before and the bias-corrected prediction %s [%s, %s]: \"%s\".",
          f3(m[["model_rmse"]]), f3(ma[["model_rmse"]]), f2(hr$ratio[1]), f2(hr$lower[1]), f2(hr$upper[1]),
          f2(hr$ratio[2]), f2(hr$lower[2]), f2(hr$upper[2]), attr(cmp, "verdict")),
  sprintf("Against the test bed's noise-free reality the ratios are %s (model alone) and %s (bias-corrected), and reality itself is graded %s times the unfixed model's error against the registered held-out curve: what one registered curve can tell is limited by the registration's own error at the events (`studies/README.md`, \"yardstick.R\").",
          f2(truth_model), f2(truth_corrected), f2(reality_graded)),
  "(Written by `make readme` from the demo's results.)"
)
wrapped <- strwrap(paste(paragraph, collapse = " "), width = 78)
readme <- readLines("README.md", warn = FALSE)
start <- grep("<!-- demo:start -->", readme, fixed = TRUE)
end <- grep("<!-- demo:end -->", readme, fixed = TRUE)
if (length(start) != 1L || length(end) != 1L || end <= start) stop("README.md lacks the demo markers")
writeLines(c(readme[seq_len(start)], wrapped, readme[end:length(readme)]), "README.md")
cat(wrapped, sep = "\n")
