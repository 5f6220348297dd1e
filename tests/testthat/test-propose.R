# propose_terms(): a term planted in the field is proposed in its family,
# nothing is proposed without one, the simulated effect of a state term is
# its derivative, and the nuisance directions are never proposed.

propose_problem <- function(strength, seed = 1, windows = NULL) {
  t <- seq(0, 1, length.out = 128)
  model <- function(u, x) (1 + 0.5 * x) * sin(2 * pi * t) + u * exp(-((t - 0.6) / 0.08)^2)
  withr::with_seed(seed, {
    design <- data.frame(u1 = (0:29 + stats::runif(30)) / 30, x1 = (sample(30) - stats::runif(30)) / 30)
    runs <- model_runs(design, t(mapply(model, design$u1, design$x1)), t, site = "site1")
    truth <- model(0.4, 0.5)
    # the planted term: a hinge of the output above 0.8
    reality <- truth + strength * pmax(truth - 0.8, 0)
    reps <- t(replicate(3, reality + stats::rnorm(length(t), sd = 0.01)))
  })
  field <- field_runs(reps, t, x_nom = c(x1 = 0.5))
  iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), c(0, 0), c(1, 1), nominal = c(0.5, 0.5))
  suppressWarnings(validate(runs, field, iu, windows = windows, chains = 1, seed = 1,
                            sampler = sampler_control(n_draws = 60, n_inner = 10, quiet = TRUE)))
}

test_that("a planted hinge is proposed as a hinge, with its strength inside the interval; none without it", {
  fit_on <- propose_problem(2)
  pr <- propose_terms(fit_on, term_library(fit_on), n_draws = 40, seed = 1)
  expect_s3_class(pr, "wv_proposals")
  expect_identical(pr$family[1], "hinge_above")
  expect_identical(pr$channel[1], "output")
  expect_gt(pr$inclusion_prob[1], 0.9)
  expect_true(pr$strength_lower[1] < 2 && pr$strength_upper[1] > 1)
  expect_true(pr$from[1] <= 0.25 && pr$to[1] >= 0.25)
  expect_output(print(pr), "Proposed: hinge_above")

  fit_off <- propose_problem(0)
  pr0 <- propose_terms(fit_off, term_library(fit_off), n_draws = 40, seed = 1)
  expect_lt(pr0$inclusion_prob[1], 0.5)
  expect_gt(attr(pr0, "none"), 0.5)
  expect_output(print(pr0), "No term proposed")
})

test_that("a proposal becomes a candidate that explain_bias() weighs first", {
  fit <- propose_problem(2)
  pr <- propose_terms(fit, term_library(fit), n_draws = 40, seed = 1)
  cand <- proposed_candidates(pr, fit, n = 2)
  expect_named(cand, pr$term[1:2])
  ex <- explain_bias(fit, cand, positive = FALSE, n_draws = 20, seed = 1)
  expect_identical(ex$candidate[1], pr$term[1])
  expect_error(proposed_candidates(pr, example_fit()), class = "wavevalid_error_input")
})

test_that("a state term's simulated effect is the derivative of the output in its strength", {
  fit <- example_fit()
  t <- fit$basis$t
  state <- cos(2 * pi * t)
  lib <- term_library(fit, states = list(s = state), outputs = FALSE, products = FALSE)
  expect_true(all(lib$channels$kind == "state"))
  # a simulator whose output moves by strength * fun(state), then by its square
  lin <- function(channel, fun, strength) list(site1 = sin(2 * pi * t) + strength * fun(state))
  quad <- function(channel, fun, strength) list(site1 = sin(2 * pi * t) + strength * fun(state) + strength^2)
  X_dir <- wavevalid:::term_signatures(fit, lib, NULL)$X
  X_lin <- wavevalid:::term_signatures(fit, lib, lin)$X
  X_quad <- wavevalid:::term_signatures(fit, lib, quad)$X
  expect_equal(X_lin, X_dir, tolerance = 1e-8)
  # the central difference removes the strength's square exactly
  expect_equal(X_quad, X_dir, tolerance = 1e-8)
  # a term whose simulation fails is left out, with a message
  flaky <- function(channel, fun, strength) {
    if (identical(fun, lib$funs[[2]])) stop("the solver failed")
    lin(channel, fun, strength)
  }
  expect_message(sig <- wavevalid:::term_signatures(fit, lib, flaky), "failed or was not finite")
  expect_identical(sig$keep, seq_along(lib$funs) != 2L)
  expect_equal(sig$X, X_dir[, -2], tolerance = 1e-8)
  bad <- function(channel, fun, strength) list(other = t)
  expect_error(propose_terms(fit, lib, simulate = bad, n_draws = 5), class = "wavevalid_error_input")
})

