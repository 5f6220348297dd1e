# Where the work runs: the chains, the emulators' fits and hold_inputs()'
# strata are futures, so future::plan() decides where; the results must not
# depend on it, on this machine's workers as through a cluster's scheduler.

skip_unless_installed <- function() {
  skip_on_cran()
  skip_if(length(find.package("wavevalid", lib.loc = .libPaths(), quiet = TRUE)) == 0L)
  skip_if(isNamespaceLoaded("pkgload") && pkgload::is_dev_package("wavevalid"))
}

plan_sampler <- function(together = NULL) {
  sampler_control(n_draws = 40, n_inner = 5, burnin = 200, n_search = 10, quiet = TRUE, together = together)
}

# `together` NULL: under a local plan with a worker per chain the chains run
# together in this process; FALSE: each chain a future of the plan.
plan_draws <- function(ex, together = NULL) {
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 7,
                                    sampler = plan_sampler(together)))
  as.matrix(fit$draws)
}

# A stand-in for Slurm's commands on this machine: sbatch keeps a copy of
# the job script (in submitted.txt), runs it at once and answers as Slurm
# does; squeue lists no job (all done).
fake_slurm <- function(dir) {
  dir.create(dir, showWarnings = FALSE)
  writeLines(c("#!/bin/sh", "cat \"$1\" >> \"$(dirname \"$0\")/submitted.txt\"", "bash \"$1\" >/dev/null 2>&1",
               "echo \"Submitted batch job $$\""), file.path(dir, "sbatch"))
  writeLines(c("#!/bin/sh", "exit 0"), file.path(dir, "squeue"))
  writeLines(c("#!/bin/sh", "exit 0"), file.path(dir, "scancel"))
  Sys.chmod(file.path(dir, c("sbatch", "squeue", "scancel")), "0755")
  dir
}

test_that("the chains' draws are the sequential ones under future.callr and batchtools, local and through Slurm", {
  skip_unless_installed()
  skip_if_not_installed("future.callr")
  skip_if_not_installed("future.batchtools")
  skip_if(.Platform$OS.type != "unix" || !nzchar(Sys.which("bash")))
  ex <- example_problem(1)
  old <- future::plan(future::sequential)
  withr::defer(future::plan(old))
  ref <- plan_draws(ex)
  future::plan(future.callr::callr, workers = 2)
  expect_identical(plan_draws(ex), ref)
  expect_identical(plan_draws(ex, together = FALSE), ref)
  # batchtools keeps its registries under the working directory
  withr::local_dir(withr::local_tempdir())
  future::plan(future.batchtools::batchtools_local)
  expect_identical(plan_draws(ex), ref)
  # a cluster plan: batchtools' Slurm template, each chain a job submitted with sbatch
  bin <- fake_slurm(file.path(getwd(), "bin"))
  withr::local_envvar(PATH = paste(bin, Sys.getenv("PATH"), sep = .Platform$path.sep))
  future::plan(future.batchtools::batchtools_slurm, template = "slurm-simple",
               resources = list(walltime = 600, memory = 1000, ncpus = 1))
  expect_identical(plan_draws(ex), ref)
  # the chains went through the template: at least a job script per chain,
  # each with the template's #SBATCH lines
  submitted <- readLines(file.path(bin, "submitted.txt"))
  n_jobs <- sum(grepl("batchtools::doJobCollection", submitted, fixed = TRUE))
  expect_gte(n_jobs, 2L)
  expect_identical(sum(grepl("^#SBATCH --mem-per-cpu=1000$", submitted)), n_jobs)
  expect_identical(sum(grepl("^#SBATCH --time=10$", submitted)), n_jobs)
})

test_that("hold_inputs() gives the sequential draws under a multisession plan", {
  skip_unless_installed()
  skip_if_not_installed("future")
  fit <- example_fit()
  old <- future::plan(future::sequential)
  withr::defer(future::plan(old))
  withr::local_options(wavevalid.quiet = TRUE)
  ref <- hold_inputs(fit, inputs = "u1", strata = 3)
  future::plan(future::multisession, workers = 2)
  par <- hold_inputs(fit, inputs = "u1", strata = 3)
  expect_identical(as.matrix(par$draws), as.matrix(ref$draws))
  expect_identical(par$wb, ref$wb)
})

test_that("a chain's future carries the sampler's sites and priors, not its caller's data", {
  big <- stats::runif(2e6)  # 15 MiB
  spec <- list(sites = list(s = list(bank = stats::runif(1e4))), priors = list(1), groups = data.frame(name = "g"),
               z_init = 0.5, basis = list(Psi = big), informs = NULL, temper = 1, input_weight = 1)
  caller <- function() {
    unused <- big  # a large object in the calling frame
    chain_worker(spec, list(n_draws = 1L, quiet = TRUE), seed = 1 + 0, tau = list(fixed = FALSE),
                 debug_break = 0L, p_global = 0.1)
  }
  worker <- caller()
  size <- length(serialize(worker, NULL))
  expect_lt(size, 2 * length(serialize(spec$sites, NULL)) + 1e5)
  expect_setequal(ls(environment(worker)), c("spec", "sm", "seed", "debug_break", "p_global", "fix", "tau_init",
                                              "team", "settings", "progress_of"))
  expect_null(environment(worker)$spec$basis)
  # the emulators' worker: the coefficients and the design, not the caller's runs
  fit_caller <- function() {
    unused <- big
    emulator_worker("gasp", X = matrix(0, 2, 1), W = list(s = matrix(0, 2, 1)), starts = 2L,
                    log_beta_range = c(-1, 1), seed = 1 + 0, km_args = list())
  }
  expect_lt(length(serialize(fit_caller(), NULL)), 1e5)
})

