# propose_terms(): a term planted in the field is proposed in its family,
# nothing is proposed without one, the simulated effect of a state term is
# its derivative, and the nuisance directions are never proposed.

# The planted term: strength * (output - c)_+, c = 0.8 or, with `q`, the
# quantile q of the true output (a threshold the term library holds).
propose_problem <- function(strength, seed = 1, windows = NULL, q = NULL) {
  t <- seq(0, 1, length.out = 128)
  model <- function(u, x) (1 + 0.5 * x) * sin(2 * pi * t) + u * exp(-((t - 0.6) / 0.08)^2)
  withr::with_seed(seed, {
    design <- data.frame(u1 = (0:29 + stats::runif(30)) / 30, x1 = (sample(30) - stats::runif(30)) / 30)
    runs <- model_runs(design, t(mapply(model, design$u1, design$x1)), t, site = "site1")
    truth <- model(0.4, 0.5)
    threshold <- if (is.null(q)) 0.8 else stats::quantile(truth, q, names = FALSE)
    reality <- truth + strength * pmax(truth - threshold, 0)
    reps <- t(replicate(3, reality + stats::rnorm(length(t), sd = 0.01)))
  })
  field <- field_runs(reps, t, x_nom = c(x1 = 0.5))
  iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), c(0, 0), c(1, 1), nominal = c(0.5, 0.5))
  suppressWarnings(validate(runs, field, iu, windows = windows, chains = 1, seed = 1,
                            sampler = sampler_control(n_draws = 60, n_inner = 10, quiet = TRUE)))
}

test_that("a planted hinge the library holds is proposed as that hinge, its strength inside the interval; none without it", {
  # planted: 0.5 (output - c)_+ with c the 0.9 quantile of the true output, which is a version of the
  # library's hinge_above family (its thresholds are quantiles of the output at the calibrated inputs)
  fit_lib <- propose_problem(0.5, q = 0.9)
  lib <- term_library(fit_lib)
  pr <- propose_terms(fit_lib, lib, n_draws = 40, seed = 1)
  expect_s3_class(pr, "wv_proposals")
  expect_identical(pr$family[1], "hinge_above")
  expect_identical(pr$channel[1], "output")
  expect_gt(pr$inclusion_prob[1], 0.9)
  expect_lt(pr$inclusion_prob[2], 0.5)
  # the version: linear (k = 1), at the library's 0.9 quantile of the output
  out <- lib$channels$curves$output$site1
  expect_identical(pr$term[1], sprintf("hinge_above(output; c = %s, k = 1)",
                                       format(signif(stats::quantile(out, 0.9, names = FALSE), 3))))
  expect_true(pr$strength_lower[1] <= 0.5 && pr$strength_upper[1] >= 0.5,
              label = sprintf("[%.3f, %.3f]", pr$strength_lower[1], pr$strength_upper[1]))
  expect_lt(pr$strength_upper[1] - pr$strength_lower[1], 0.5)
  expect_output(print(pr), "Proposed: hinge_above(output; c = ", fixed = TRUE)

  # planted 2 (output - 0.8)_+: no library version (the thresholds are quantiles) and the variation
  # input x1, which scales the output's amplitude, absorbs part of it. A hinge above the output is
  # proposed, where it acts, but its strength is not the planted one: the interval lies below 2
  fit_on <- propose_problem(2)
  pr2 <- propose_terms(fit_on, term_library(fit_on), n_draws = 40, seed = 1)
  expect_identical(pr2$family[1], "hinge_above")
  expect_identical(pr2$channel[1], "output")
  expect_gt(pr2$inclusion_prob[1], 0.9)
  expect_lt(pr2$strength_upper[1], 2)
  expect_true(pr2$from[1] <= 0.25 && pr2$to[1] >= 0.25)
  expect_gt(stats::coef(fit_on)[["x1"]], 0.6)

  fit_off <- propose_problem(0)
  pr0 <- propose_terms(fit_off, term_library(fit_off), n_draws = 40, seed = 1)
  expect_lt(pr0$inclusion_prob[1], 0.5)
  expect_gt(attr(pr0, "none"), 0.5)
  expect_output(print(pr0), "No term proposed")
})

