smooth <- function(t) 300 + 50 * t + 10 * sin(2 * pi * t)

# Uneven times on [0, 1] with both ends: m points, each jittered in its slot.
uneven_times <- function(m) sort(c(0, 1, (seq_len(m - 2) - stats::runif(m - 2, 0.1, 0.9)) / (m - 2)))

test_that("curves on their own times are the interpolation by hand plus each curve's noise evidence", {
  withr::local_seed(11)
  grid <- seq(0, 1, length.out = 64)
  ta <- list(uneven_times(30), uneven_times(17))
  ta[[2]] <- sort(c(ta[[2]], ta[[2]][c(4, 9)]))  # two repeated measurements in the second replicate
  tb <- uneven_times(40)
  ya <- lapply(ta, function(x) smooth(x) + stats::rnorm(length(x), sd = 2))
  yb <- smooth(tb) + stats::rnorm(40, sd = 2)
  expect_message(f <- field_runs(list(a = ya, b = yb), list(a = ta, b = tb), grid = grid), class = "wavevalid_message")
  expect_identical(f$t, grid)
  expect_equal(dim(f$curves$a), c(2L, 64L))
  by_hand <- function(x, y) {
    avg <- tapply(y, x, mean)
    stats::approx(as.numeric(names(avg)), avg, xout = grid, rule = 2)$y
  }
  expect_equal(f$curves$a[1, ], by_hand(ta[[1]], ya[[1]]))
  expect_equal(f$curves$a[2, ], by_hand(ta[[2]], ya[[2]]))
  expect_equal(f$curves$b[1, ], by_hand(tb, yb))
  # the evidence of each curve on its own stamps: scatter of the repeats, detail sd, resampling
  one <- lapply(1:2, function(r) suppressMessages(field_runs(rbind(ya[[r]]), ta[[r]], grid = grid))$noise$site1)
  nz <- f$noise$a
  expect_equal(nz$df, 2)
  expect_equal(nz$ss, one[[2]]$ss)
  expect_equal(nz$detail_sd, mean(c(one[[1]]$detail_sd, one[[2]]$detail_sd)))
  expect_identical(nz$n_stamps, 30L + 17L)
  Psi <- qr.Q(qr(matrix(stats::rnorm(64 * 5), 64, 5)))
  expect_equal(resampled_noise_multipliers(nz$map, Psi),
               (resampled_noise_multipliers(one[[1]]$map, Psi) +
                  resampled_noise_multipliers(one[[2]]$map, Psi)) / 2)
  expect_equal(f$noise$b$detail_sd, detail_noise_sd(rbind(yb), tb, rep(1, 40)))
  # without `grid`: the range every curve covers, the next power of two of the most times of a curve
  expect_message(d <- field_runs(list(a = ya, b = yb), list(a = ta, b = tb)), "range every curve covers")
  expect_length(d$t, 64L)
  expect_equal(range(d$t), c(max(ta[[1]][1], ta[[2]][1], tb[1]), min(1, 1, 1)))
})

test_that("when every curve shares its times, the list form is the wide form", {
  withr::local_seed(12)
  t <- seq(0, 1, length.out = 40)
  Y <- rbind(smooth(t), smooth(t) + 1) + stats::rnorm(80, sd = 2)
  wide <- suppressMessages(field_runs(list(a = Y, b = Y[1, , drop = FALSE]), t, x_nom = c(x = 1)))
  listed <- suppressMessages(field_runs(list(a = list(Y[1, ], Y[2, ]), b = Y[1, ]), list(a = list(t, t), b = t),
                                        x_nom = c(x = 1)))
  expect_identical(listed, wide)
  design <- data.frame(a = 1:3 / 4)
  runs <- suppressMessages(model_runs(design, rbind(Y, Y[1, ] * 2), t))
  expect_identical(suppressMessages(model_runs(design, list(site1 = list(Y[1, ], Y[2, ], Y[1, ] * 2)), list(t))), runs)
})

