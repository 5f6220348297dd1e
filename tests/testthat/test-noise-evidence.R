# The measured curve's own points as data on the learned noise.

test_that("difference residuals give chi-square evidence of the noise variance with Satterthwaite's df", {
  withr::local_seed(1)
  t <- seq(0, 1, length.out = 102)
  # at even stamps the residuals' lag-1 and lag-2 correlations are -2/3 and 1/6
  d <- difference_residuals(rnorm(102), t, rep(1, 102))
  expect_equal(unique(round(d$r1, 10)), -2 / 3)
  expect_equal(unique(round(d$r2, 10)), 1 / 6)
  ev <- difference_evidence(rbind(rnorm(102)), t, rep(1, 102))
  expect_equal(ev[["df"]], difference_efficiency * 100^2 / (100 + 2 * 99 * 4 / 9 + 2 * 98 / 36))
  # ss / df estimates sigma2 at uneven stamps with averaged values (var 1 / n at a stamp)
  tu <- sort(c(0, 1, runif(60)))
  n_at <- sample(1:2, 62, replace = TRUE)
  est <- replicate(200, {
    y <- 3 * sin(2 * tu) + rnorm(62, sd = 0.1 / sqrt(n_at))
    e <- difference_evidence(rbind(y), tu, 1 / n_at)
    e[["ss"]] / e[["df"]]
  })
  expect_lt(abs(mean(est) / 0.01 - 1), 0.05)
  # a bend counts at most as a point 3 MAD-based sds out
  y <- rnorm(62, sd = 0.1) + 50 * (tu > 0.5)
  e <- difference_evidence(rbind(y), tu, rep(1, 62))
  expect_lt(sqrt(e[["ss"]] / e[["df"]]), 0.2)
  f <- suppressMessages(field_runs(rbind(y), tu, grid = seq(0, 1, length.out = 64)))
  expect_equal(f$noise$site1$detail_df, e[["df"]])
})

test_that("a misfit on one curve per site with few points goes to the bias, not the noise", {
  # flow-stress-like curves at six temperatures, one each on its own 15 to 43 strains, noise sd 1 at
  # levels 100 to 600; the model (Voce hardening, its level falling with the temperature) lacks the
  # softening at large strain. Without the points' own evidence the learned sd was 10 and 12.6 times
  # what the points show at two sites.
  temps <- c(20, 100, 200, 300, 400, 500)
  voce <- function(e, temp, s0, ssat, ec) (1 - temp / 600) * (s0 + (ssat - s0) * (1 - exp(-e / ec)))
  truth <- function(e, temp) voce(e, temp, 120, 600, 0.05) * (1 - 0.25 * (temp / 500) * pmax(e - 0.1, 0) / 0.2) + 10
  tg <- seq(0, 0.3, length.out = 64)
  sites <- paste0("T", temps)
  withr::local_seed(3)
  design <- data.frame(s0 = runif(30, 50, 200), ssat = runif(30, 400, 800), ec = runif(30, 0.02, 0.1))
  runs <- model_runs(design, stats::setNames(lapply(temps, function(temp) {
    t(apply(design, 1, function(z) voce(tg, temp, z[1], z[2], z[3])))
  }), sites), tg)
  iu <- iu_map(c("s0", "ssat", "ec"), rep("calibration", 3), c(50, 400, 0.02), c(200, 800, 0.1))
  npts <- c(43, 35, 28, 22, 18, 15)
  xs <- stats::setNames(lapply(npts, function(m) sort(c(0, 0.3, runif(m - 2, 0, 0.3)))), sites)
  ys <- stats::setNames(lapply(seq_along(temps), function(k) truth(xs[[k]], temps[k]) + rnorm(npts[k], sd = 1)), sites)
  field <- suppressMessages(field_runs(ys, xs, grid = tg))
  fit <- suppressWarnings(suppressMessages(validate(runs, field, iu, chains = 1, seed = 1,
                                                    sampler = sampler_control(n_draws = 150, n_inner = 10, quiet = TRUE))))
  ratio <- vapply(sites, function(s) {
    nz <- field$noise[[s]]
    stats::median(sqrt(fit$sigma2[[s]][, 1] / fit$noise_evidence[[s]]$mult[1])) / sqrt(nz$detail_ss / nz$detail_df)
  }, numeric(1))
  expect_true(all(abs(log(ratio)) < log(2)))
  expect_true(any(grepl("points' differences in the likelihood", capture.output(print(fit)))))
})
