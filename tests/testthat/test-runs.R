make_curves <- function(k, t) t(vapply(seq_len(k), function(i) sin(2 * pi * t * (1 + i / k)), numeric(length(t))))

test_that("model_runs and field_runs hold one or several sites", {
  t <- seq(0, 1, length.out = 64)
  design <- data.frame(a = 1:5 / 6, b = 5:1 / 6)
  runs <- model_runs(design, list(front = make_curves(5, t), rear = 2 * make_curves(5, t)), t)
  expect_s3_class(runs, "wv_runs")
  expect_named(runs$curves, c("front", "rear"))
  expect_equal(dim(runs$curves$rear), c(5L, 64L))
  one <- model_runs(design, make_curves(5, t), t, site = "s")
  expect_named(one$curves, "s")
  field <- field_runs(make_curves(3, t), t, x_nom = c(a = 0.5))
  expect_s3_class(field, "wv_field")
  expect_equal(nrow(field$curves$site1), 3L)
  expect_snapshot(print(runs))
  expect_snapshot(print(summary(field)))
  # the runs' and the replicates' lines in each window, a panel per site and window
  pc <- plot_drawn(autoplot(runs, field = field, windows = list(c(0.1, 0.3), c(0.6, 0.8))))
  n_win <- sum(t >= 0.1 & t <= 0.3) + sum(t >= 0.6 & t <= 0.8)
  expect_identical(pc$geoms, c("GeomLine", "GeomLine"))
  expect_identical(nrow(pc$data[[1]]), 2L * 5L * n_win)
  expect_identical(nrow(pc$data[[2]]), 3L * n_win)
  expect_identical(length(unique(pc$data[[2]]$colour)), 3L)
  expect_identical(pc$panels, 3L * 2L)
  expect_equal(range(pc$data[[1]]$x), c(min(t[t >= 0.1]), max(t[t <= 0.8])))
  expect_false(any(pc$data[[1]]$x > 0.3 & pc$data[[1]]$x < 0.6))
  expect_identical(pc$labels$title, "Model runs (grey) and field replicates")
})

test_that("containers reject bad input with classed errors", {
  t <- seq(0, 1, length.out = 64)
  design <- data.frame(a = 1:5 / 6)
  cur <- make_curves(5, t)
  # mismatched dimensions
  expect_error(model_runs(design, cur[, -1], t), class = "wavevalid_error_input")
  expect_error(model_runs(design, cur[-1, ], t), class = "wavevalid_error_input")
  expect_snapshot(model_runs(design, cur[, -1], t), error = TRUE)
  # non-increasing grid
  expect_error(model_runs(design, cur, rev(t)), class = "wavevalid_error_input")
  expect_error(field_runs(cur, c(t[1:10], t[9], t[12:64])), class = "wavevalid_error_input")
  # a repeated time stamp is a repeated measurement (averaged, see test-noise.R)
  expect_s3_class(suppressMessages(field_runs(cur, c(t[1:10], t[10], t[12:64]))), "wv_field")
  # NA inside a field curve is refused and located
  bad <- cur
  bad[2, 30] <- NA
  expect_error(field_runs(bad, t), class = "wavevalid_error_input")
  expect_snapshot(field_runs(bad, t), error = TRUE)
  # unnamed or non-numeric design columns
  expect_error(model_runs(matrix(1:5, ncol = 1), cur, t), class = "wavevalid_error_input")
  expect_error(model_runs(data.frame(a = letters[1:5]), cur, t), class = "wavevalid_error_input")
  expect_error(field_runs(cur, t, x_nom = 0.5), class = "wavevalid_error_input")
  expect_error(model_runs(design, "curves", t), class = "wavevalid_error_input")
})

test_that("failed runs are dropped with a warning naming them", {
  t <- seq(0, 1, length.out = 64)
  design <- data.frame(a = 1:5 / 6)
  cur <- make_curves(5, t)
  cur[2, ] <- NA
  cur[4, 50] <- Inf
  expect_warning(runs <- model_runs(design, cur, t), "runs 2 and 4", class = "wavevalid_warning_failed_runs")
  expect_equal(nrow(runs$design), 3L)
  expect_equal(runs$design$a, c(1, 3, 5) / 6)
  expect_equal(runs$curves$site1, make_curves(5, t)[c(1, 3, 5), ])
})

test_that("a non-dyadic grid is interpolated to the next dyadic grid with a message", {
  t <- seq(2, 7, length.out = 136)
  cur <- make_curves(3, t)
  expect_message(f <- field_runs(cur, t), "256 equally spaced")
  expect_length(f$t, 256L)
  expect_equal(range(f$t), c(2, 7))
  # linear interpolation reproduces a linear curve exactly
  lin <- rbind(3 * t + 1)
  # (a straight line holds no noise: read as interpolated from its two ends, with a warning)
  expect_warning(f2 <- suppressMessages(field_runs(lin, t)), class = "wavevalid_warning_interpolated")
  expect_equal(f2$curves$site1[1, ], 3 * f2$t + 1)
  # a dyadic grid stays untouched
  td <- 65 * (0:63) / 64
  expect_silent(field_runs(make_curves(2, td), td))
})