test_that("model runs on their own times are interpolated onto the grid", {
  withr::local_seed(13)
  grid <- seq(0, 1, length.out = 64)
  design <- data.frame(a = c(0.2, 0.5, 0.8))
  tt <- lapply(1:3, function(k) uneven_times(20 + 5 * k))
  yy <- lapply(1:3, function(k) smooth(tt[[k]]) * design$a[k])
  runs <- suppressMessages(model_runs(design, list(load = yy), list(load = tt), grid = grid))
  expect_identical(runs$t, grid)
  for (k in 1:3) expect_equal(runs$curves$load[k, ], stats::approx(tt[[k]], yy[[k]], xout = grid, rule = 2)$y)
  # a failed run (NA values) is dropped as in the wide form
  yy[[2]][5] <- NA
  expect_warning(r2 <- suppressMessages(model_runs(design, list(load = yy), list(load = tt), grid = grid)),
                 class = "wavevalid_warning_failed_runs")
  expect_equal(r2$design$a, c(0.2, 0.8))
  # a model run has one value per time
  tt[[1]][3] <- tt[[1]][2]
  expect_error(model_runs(design, list(load = yy), list(load = tt), grid = grid), class = "wavevalid_error_stamps")
})

test_that("long data frames give the same object as the wide form", {
  withr::local_seed(14)
  t <- seq(0, 1, length.out = 50)
  Y <- list(cold = rbind(smooth(t), smooth(t) + 3), hot = rbind(smooth(t) / 2)) 
  Y <- lapply(Y, function(m) m + stats::rnorm(length(m), sd = 2))
  wide <- suppressMessages(field_runs(Y, t))
  long <- do.call(rbind, lapply(names(Y), function(s) {
    data.frame(temperature = s, rep = rep(seq_len(nrow(Y[[s]])), each = length(t)),
               strain = rep(t, nrow(Y[[s]])), stress = as.vector(t(Y[[s]])))
  }))
  long <- long[sample(nrow(long)), ]
  from_long <- suppressMessages(field_runs(long, t = "strain", y = "stress", site = "temperature", replicate = "rep"))
  expect_identical(from_long, wide)
  # curves of unequal times in long form are the list form
  keep <- !(long$temperature == "hot" & long$strain > 0.9)
  uneq <- suppressMessages(field_runs(long[keep, ], t = "strain", y = "stress", site = "temperature",
                                      replicate = "rep", grid = seq(0, 0.9, length.out = 32)))
  listed <- suppressMessages(field_runs(list(cold = list(Y$cold[1, ], Y$cold[2, ]), hot = Y$hot[1, t <= 0.9]),
                                        list(cold = t, hot = t[t <= 0.9]), grid = seq(0, 0.9, length.out = 32)))
  expect_identical(uneq, listed)
  # model runs: the design matched by a run column, or by position when runs are numbered 1..K
  design <- data.frame(a = c(0.1, 0.4, 0.7), b = c(1, 0, 1))
  curves <- t(sapply(design$a, function(a) sin(2 * pi * t * (1 + a))))
  wide_runs <- suppressMessages(model_runs(design, curves, t))
  lr <- data.frame(run = rep(c("r1", "r2", "r3"), each = 50), time = rep(t, 3), load = as.vector(t(curves)))
  lr <- lr[sample(nrow(lr)), ]
  keyed <- cbind(run = c("r3", "r1", "r2"), design[c(3, 1, 2), ])
  by_key <- suppressMessages(model_runs(lr, t = "time", y = "load", run = "run", design = keyed))
  expect_equal(by_key$design$a, c(0.7, 0.1, 0.4))
  expect_equal(by_key$curves$site1, wide_runs$curves$site1[c(3, 1, 2), ])
  lr$run <- match(lr$run, c("r1", "r2", "r3"))
  expect_identical(suppressMessages(model_runs(lr, t = "time", y = "load", run = "run", design = design)), wide_runs)
})