test_that("chains that ran one after the other for a minute with free cores get the plan that runs them at once", {
  skip_if_not_installed("future")
  old <- future::plan(future::sequential)
  withr::defer(future::plan(old))
  withr::local_options(wavevalid.quiet = FALSE, wavevalid.workers = "auto")
  hint <- hint_parallel_chains
  msg <- expect_message(hint(75, 2L, 2L, FALSE), class = "wavevalid_message_parallel")
  expect_match(conditionMessage(msg), "multisession, workers = 2", fixed = TRUE)
  expect_match(conditionMessage(msg), "75 s", fixed = TRUE)
  # not when quiet, with one chain, one free core, a short run, or another plan
  expect_no_message(expect_false(hint(75, 2L, 2L, TRUE)))
  expect_no_message(expect_false(hint(75, 1L, 2L, FALSE)))
  expect_no_message(expect_false(hint(75, 2L, 1L, FALSE)))
  expect_no_message(expect_false(hint(30, 2L, 2L, FALSE)))
  # nor when the user chose one process
  withr::with_options(list(wavevalid.workers = 1),
                      expect_no_message(expect_false(hint(75, 2L, 2L, FALSE))))
  future::plan(future::multisession, workers = 2)
  expect_no_message(expect_false(hint(75, 2L, 2L, FALSE)))
})

test_that("chains that resume in rounds (n_draws = NULL) give the sequential draws under a multisession plan", {
  skip_unless_installed()
  skip_if_not_installed("future")
  withr::local_seed(7)
  gp <- grid_problem()
  old <- future::plan(future::sequential)
  withr::defer(future::plan(old))
  run <- function(n_draws = NULL, together = NULL) {
    calibrate(gp$pb$emulators, gp$field, gp$pb$iu, chains = 2, seed = 3, bias = bias_control(sigma2 = gp$sigma2),
              sampler = sampler_control(n_draws = n_draws, n_inner = 5, ess = 150, burnin = 2000, quiet = TRUE,
                                        together = together))
  }
  ref <- run()
  # the stopping rule ran more than one round, and stopped before the ceiling
  expect_gt(ref$stopping$rounds, 1L)
  expect_lt(ref$stopping$draws, ref$stopping$max_draws)
  future::plan(future::multisession, workers = 2)
  # the chains together in this process, then each a future of the plan
  for (together in list(NULL, FALSE)) {
    par <- run(together = together)
    expect_identical(as.matrix(par$draws), as.matrix(ref$draws))
    expect_identical(par$stopping, ref$stopping)
  }
  # the first round (ess / chains = 75 draws each) is the chains run at once;
  # the continued rounds move by walks learned from their draws, so they differ
  future::plan(future::sequential)
  whole <- run(ref$stopping$draws)
  first <- seq_len(75L)
  for (ch in 1:2) {
    expect_identical(as.matrix(whole$draws[[ch]])[first, ], as.matrix(ref$draws[[ch]])[first, ])
    expect_false(identical(as.matrix(whole$draws[[ch]])[-first, ], as.matrix(ref$draws[[ch]])[-first, ]))
  }
})

test_that("validate() with future's default plan runs on the free cores for the call, with the same draws", {
  skip_unless_installed()
  skip_if_not_installed("future")
  ex <- example_problem()
  runs <- model_runs(as.data.frame(ex$emulators$design),
                     ex$emulators$banks$site1$y %*% t(ex$emulators$basis$Psi), ex$field$t, site = "site1")
  old <- future::plan(future::sequential)
  withr::defer(future::plan(old))
  go <- function(quiet = TRUE) {
    suppressWarnings(validate(runs, ex$field, ex$iu, chains = 2, seed = 3,
                              sampler = sampler_control(n_draws = 30, n_inner = 5, quiet = quiet)))
  }
  withr::local_options(wavevalid.workers = 1)
  ref <- go()
  # "auto" with two free cores: a multisession plan while validate() runs,
  # the sequential one again after it; the workers ran the emulators' fits
  # and the chains (the draws are the one-process draws)
  skip_if(future::availableCores() < 2L, "one core available")
  withr::local_options(wavevalid.workers = "auto", wavevalid.free_cores = 2L)
  seen <- NULL
  trace_plan <- function() seen <<- c(seen, inherits(future::plan(), "multisession"))
  withr::local_options(wavevalid.quiet = FALSE)
  msg <- expect_message(par <- withCallingHandlers(go(quiet = FALSE), wavevalid_message_cores = function(m) trace_plan()),
                        class = "wavevalid_message_cores")
  expect_match(conditionMessage(msg), "Running on 2 cores", fixed = TRUE)
  expect_identical(seen, TRUE)
  expect_true(inherits(future::plan(), "sequential"))
  expect_identical(as.matrix(par$draws), as.matrix(ref$draws))
  expect_identical(par$emulators$banks, ref$emulators$banks)
  # a plan of the user's own is kept; calibrate() with one chain starts none
  future::plan(future::multisession, workers = 2)
  expect_no_message(go(quiet = FALSE), class = "wavevalid_message_cores")
  future::plan(future::sequential)
  expect_no_message(suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 1,
                                               sampler = sampler_control(n_draws = 20, n_inner = 5))),
                    class = "wavevalid_message_cores")
  withr::local_options(wavevalid.workers = "all")
  expect_error(go(), class = "wavevalid_error_workers")
})
