# Chains that stop when they have enough: a chain continued from its state
# draws what the chain run at once draws; the rounds stop on the targets.

resume_setup <- function(n_inner = 5L, adaptive = TRUE) {
  withr::local_seed(11)
  gp <- grid_problem()
  spec <- calibration_spec(gp$pb$emulators, gp$field, gp$pb$iu, sigma2 = gp$sigma2)
  tau <- resolve_fix_tau2(NULL, spec$groups)
  sm <- sampler_control(n_inner = n_inner, proposal = if (adaptive) "adaptive" else "report", burnin = 300,
                        quiet = TRUE)
  list(gp = gp, spec = spec, tau = tau, sm = sm, worker = chain_worker(spec, sm, seed = 5, tau, 0L, 0.1))
}

test_that("a chain continued from its state draws what the chain run at once draws", {
  for (adaptive in c(TRUE, FALSE)) {
    s <- resume_setup(adaptive = adaptive)
    whole <- s$worker(list(chain = 2L, n_draws = 30L, resume = NULL))
    first <- s$worker(list(chain = 2L, n_draws = 18L, resume = NULL))
    rest <- s$worker(list(chain = 2L, n_draws = 12L, resume = first$state))
    joined <- join_chain_runs(first, rest)
    expect_identical(joined$inputs, whole$inputs)
    expect_identical(joined$tau2, whole$tau2)
    expect_identical(joined$wb, whole$wb)
    expect_identical(joined$sigma2, whole$sigma2)
    expect_identical(joined$state, whole$state)
    # the continuation is not a fresh chain: without the state the draws differ
    expect_false(identical(s$worker(list(chain = 2L, n_draws = 12L, resume = NULL))$inputs, rest$inputs))
  }
})

test_that("a continued chain's walk is learned from its own draws", {
  s <- resume_setup()
  first <- s$worker(list(chain = 2L, n_draws = 40L, resume = NULL))
  re <- relearn_walk(first, s$spec$priors)
  z <- first$inputs
  p <- ncol(z)
  rng <- s$spec$priors$upper - s$spec$priors$lower
  learned <- 2.38^2 / p * (stats::cov(z) + diag(1e-6 * rng^2, p))
  expect_equal(tcrossprod(re$state$walk_chol), learned, ignore_attr = TRUE)
  expect_false(isTRUE(all.equal(tcrossprod(first$state$walk_chol), learned, check.attributes = FALSE)))
  # the continued chain moves by it
  rest <- s$worker(list(chain = 2L, n_draws = 5L, resume = re$state))
  expect_equal(rest$proposal_cov, tcrossprod(re$state$walk_chol), ignore_attr = TRUE)
  # fewer than 20 draws per input: the burn-in's walk is kept
  few <- s$worker(list(chain = 2L, n_draws = 10L, resume = NULL))
  expect_identical(relearn_walk(few, s$spec$priors), few)
  # a chain that hardly moved (its draws repeat): its walk is kept, not shrunk to the repeats' spread
  stuck <- first
  stuck$inputs <- first$inputs[rep(1:3, length.out = nrow(first$inputs)), , drop = FALSE]
  expect_identical(relearn_walk(stuck, s$spec$priors), stuck)
  # with independence moves, their t takes the draws' mean and covariance, its
  # normalising constant computed as the sampler computes it at the burn-in's end
  sm <- sampler_control(n_inner = 5L, burnin = 300, global_moves = 0.5, quiet = TRUE)
  w <- chain_worker(s$spec, sm, seed = 5, s$tau, 0L, 0.1)
  g <- w(list(chain = 1L, n_draws = 40L, resume = NULL))
  expect_true(g$state$has_indep)
  L <- g$state$ind_chol
  const <- lgamma(0.5 * (4 + p)) - lgamma(2) - 0.5 * p * log(4 * pi) - sum(log(diag(L)))
  expect_equal(g$state$log_t_const, const)
  rg <- relearn_walk(g, s$spec$priors)
  expect_equal(tcrossprod(rg$state$ind_chol), stats::cov(g$inputs) + diag(1e-6 * rng^2, p), ignore_attr = TRUE)
  expect_equal(rg$state$ind_mean, unname(colMeans(g$inputs)))
  expect_equal(rg$state$log_t_const,
               lgamma(0.5 * (4 + p)) - lgamma(2) - 0.5 * p * log(4 * pi) - sum(log(diag(rg$state$ind_chol))))
  expect_no_error(w(list(chain = 1L, n_draws = 5L, resume = rg$state)))
})

