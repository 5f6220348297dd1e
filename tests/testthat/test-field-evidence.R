gentle <- function(t) 300 + 50 * t + 10 * sin(2 * pi * t)
jittered_times <- function(m) sort(c(0, 1, (seq_len(m - 2) - stats::runif(m - 2, 0.1, 0.9)) / (m - 2)))

test_that("a curve interpolated before it came in is detected and its noise evidence is that of its measured points", {
  g <- seq(0, 1, length.out = 512)
  Psi <- qr.Q(qr(matrix(stats::rnorm(512 * 6), 512, 6)))
  for (seed in 1:5) {
    withr::local_seed(seed)
    m <- 15 + 5 * seed  # 20 to 40 measured points
    xs <- jittered_times(m)
    ys <- gentle(xs) + stats::rnorm(m, sd = 2)
    by_hand <- stats::approx(xs, ys, xout = g)$y
    expect_message(f <- field_runs(rbind(by_hand), g), class = "wavevalid_message_interpolated")
    # the points the interpolation went through are found again, exactly
    kn <- interpolation_knots(g, by_hand)
    expect_equal(kn$x, xs, tolerance = 1e-8)
    expect_equal(kn$y, ys, tolerance = 1e-8)
    expect_true(all(kn$exact))
    # the evidence is that of the curve given on its own points
    own <- suppressMessages(field_runs(list(site1 = ys), list(site1 = xs), grid = g))$noise$site1
    nz <- f$noise$site1
    expect_equal(nz$detail_sd, own$detail_sd, tolerance = 1e-6)
    expect_identical(nz$n_stamps, as.integer(m))
    expect_equal(resampled_noise_multipliers(nz$map, Psi),
                 resampled_noise_multipliers(own$map, Psi), tolerance = 1e-6)
    # ... and near the true noise sd, where the curve on the grid shows none
    expect_lt(abs(log(nz$detail_sd / 2)), log(2))
    expect_lt(detail_noise_sd(rbind(by_hand), g, rep(1, 512)), 0.01)
  }
})

test_that("a noisy curve, a smooth noise-free one and a measured flat stretch are not read as interpolated", {
  withr::local_seed(3)
  g <- seq(0, 1, length.out = 512)
  expect_silent(f <- field_runs(rbind(gentle(g) + stats::rnorm(512, sd = 0.5)), g))
  expect_null(f$noise)
  g4 <- seq(0, 1, length.out = 4096)
  expect_null(interpolation_knots(g4, sin(2 * pi * g4)))
  expect_null(interpolation_knots(g, 1.2 * stats::plogis((g - 0.5) / 0.025)))
  quiet_then_noisy <- c(rep(0, 200), 5 + stats::rnorm(312, sd = 0.1))
  expect_null(interpolation_knots(g, quiet_then_noisy))
  # an interpolated stretch among noisy ones is found
  noisy <- gentle(g) + stats::rnorm(512, sd = 0.5)
  noisy[100:300] <- seq(noisy[100], noisy[300], length.out = 201)
  expect_false(is.null(interpolation_knots(g, noisy)))
})

test_that("where too few measured points can be told the noise is not learned from the curve until a prior is given", {
  ex <- example_problem()
  tg <- ex$field$t
  withr::local_seed(4)
  knots <- c(0, 0.2, 0.45, 0.7, tg[32])
  curve <- stats::approx(knots, sin(2 * pi * knots) + stats::rnorm(5, sd = 0.03), xout = tg)$y
  expect_warning(field <- field_runs(rbind(curve), tg, x_nom = c(x1 = 0.5)), class = "wavevalid_warning_interpolated")
  expect_identical(field$noise$site1$detail_sd, 0)
  expect_error(suppressMessages(calibrate(ex$emulators, field, ex$iu, chains = 1, seed = 1,
                                          sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE))),
               class = "wavevalid_error_numeric")
  fit <- suppressWarnings(suppressMessages(calibrate(ex$emulators, field, ex$iu, chains = 1, seed = 1,
                                                     bias = bias_control(sigma2 = noise_prior(scale = 0.03)),
                                                     sampler = sampler_control(n_draws = 20, n_inner = 5, quiet = TRUE))))
  expect_s3_class(fit, "wv_fit")
  # preflight() says so before anything is fitted
  reps <- c(site1 = 1L)
  expect_false(describe_noise(NULL, reps, field$noise)$ok[["site1"]])
  expect_true(describe_noise(noise_prior(scale = 0.03), reps, field$noise)$ok[["site1"]])
  # 40 points on a 64-point grid: measured points closer than two grid steps cannot be told apart
  g <- seq(0, 1, length.out = 64)
  withr::local_seed(2)
  xs <- jittered_times(40)
  expect_warning(f <- suppressMessages(field_runs(rbind(stats::approx(xs, gentle(xs) + stats::rnorm(40, sd = 2), xout = g)$y), g)),
                 class = "wavevalid_warning_interpolated")
  expect_identical(f$noise$site1$detail_sd, 0)
  # enough residuals of exact points, but most points read as measured are not exact
  kn <- list(x = seq(0, 1, length.out = 40), y = stats::rnorm(40), exact = rep(c(TRUE, FALSE), c(15, 25)))
  expect_identical(knots_noise_sd(kn), 0)
  kn$exact[] <- TRUE
  expect_gt(knots_noise_sd(kn), 0)
})

test_that("the noise learned from a curve interpolated by the user does not collapse", {
  skip_on_cran()
  f <- function(t, a, b) sin(2 * pi * t * (1 + a)) + b * t
  tg <- seq(0, 1, length.out = 128)
  withr::local_seed(1)
  design <- data.frame(a = stats::runif(25), b = stats::runif(25))
  runs <- model_runs(design, t(apply(design, 1, function(z) f(tg, z[1], z[2]))), tg)
  iu <- iu_map(c("a", "b"), c("calibration", "calibration"), c(0, 0), c(1, 1))
  xs <- jittered_times(25)
  y <- f(xs, 0.4, 0.6) + stats::rnorm(25, sd = 0.05)
  field <- suppressMessages(field_runs(rbind(stats::approx(xs, y, tg)$y), tg))
  fit <- suppressWarnings(suppressMessages(validate(runs, field, iu, chains = 1, seed = 1,
                                                    sampler = sampler_control(n_draws = 300, n_inner = 20, quiet = TRUE))))
  ev <- fit$noise_evidence$site1
  expect_identical(ev$n_stamps, 25L)
  sd_draws <- sqrt(fit$sigma2$site1[, 1] / ev$mult[1])
  expect_gt(stats::median(sd_draws), 0.05 / 5)
})