test_that("terms the parameter shifts or the registration's error span are never proposed", {
  fit <- example_fit()
  N <- wavevalid:::proposal_nuisance(fit, FALSE)$X
  expect_identical(ncol(N), 3L)  # shift:u1, shift:x1 and the offset of site1
  X <- cbind(inside = drop(N %*% c(2, -1, 0.5)), outside = withr::with_seed(1, rnorm(nrow(N))))
  expect_identical(unname(wavevalid:::outside_span(X, N, rep(1, nrow(N)))), c(FALSE, TRUE))
  # a registered field: a shift and a blur direction at each knot of the
  # warps, random, not fixed: a hinge of the output stays a term
  fit_r <- propose_problem(0, windows = list(c(0.15, 0.35), c(0.65, 0.85)))
  nu <- wavevalid:::proposal_nuisance(fit_r, TRUE)
  expect_identical(ncol(nu$X), 3L)
  expect_identical(ncol(nu$R), length(nu$kind))
  expect_setequal(unique(nu$kind), c("shift", "blur"))
  expect_identical(sum(nu$kind == "shift"), nu$knots)
  lib <- term_library(fit_r)
  X <- wavevalid:::term_signatures(fit_r, lib, NULL)$X
  ok <- wavevalid:::outside_span(X, nu$X, rep(1, nrow(X)))
  expect_true(all(ok[lib$terms$family == "hinge_above"]))
  pr <- propose_terms(fit_r, lib, n_draws = 10, seed = 1)
  expect_match(attr(pr, "nuisance")[3], "registration's error at its [0-9]+ warp knots")
  # abs(y - c) = 2 (y - c)_+ - (y - c): with the output's scale a shift of x1
  # and the offset in every model, the two are one effect, kept once
  eq <- wavevalid:::equivalent_terms(X[, c("hinge_above(output; c = 0, k = 1)", "abs(output; c = 0)")], nu$X,
                                     rep(1, nrow(X)))
  expect_identical(unname(eq), c(NA, "hinge_above(output; c = 0, k = 1)"))
})

test_that("propose_terms() refuses bad input before any work", {
  fit <- example_fit()
  lib <- term_library(fit)
  expect_error(propose_terms(fit, list()), class = "wavevalid_error_input")
  expect_error(propose_terms(fit, lib, max_size = 3), class = "wavevalid_error_input")
  expect_error(propose_terms(fit, lib, simulate = 1), class = "wavevalid_error_input")
  other <- propose_problem(0)
  expect_error(propose_terms(other, lib), "another fit", class = "wavevalid_error_input")
  expect_error(term_library(fit, states = list(1:3)), class = "wavevalid_error_input")
  expect_error(term_library(fit, outputs = FALSE), class = "wavevalid_error_input")
})

test_that("the registration error's sizes are recovered by restricted maximum likelihood", {
  withr::local_seed(3)
  n <- 600
  w <- stats::runif(n, 0.5, 2)
  F <- cbind(1, seq_len(n) / n)
  R <- matrix(stats::rnorm(n * 60), n, 60)
  kind <- rep(c("shift", "blur"), each = 30)
  lam <- c(shift = 4, blur = 0.25)
  est <- replicate(20, {
    Rs <- sweep(R, 2L, sqrt(colSums(R^2 * w)), `/`)
    y <- drop(F %*% c(1, -2) + Rs %*% stats::rnorm(60, sd = sqrt(lam[kind])) + stats::rnorm(n, sd = 1 / sqrt(w)))
    wavevalid:::registration_scale(y, w, F, R, kind)$by_kind[c("shift", "blur")]
  })
  # the median over 20 data sets within 30% of the truth, each kind
  med <- apply(est, 1, stats::median)
  expect_equal(unname(med), unname(lam), tolerance = 0.3)
  # and the shift's variance told from none: its 10% quantile above 1
  expect_gt(stats::quantile(est["shift", ], 0.1), 1)
})
