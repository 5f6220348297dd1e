# An effect that an input with a flat prior takes up: does propose_terms()
# name it where where_fails() finds nothing? A sine of eight peaks; the
# model's calibration input u1 (flat on [-1, 1]) adds a bump at each peak
# (much like the missing effect), x1 a slow cosine; reality has, besides, a
# cap at each peak (the part of the sine above 0.6, centred: no offset of
# the record), of strength s. 30 runs, 3 replicates of noise sd 0.15, one
# chain of 200 x 20 (seed 1); propose_terms() on term_library(fit) with its
# defaults. Per strength: u1's posterior mean, where_fails()'s findings and
# the top proposal.
#   Rscript studies/propose_absorbed.R [strengths=0,1,2,3] [sd=0.15]
suppressPackageStartupMessages(library(wavevalid))
source("studies/args.R")
a <- study_args(list(strengths = "0,1,2,3", sd = "0.15"))
options(wavevalid.quiet = TRUE)
t <- seq(0, 1, length.out = 256)
base <- sin(2 * pi * 8 * t)
cap <- pmax(base - 0.6, 0)
cap <- cap - mean(cap)
a_t <- exp(-((base - 1) / 0.35)^2)
a_t <- a_t - mean(a_t)
b_t <- cos(2 * pi * t)
model <- function(u, x) base + u * a_t + 0.3 * x * b_t
for (s in arg_numbers(a$strengths)) {
  withr::with_seed(1, {
    design <- data.frame(u1 = -1 + 2 * (0:29 + stats::runif(30)) / 30, x1 = (sample(30) - stats::runif(30)) / 30)
    runs <- model_runs(design, t(mapply(model, design$u1, design$x1)), t, site = "site1")
    reality <- model(0, 0.5) + s * cap
    reps <- t(replicate(3, reality + stats::rnorm(length(t), sd = as.numeric(a$sd))))
  })
  field <- field_runs(reps, t, x_nom = c(x1 = 0.5))
  iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), c(-1, 0), c(1, 1), nominal = c(0, 0.5))
  fit <- suppressWarnings(validate(runs, field, iu, chains = 1, seed = 1,
                                   sampler = sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE)))
  pr <- propose_terms(fit, term_library(fit), seed = 1)
  wf <- where_fails(fit)
  cat(sprintf("strength %g: u1 %.2f | where_fails(): %s | top proposal %s at %.2f\n", s, coef(fit)[["u1"]],
              if (nrow(wf)) paste(table(wf$kind), names(table(wf$kind)), collapse = ", ") else "nothing",
              pr$term[1], pr$inclusion_prob[1]))
}