test_that("a state that does not match the sampler is refused", {
  s <- resume_setup()
  st <- s$worker(list(chain = 1L, n_draws = 5L, resume = NULL))$state
  bad <- st
  bad$z <- c(bad$z, 0.5)
  expect_error(s$worker(list(chain = 1L, n_draws = 5L, resume = bad)), "does not match")
  bad <- st
  bad$rng <- "not a stream"
  expect_error(s$worker(list(chain = 1L, n_draws = 5L, resume = bad)), "random number stream")
})

test_that("the chains stop when every input's ESS and R-hat meet the targets, or warn at the ceiling", {
  # seeded data: with this field the chains stop after three rounds, at 75, 150 and 300 draws each
  withr::local_seed(7)
  gp <- grid_problem()
  rounds <- character()
  fit <- withCallingHandlers(
    calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 2, seed = 3, bias = bias_control(sigma2 = gp$sigma2),
              sampler = sampler_control(n_inner = 5, ess = 150, quiet = FALSE)),
    wavevalid_message = function(m) {
      rounds[length(rounds) + 1L] <<- conditionMessage(m)
      invokeRestart("muffleMessage")
    })
  st <- fit$stopping
  expect_true(st$met)
  expect_identical(nrow(fit$draws[[1]]), as.integer(st$draws))
  expect_identical(fit$settings$n_draws, as.integer(st$draws))
  ess <- coda::effectiveSize(fit$draws)[fit$inputs]
  expect_gte(min(ess), 150)
  expect_equal(unname(min(ess)), st$ess)
  expect_lte(st$rhat, 1.05)
  # the chains stopped before the ceiling, in more than one round
  expect_lt(st$draws, st$max_draws)
  expect_gt(st$rounds, 1L)
  # the first round held ess / chains = 75 draws; each further round says how many it added
  more <- as.integer(sub(".*continued by ([0-9]+) draws each.*", "\\1", rounds[grepl("continued by", rounds)]))
  expect_length(more, st$rounds - 1L)
  expect_identical(as.integer(st$draws - sum(more)), 75L)
  # the round before the last missed the targets (a chain continued from its state draws what
  # the chain run at once draws, so the draws held then are the first `before` of each chain)
  before <- st$draws - more[length(more)]
  held <- coda::mcmc.list(lapply(fit$draws, function(d) coda::mcmc(as.matrix(d)[seq_len(before), "u1", drop = FALSE])))
  missed <- coda::effectiveSize(held) < 150 ||
    coda::gelman.diag(held, autoburnin = FALSE, multivariate = FALSE)$psrf[1, 1] > 1.05
  expect_true(missed)
  # the last round's walk was learned from each chain's draws before it
  rng <- fit$prior_iu$upper - fit$prior_iu$lower
  for (ch in seq_along(fit$draws)) {
    z <- as.matrix(fit$draws[[ch]])[seq_len(before), fit$inputs, drop = FALSE]
    expect_equal(unname(fit$proposal_cov[[ch]]),
                 2.38^2 / ncol(z) * unname(stats::cov(z) + diag(1e-6 * rng^2, ncol(z))))
  }
  # the burn-in is sized to the first round, max(5000, 75 * n_inner / 4)
  expect_identical(as.integer(fit$settings$burnin), 5000L)
  thin <- calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 2, seed = 3, bias = bias_control(sigma2 = gp$sigma2),
                    sampler = sampler_control(n_inner = 400, ess = 150, quiet = TRUE))
  expect_identical(as.integer(thin$settings$burnin), 7500L)
  expect_identical(thin$stopping$rounds, 1L)
  expect_identical(nrow(thin$draws[[1]]), 75L)
  expect_match(capture.output(print(fit)), "Chains stopped at [0-9]+ draws each", all = FALSE)
  # a target the ceiling cannot reach: the chains stop there and warn
  warned <- list()
  short <- withCallingHandlers(
    calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 2, seed = 3, bias = bias_control(sigma2 = gp$sigma2),
              sampler = sampler_control(n_inner = 1, ess = 5000, max_draws = 60, quiet = TRUE)),
    warning = function(w) {
      warned[[length(warned) + 1L]] <<- w
      invokeRestart("muffleWarning")
    })
  ceiling <- Filter(function(w) grepl("ceiling of 60 draws", conditionMessage(w)), warned)
  expect_length(ceiling, 1L)
  expect_s3_class(ceiling[[1]], "wavevalid_warning_mixing")
  expect_false(short$stopping$met)
  expect_identical(nrow(short$draws[[1]]), 60L)
  expect_match(capture.output(print(short)), "ceiling of 60 draws", all = FALSE)
  # a fixed length has no stopping rule
  fixed <- calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 1, seed = 3, bias = bias_control(sigma2 = gp$sigma2),
                     sampler = sampler_control(n_draws = 40, n_inner = 5, quiet = TRUE))
  expect_null(fixed$stopping)
  expect_identical(nrow(fixed$draws[[1]]), 40L)
})

