# Chains run together (sampler_control(together = TRUE)): one process, a
# thread per chain, each emulator bank evaluated at every chain's inputs at
# once. The draws must be those of the chains run apart, to the bit: with
# one site and with an experiment (sites sharing a bank), with two and three
# chains, and over the stopping rule's rounds (chains continued from their
# state, their walks re-learned).

expect_same_fit <- function(a, b) {
  drop <- c("sampling_seconds", "control", "timing")
  a <- unclass(a)
  b <- unclass(b)
  expect_identical(a[setdiff(names(a), drop)], b[setdiff(names(b), drop)])
}

# The number of calls of the team's sampler while `expr` runs.
team_calls <- function(expr) {
  n <- 0L
  ns <- asNamespace("wavevalid")
  suppressMessages(trace("calibrate_team_cpp", tracer = function() n <<- n + 1L, where = ns, print = FALSE))
  on.exit(suppressMessages(untrace("calibrate_team_cpp", where = ns)))
  force(expr)
  n
}

team_fit <- function(together, ex, chains = 2, experiments = NULL, ...) {
  suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, seed = 5, experiments = experiments,
                             sampler = sampler_control(n_inner = 5, burnin = 200, n_search = 10, quiet = TRUE,
                                                       chains = chains, together = together, ...)))
}

test_that("chains run together draw what they draw apart", {
  ex <- example_problem(1)
  expect_identical(team_calls(apart <- team_fit(FALSE, ex, n_draws = 40)), 0L)
  expect_identical(team_calls(together <- team_fit(TRUE, ex, n_draws = 40)), 1L)
  expect_same_fit(apart, together)
  # three chains: a batch of three requests
  expect_same_fit(team_fit(FALSE, ex, chains = 3, n_draws = 30), team_fit(TRUE, ex, chains = 3, n_draws = 30))
  # an experiment: its site and the base site evaluate one bank, for every chain at once
  field2 <- ex$field
  field2$curves$site1 <- field2$curves$site1[1:2, , drop = FALSE]
  exps <- list(loaded = experiment(field2, change = c(x1 = 0.1)))
  expect_same_fit(team_fit(FALSE, ex, experiments = exps, n_draws = 30),
                  team_fit(TRUE, ex, experiments = exps, n_draws = 30))
  # the stopping rule's rounds: every chain continued from its state
  a <- team_fit(FALSE, ex, ess = 300, max_draws = 200)
  rounds <- team_calls(b <- team_fit(TRUE, ex, ess = 300, max_draws = 200))
  expect_gt(fit_get(a, "stopping")$rounds, 1L)
  expect_identical(rounds, fit_get(b, "stopping")$rounds)
  expect_same_fit(a, b)
})

test_that("the chains run together where each has a core, and apart where asked or sent away", {
  withr::local_options(wavevalid.workers = "auto")
  expect_false(chains_together(NULL, 1L, 4L))
  expect_false(chains_together(TRUE, 1L, 4L))
  expect_true(chains_together(TRUE, 2L, 1L))
  expect_false(chains_together(FALSE, 2L, 4L))
  withr::with_options(list(future.plan = NULL), {
    old <- future::plan(future::sequential)
    on.exit(future::plan(old), add = TRUE)
    expect_true(chains_together(NULL, 2L, 2L))
    expect_false(chains_together(NULL, 3L, 2L))
    withr::with_options(list(wavevalid.workers = 1), expect_false(chains_together(NULL, 2L, 4L)))
  })
  expect_error(sampler_control(together = NA), class = "wavevalid_error_input")
})

test_that("a chain that fails stops its team, and its own error is the one reported", {
  withr::local_seed(3)
  s <- sbc_setup(3L, NULL)
  W <- matrix(stats::rnorm(3L * s$n, 0, 0.3), 3L, s$n)
  spec <- s$spec
  spec$sites$site1$wbar <- colMeans(W)
  spec$sites$site1$s2 <- colSums(sweep(W, 2L, colMeans(W))^2)
  set <- function(chain, resume = NULL) {
    list(n_groups = s$G, z_init = 0.5, tau2_init = numeric(0), fix_tau2 = FALSE, n_draws = 20L, n_inner = 5L,
         step = 0.3, seed = 7, chain = chain, adaptive = TRUE, burnin = 100L, n_search = 5L, resume = resume)
  }
  one <- calibrate_chain_cpp(spec$sites, spec$priors, set(1L))
  both <- calibrate_team_cpp(spec$sites, spec$priors, list(set(1L), set(2L)))
  expect_identical(both[[1]]$inputs, one$inputs)
  expect_identical(both[[2]]$inputs, calibrate_chain_cpp(spec$sites, spec$priors, set(2L))$inputs)
  bad <- one$state
  bad$z <- c(bad$z, 0.1)
  # the failing chain second, then first: the other chain stops at its next prediction
  expect_error(calibrate_team_cpp(spec$sites, spec$priors, list(set(1L), set(2L, bad))), "state does not match")
  expect_error(calibrate_team_cpp(spec$sites, spec$priors, list(set(1L, bad), set(2L))), "state does not match")
})