test_that("the term library prints its terms, families and channels", {
  fit <- propose_problem(0.5, q = 0.9)
  lib <- term_library(fit)
  out <- capture.output(print(lib))
  fam <- table(factor(lib$terms$family, levels = unique(lib$terms$family)))
  expect_identical(out[1], sprintf("<wv_term_library> %d terms in %d families of 2 channels", nrow(lib$terms),
                                   length(unique(lib$terms$effect))))
  expect_identical(out[2], "Channels: output (output), d/dt output (output)")
  expect_identical(out[3], paste0("Families: ", paste(names(fam), as.integer(fam), collapse = ", ")))
  # three powers and one linear term per channel; the output's three filters, three delays and integral;
  # the product of the two channels and the output's filters and integral times the output
  expect_match(out[3], "^Families: linear 2, power 6, ")
  expect_match(out[3], ", filter 3, delay 3, integral 1, product 5$")
  # a state channel is named as such; without products there is no product family
  st <- term_library(fit, states = list(s = cos(2 * pi * fit$basis$t)), outputs = FALSE, products = FALSE)
  out_st <- capture.output(print(st))
  expect_match(out_st[1], " of 1 channels$")
  expect_identical(out_st[2], "Channels: s (state)")
  expect_no_match(out_st[3], "product")
})

test_that("autoplot() of proposals draws the posterior mean bias and each leading term's effect", {
  fit <- propose_problem(0.5, q = 0.9)
  pr <- propose_terms(fit, term_library(fit), n_draws = 40, seed = 1)
  cur <- attr(pr, "curves")
  p <- autoplot(pr)
  b <- ggplot2::ggplot_build(p)
  expect_identical(vapply(p$layers, function(l) class(l$geom)[1], ""), "GeomLine")
  expect_identical(nrow(b$data[[1]]), nrow(cur))
  expect_identical(p$labels$title, "Posterior mean bias and the leading proposed terms")
  expect_identical(p$labels$y, "bias")
  # one line per curve: the bias and the leading term at its strength
  curves <- unique(as.character(cur$curve))
  expect_identical(length(unique(b$data[[1]]$group)), length(curves))
  expect_true("posterior mean bias" %in% curves)
  lead <- curves[startsWith(curves, pr$term[1])]
  expect_length(lead, 1L)
  expect_match(lead, sprintf("x %s$", format(signif(pr$strength[1], 3))))
  # the lead term's line is its effect at its strength, and follows the bias
  sig <- drop(fit$basis$Psi %*% attr(pr, "signatures")[, pr$term[1]])
  bias <- cur$value[cur$curve == "posterior mean bias"]
  eff <- cur$value[cur$curve == lead]
  expect_equal(eff, pr$strength[1] * sig)
  expect_gt(stats::cor(bias, eff), 0.8)
  expect_equal(sort(unique(b$data[[1]]$y)), sort(unique(cur$value)))
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
  X_dir <- term_signatures(fit, lib, NULL)$X
  X_lin <- term_signatures(fit, lib, lin)$X
  X_quad <- term_signatures(fit, lib, quad)$X
  expect_equal(X_lin, X_dir, tolerance = 1e-8)
  # the central difference removes the strength's square exactly
  expect_equal(X_quad, X_dir, tolerance = 1e-8)
  # a term whose simulation fails is left out, with a message
  flaky <- function(channel, fun, strength) {
    if (identical(fun, lib$funs[[2]])) stop("the solver failed")
    lin(channel, fun, strength)
  }
  expect_message(sig <- term_signatures(fit, lib, flaky), "failed or was not finite")
  expect_identical(sig$keep, seq_along(lib$funs) != 2L)
  expect_equal(sig$X, X_dir[, -2], tolerance = 1e-8)
  bad <- function(channel, fun, strength) list(other = t)
  expect_error(propose_terms(fit, lib, simulate = bad, n_draws = 5), class = "wavevalid_error_input")
})