test_that("a round adds the missing draws and a fifth, at most the draws held", {
  # chains of known mixing: AR(1) draws with phi = 0.9 (about 0.05 effective draws per draw),
  # continued from their last value. From 50 draws each, R-hat above target doubles the
  # draws twice; then the ESS (29 of 100 at 200 draws, 40 at 400) projects about three
  # times the draws held, and the rounds double them instead, until the projection rests on
  # enough draws (85 of 100 at 800: 167 more)
  phi <- 0.9
  run <- function(jobs) {
    lapply(jobs, function(j) {
      set.seed(100L * j$chain + (j$resume$n %||% 0L))
      x <- numeric(j$n_draws)
      prev <- j$resume$last %||% 0
      for (i in seq_along(x)) x[i] <- prev <- phi * prev + sqrt(1 - phi^2) * stats::rnorm(1)
      list(inputs = cbind(u1 = x), state = list(last = prev, n = (j$resume$n %||% 0L) + j$n_draws),
           acc_tau = NA_real_, acc_input = NA_real_, acc_global = NA_real_, acc_noise = NA_real_)
    })
  }
  sm <- list(ess = 100, rhat = 1.05, max_draws = 5000L, quiet = FALSE, proposal = "report")
  said <- character()
  runs <- withCallingHandlers(
    chain_rounds(run, list(inputs = "u1", priors = list()), sm, chains = 2L),
    wavevalid_message = function(m) {
      said[length(said) + 1L] <<- conditionMessage(m)
      invokeRestart("muffleMessage")
    })
  st <- attr(runs, "stopping")
  expect_true(st$met)
  expect_gte(st$ess, 100)
  more <- as.integer(sub(".*continued by ([0-9]+) draws each.*", "\\1", said))
  held <- 50L + cumsum(c(0L, more))
  expect_identical(as.integer(st$draws), held[length(held)])
  expect_identical(nrow(runs[[1]]$inputs), as.integer(st$draws))
  # never more than the draws held, and doubling while the projection asks for more
  expect_true(all(more <= held[-length(held)]))
  expect_identical(more[1:4], c(50L, 100L, 200L, 400L))
  # the last round's size is the missing draws and a fifth: between what the
  # round before projected without and with the fifth
  before <- held[length(held) - 1L]
  ess_before <- as.numeric(sub(".*ESS is ([0-9.]+) of.*", "\\1", said[length(said)]))
  expect_lt(more[length(more)], before)
  expect_equal(more[length(more)], ceiling(1.2 * before * (100 / ess_before - 1)), tolerance = 0.05)
  # R-hat above target doubles the draws, whatever the ESS says
  sm$rhat <- 1.0000001
  sm$max_draws <- 400L
  capped <- suppressMessages(chain_rounds(run, list(inputs = "u1", priors = list()), sm, chains = 2L))
  expect_identical(attr(capped, "stopping")$draws, 400L)
  expect_identical(attr(capped, "stopping")$rounds, 4L)
})

test_that("sampler_control() refuses targets it cannot use", {
  expect_error(sampler_control(ess = 0), class = "wavevalid_error")
  expect_error(sampler_control(rhat = 1), class = "wavevalid_error")
  expect_error(sampler_control(max_draws = 5), class = "wavevalid_error")
  expect_null(sampler_control()$n_draws)
})
