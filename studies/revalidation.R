# Which mechanism is missing, told by re-validating the model with each
# candidate mechanism instead of regressing the bias on fixed signature
# curves. For each case (hidden mechanism, seed) the model without any
# mechanism is validated on condition A as the diagnosis tests validate it
# (testbed_validation(): 66 runs, 150 x 20 draws, one chain); for each
# test-bed mechanism m, the model with m (its strength s_m a calibration input
# on [0, 1]) is simulated at a 66-point maximin design, its emulators fitted
# on the same basis and calibrated on the same registered field data
# (testbed_revalidation()). Chosen by `measure` (comma-separated):
#   candidates  explain_bias(base, fits), each fit weighed by its
#               Savage-Dickey Bayes factor against itself with s_m = 0: the
#               leading candidate, the inclusion probability of the hidden
#               one, the largest of the others, the probability of "(none)",
#               the log Bayes factors;
#   nested      each model scored by the largest log posterior over its
#               inputs with every tau2 at its mode under its prior 1 / (tau2 +
#               c_j) and sigma2 at the base fit's posterior median: lp_free
#               with s_m free, lp_off with s_m fixed at 0 (the same emulators,
#               the mechanism switched off); nested = lp_free - lp_off is free
#               of the differences between emulators fitted to different
#               designs, lp_free alone is not. Also the posterior mean strength
#               and the rms posterior mean bias.
#   Rscript studies/revalidation.R [measure=candidates] [cases=digressive_damper:3] [n_draws=150] [n_inner=20]
# cases: hidden:seed, comma-separated (all: every mechanism and none at seeds 1-5).
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
opt <- study_args(list(measure = "candidates", cases = "digressive_damper:3", n_draws = "150", n_inner = "20"))
measure <- arg_names(opt$measure)
stopifnot(all(measure %in% c("candidates", "nested")))
cases <- if (opt$cases == "all") {
  arg_cases("", paste(c("none", testbed_mechanisms()), collapse = ","), "1:5")
} else {
  arg_cases(opt$cases, "", "")
}
n_draws <- as.integer(opt$n_draws)
n_inner <- as.integer(opt$n_inner)
options(wavevalid.quiet = TRUE)

# Log posterior of `fit` at inputs z (the emulators' units), every tau2 at its
# mode under its prior, the field variances `sigma2` (by site).
log_post <- function(fit, z, sigma2) {
  tot <- 0
  for (s in names(fit$wb)) {
    pr <- predict(fit$emulators, matrix(z, 1, dimnames = list(NULL, fit$inputs)), site = s)
    e <- fit$wbar[[s]] - pr$mean[1, ]
    S <- pr$var[1, ] + sigma2[[s]] / fit$n_rep[[s]]
    g <- fit$bias_group[[s]]
    for (j in unique(g)) {
      i <- g == j
      cj <- mean(sigma2[[s]][i] / fit$n_rep[[s]])
      f <- function(lt) sum(stats::dnorm(e[i], 0, sqrt(S[i] + exp(lt)), log = TRUE)) - log(exp(lt) + cj) + lt
      tot <- tot + stats::optimize(f, c(log(cj) - 30, log(max(e[i]^2) + cj) + 5), maximum = TRUE)$objective
    }
  }
  p <- fit$prior_iu[match(fit$inputs, fit$prior_iu$name), ]
  v <- p$type == "variation"
  tot + sum(stats::dnorm(z[v], p$nominal[v], p$prior_sd[v], log = TRUE))
}
# Largest log posterior from six starts among the draws `D` (columns named),
# the inputs in `fixed` held at their values.
best <- function(fit, D, sigma2, fixed = NULL) {
  p <- fit$prior_iu[match(fit$inputs, fit$prior_iu$name), ]
  free <- setdiff(fit$inputs, names(fixed))
  k <- match(free, p$name)
  lo <- ifelse(p$type[k] == "calibration", p$lower[k], -Inf)
  hi <- ifelse(p$type[k] == "calibration", p$upper[k], Inf)
  full <- function(x) c(stats::setNames(x, free), fixed)[fit$inputs]
  starts <- D[unique(round(seq(1, nrow(D), length.out = 6))), free, drop = FALSE]
  res <- lapply(seq_len(nrow(starts)), function(r) {
    stats::optim(pmin(pmax(starts[r, ], lo), hi), function(x) -log_post(fit, full(x), sigma2),
                 method = "L-BFGS-B", lower = lo, upper = hi, control = list(maxit = 200))
  })
  -min(vapply(res, `[[`, 0, "value"))
}
bias_rms <- function(fit) sqrt(mean(bias(fit)$mean^2))

nested_table <- function(base, fits) {
  sigma2 <- lapply(base$sigma2, function(m) apply(m, 2, stats::median))
  D0 <- as.matrix(base$draws)
  rows <- list(data.frame(model = "none", lp_free = best(base, D0, sigma2), lp_off = NA, s_mean = NA,
                          bias_rms = bias_rms(base)))
  for (m in names(fits)) {
    fit_m <- fits[[m]]
    s_name <- paste0("s_", m)
    Dm <- as.matrix(fit_m$draws)
    D0m <- cbind(D0[, base$inputs], stats::setNames(rep(0, nrow(D0)), s_name))
    colnames(D0m)[ncol(D0m)] <- s_name
    rows[[m]] <- data.frame(model = m, lp_free = best(fit_m, rbind(Dm[, fit_m$inputs], D0m[, fit_m$inputs]), sigma2),
                            lp_off = best(fit_m, D0m, sigma2, fixed = stats::setNames(0, s_name)),
                            s_mean = mean(Dm[, s_name]), bias_rms = bias_rms(fit_m))
  }
  res <- do.call(rbind, rows)
  res$nested <- res$lp_free - res$lp_off
  rownames(res) <- NULL
  res
}

out <- NULL
for (i in seq_len(nrow(cases))) {
  hidden <- cases$hidden[i]
  seed <- cases$seed[i]
  t0 <- clock()
  v <- testbed_validation(hidden, seed, n_draws = n_draws, n_inner = n_inner)
  base <- v$fit
  fits <- testbed_revalidation(v$tb, base, n_draws = n_draws, n_inner = n_inner)
  if ("candidates" %in% measure) {
    ex <- explain_bias(base, fits)
    lbf <- attr(ex, "log_bf")
    sub <- attr(ex, "subsets")
    row <- data.frame(hidden = hidden, seed = seed, first = ex$candidate[1],
                      p_hidden = if (hidden == "none") NA else ex$inclusion_prob[ex$candidate == hidden],
                      p_other = max(ex$inclusion_prob[ex$candidate != hidden]),
                      p_none = sub$probability[sub$subset == "(none)"],
                      log_bf = paste(sprintf("%s %.1f", names(lbf), lbf), collapse = ", "),
                      seconds = round(clock() - t0))
    print(row, digits = 3, row.names = FALSE)
    out <- rbind(out, row)
  }
  if ("nested" %in% measure) {
    cat(sprintf("\nhidden %s, seed %d: the model with each mechanism re-validated\n", hidden, seed))
    print(nested_table(base, fits), digits = 4)
  }
}
if (!is.null(out)) {
  cat("\n")
  print(out, digits = 3, row.names = FALSE)
}