test_that("terms the parameter shifts or the registration's error span are never proposed", {
  fit <- example_fit()
  N <- proposal_nuisance(fit, FALSE)$X
  expect_identical(ncol(N), 3L)  # shift:u1, shift:x1 and the offset of site1
  X <- cbind(inside = drop(N %*% c(2, -1, 0.5)), outside = withr::with_seed(1, rnorm(nrow(N))))
  expect_identical(unname(outside_span(X, N, rep(1, nrow(N)))), c(FALSE, TRUE))
  # a registered field: a shift and a blur direction at each knot of the
  # warps, random, not fixed: a hinge of the output stays a term
  fit_r <- propose_problem(0, windows = list(c(0.15, 0.35), c(0.65, 0.85)))
  nu <- proposal_nuisance(fit_r, TRUE)
  expect_identical(ncol(nu$X), 3L)
  expect_identical(ncol(nu$R), length(nu$kind))
  expect_setequal(unique(nu$kind), c("shift", "blur"))
  expect_identical(sum(nu$kind == "shift"), nu$knots)
  lib <- term_library(fit_r)
  X <- term_signatures(fit_r, lib, NULL)$X
  ok <- outside_span(X, nu$X, rep(1, nrow(X)))
  expect_true(all(ok[lib$terms$family == "hinge_above"]))
  pr <- propose_terms(fit_r, lib, n_draws = 10, seed = 1)
  expect_match(attr(pr, "nuisance")[3], "registration's error at its [0-9]+ warp knots")
  # abs(y - c) = 2 (y - c)_+ - (y - c): with the output's scale a shift of x1
  # and the offset in every model, the two are one effect, kept once
  eq <- equivalent_terms(X[, c("hinge_above(output; c = 0, k = 1)", "abs(output; c = 0)")], nu$X,
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
    registration_scale(y, w, F, R, kind)$by_kind[c("shift", "blur")]
  })
  # the median over 20 data sets within 30% of the truth, each kind
  med <- apply(est, 1, stats::median)
  expect_equal(unname(med), unname(lam), tolerance = 0.3)
  # and the shift's variance told from none: its 10% quantile above 1
  expect_gt(stats::quantile(est["shift", ], 0.1), 1)
})

test_that("add_term() adds the top proposal as a calibrated strength and validates again", {
  fit <- propose_problem(0.5, q = 0.9)
  pr <- propose_terms(fit, term_library(fit), n_draws = 40, seed = 1)
  expect_message(fit2 <- add_term(fit, pr), "s_term", class = "wavevalid_message")
  added <- attr(fit2, "added_term")
  expect_identical(added$term, pr$term[1])
  expect_false(added$simulated)
  expect_equal(added$range, sort(c(0, 2 * pr$strength[1])))
  expect_true("s_term" %in% fit2$inputs)
  # the term is off at 0, whichever bound of the range that is
  expect_identical(attr(fit2$iu, "off"), c(s_term = 0))
  # the model's own runs joined with the strength at 0, and as many with the term on their output
  expect_identical(nrow(fit2$pipeline$runs$design), 2L * nrow(fit$pipeline$runs$design))
  # the planted strength 0.5 is inside the strength's posterior interval, and the bias falls
  s <- as.matrix(fit2$draws)[, "s_term"]
  expect_true(stats::quantile(s, 0.025) <= 0.5 && stats::quantile(s, 0.975) >= 0.5,
              label = paste(signif(stats::quantile(s, c(0.025, 0.975)), 3), collapse = " to "))
  rms <- function(f) sqrt(mean(bias(f)$mean^2))
  expect_lt(rms(fit2), 0.5 * rms(fit))
  # a simulator hook gets the design over the inputs and the strength, the channel and the function
  seen <- NULL
  hook <- function(design, channel, fun) {
    seen <<- list(names = names(design), channel = channel, n = nrow(design))
    Y <- fit$pipeline$runs$curves$site1[seq_len(nrow(design)), ]
    model_runs(design, Y + design$s_term * matrix(fun(Y), nrow(Y)), fit$pipeline$runs$t)
  }
  fit3 <- suppressWarnings(suppressMessages(add_term(fit, pr, simulate = hook, n_runs = 12)))
  expect_identical(seen, list(names = c(fit$inputs, "s_term"), channel = pr$channel[1], n = 12L))
  expect_true(attr(fit3, "added_term")$simulated)
})

test_that("add_term() refuses what it cannot add before any work", {
  fit <- propose_problem(0.5, q = 0.9)
  pr <- propose_terms(fit, term_library(fit), n_draws = 40, seed = 1)
  expect_error(add_term(fit, pr, which = nrow(pr) + 1), class = "wavevalid_error_input")
  expect_error(add_term(fit, pr, simulate = 1), class = "wavevalid_error_input")
  expect_error(add_term(fit, data.frame()), class = "wavevalid_error_input")
  state <- pr
  state$channel[1] <- "compression"
  expect_error(add_term(fit, state), "simulate", class = "wavevalid_error_input")
  product <- pr
  attr(product, "funs")[pr$term[1]] <- list(NULL)
  expect_error(add_term(fit, product), "product", class = "wavevalid_error_input")
  expect_error(add_term(example_fit(), pr), "validate", class = "wavevalid_error_update")
})