test_that("long data frames with bad columns or curves give classed errors that name the fix", {
  t <- seq(0, 1, length.out = 20)
  long <- data.frame(strain = rep(t, 2), stress = smooth(rep(t, 2)), temperature = rep(c(20, 80), each = 20))
  cnd <- rlang::catch_cnd(field_runs(long, t = "strian", y = "stress", site = "temperature"))
  expect_s3_class(cnd, "wavevalid_error_column")
  expect_match(conditionMessage(cnd), "strian")
  expect_match(conditionMessage(cnd), "Its columns are")
  expect_match(conditionMessage(cnd), "strain")
  expect_snapshot(field_runs(long, t = "strain", y = "stres", site = "temperature"), error = TRUE)
  expect_error(field_runs(long, t = "strain", site = "temperature"), class = "wavevalid_error_column")
  expect_error(field_runs(long, t = "strain", y = "temperature", site = "stress"), class = "wavevalid_error_stamps")
  expect_error(field_runs(long, t = "strain", y = 2), class = "wavevalid_error_column")
  expect_error(field_runs(matrix(1, 2, 20), t, y = "stress"), class = "wavevalid_error_column")
  # a site with one point
  one <- rbind(long, data.frame(strain = 0.5, stress = 1, temperature = 150))
  expect_error(field_runs(one, t = "strain", y = "stress", site = "temperature"), "150", class = "wavevalid_error_stamps")
  # two curves stacked without their replicate column: not repeated measurements
  expect_snapshot(field_runs(long, t = "strain", y = "stress"), error = TRUE)
  expect_error(field_runs(long, t = "strain", y = "stress"), class = "wavevalid_error_stamps")
  # repeated measurements at one time, rows in time order: averaged
  sorted <- long[order(long$strain), ]
  expect_equal(suppressMessages(field_runs(sorted, t = "strain", y = "stress"))$noise$site1$df, 20)
  # runs: no way to match the design, a run the design lacks
  lr <- data.frame(run = rep(c("p", "q"), each = 20), time = rep(t, 2), load = rep(smooth(t), 2))
  expect_error(model_runs(lr, t = "time", y = "load", run = "run", design = data.frame(a = 1:2)),
               class = "wavevalid_error_column")
  expect_error(model_runs(lr, t = "time", y = "load", run = "run", design = data.frame(run = "p", a = 1)),
               class = "wavevalid_error_column")
})

test_that("messages about a field curve name it by the user's id column", {
  t <- seq(0, 1, length.out = 16)
  long <- do.call(rbind, lapply(c("S1", "S2", "S3"), function(id) data.frame(subject = id, t = t, y = sin(t))))
  long$y[long$subject == "S2"][5] <- NA
  err <- expect_error(field_runs(long, t = "t", y = "y", replicate = "subject"), class = "wavevalid_error_input")
  expect_match(cli::ansi_strip(conditionMessage(err)), "subject S2", fixed = TRUE)
  # curves on their own times: the same, by id
  own <- do.call(rbind, lapply(c("S1", "S2", "S3"), function(id) {
    tt <- sort(c(0, stats::runif(14), 1))
    data.frame(subject = id, t = tt, y = sin(tt))
  }))
  own$y[own$subject == "S3"][3] <- NaN
  err <- expect_error(field_runs(own, t = "t", y = "y", replicate = "subject"), class = "wavevalid_error_input")
  expect_match(cli::ansi_strip(conditionMessage(err)), "subject S3", fixed = TRUE)
  # a curve with too few times, by id
  short <- own[!(own$subject == "S2" & own$t > 0.3), ]
  err <- expect_error(field_runs(short, t = "t", y = "y", replicate = "subject"), class = "wavevalid_error_stamps")
  expect_match(cli::ansi_strip(conditionMessage(err)), "subject S2 has", fixed = TRUE)
  # without an id column, by position
  err <- expect_error(field_runs(rbind(sin(t), c(sin(t[1:5]), NA, sin(t[-(1:6)]))), t), class = "wavevalid_error_input")
  expect_match(cli::ansi_strip(conditionMessage(err)), "replicate 2", fixed = TRUE)
})
