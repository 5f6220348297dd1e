# Curves of their own extent: each field curve observed where it was
# measured, missing beyond its end.

long_cut <- function(ends, t = seq(0, 1, length.out = 64)) {
  do.call(rbind, lapply(seq_along(ends), function(r) {
    tt <- t[t <= ends[r]]
    data.frame(rep = paste0("R", r), t = tt, y = sin(2 * pi * tt) + 0.01 * r)
  }))
}

test_that("curves that end at different times keep the longest record, each observed over its own extent", {
  d <- long_cut(c(1, 0.5, 0.75))
  f <- suppressMessages(field_runs(d, t = "t", y = "y", replicate = "rep"))
  expect_equal(range(f$t), c(0, 1))
  obs <- f$observed$site1
  expect_identical(dim(obs), dim(f$curves$site1))
  expect_true(all(obs[1, ]))
  expect_true(all(!obs[2, f$t > 0.5 + diff(f$t[1:2])]))
  expect_true(all(obs[2, f$t <= 0.5]))
  # where a curve is missing it holds the mean of the curves that cover the point
  j <- which(!obs[2, ] & obs[3, ])
  expect_equal(f$curves$site1[2, j], colMeans(f$curves$site1[c(1, 3), j]))
  # the message says so
  expect_message(field_runs(d, t = "t", y = "y", replicate = "rep"), "longest record")
  # curves of one extent carry no mask
  g <- suppressMessages(field_runs(long_cut(c(1, 1, 1)), t = "t", y = "y", replicate = "rep"))
  expect_null(g$observed)
  # a grid that reaches beyond every curve: nothing is observed there
  h <- suppressMessages(field_runs(long_cut(c(0.6, 0.6)), t = "t", y = "y", replicate = "rep",
                                   grid = seq(0, 1, length.out = 64)))
  expect_true(all(!h$observed$site1[, h$t > 0.62]))
  # a curve that covers too little of the grid is refused, by its id
  dense <- rbind(long_cut(1), data.frame(rep = "R2", t = seq(0, 0.3, length.out = 20), y = 0))
  err <- expect_error(suppressMessages(field_runs(dense, t = "t", y = "y", replicate = "rep",
                                                  grid = seq(0, 1, length.out = 16))),
                      class = "wavevalid_error_grid")
  expect_match(cli::ansi_strip(conditionMessage(err)), "rep R2", fixed = TRUE)
})

test_that("a matrix with NA after a curve's end (or before its start) holds curves of their own extent", {
  t <- seq(0, 1, length.out = 64)
  m <- rbind(sin(2 * pi * t), cos(2 * pi * t), sin(2 * pi * t) + 0.1)
  m[2, 41:64] <- NA
  m[3, 1:5] <- NA
  f <- suppressMessages(field_runs(m, t))
  expect_identical(f$t, t)
  expect_identical(unname(rowSums(f$observed$site1)), c(64, 40, 59))
  expect_true(all(is.finite(f$curves$site1)))
  expect_equal(f$curves$site1[1, ], m[1, ])
  expect_output(print(f), "own extent \\(40 to 64 of 64 points\\)")
  # a gap inside a curve is still refused
  m[1, 20] <- NA
  expect_error(field_runs(m, t), class = "wavevalid_error_input")
})

test_that("a bias-variance group with fewer than three coefficients of data joins the nearest that has three", {
  level <- c(0, 4, 5, 6)
  group <- c(1, 1, 2, 2, 2, 3, 3, 3, 4, 4)
  no_data <- c(TRUE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, FALSE, TRUE, TRUE)
  expect_identical(wavevalid:::pool_data_free(group, level, no_data), c(2, 2, 2, 2, 2, 3, 3, 3, 3, 3))
  # a tie goes to the finer level; without a group of three, nothing moves
  expect_identical(wavevalid:::pool_data_free(c(1, 2, 2, 2, 3, 3, 3), c(5, 4, 6), c(TRUE, rep(FALSE, 6))),
                   c(3, 2, 2, 2, 3, 3, 3))
  expect_identical(wavevalid:::pool_data_free(c(1, 2), c(0, 1), c(FALSE, TRUE)), c(1, 2))
})

test_that("a coefficient is weighted by the curves that cover it: none, no weight", {
  b <- example_problem(1)$emulators$basis
  T <- length(b$t)
  h <- T / 2
  m <- rbind(sin(seq_len(T)), cos(seq_len(T)))
  obs <- matrix(TRUE, 2, T)
  obs[2, (h + 1):T] <- FALSE
  fv <- wavevalid:::missing_fill_variance(m, obs, b$Psi)
  inside <- colSums(b$Psi[(h + 1):T, , drop = FALSE]^2) == 0
  expect_true(any(inside))
  expect_equal(fv$var[inside], rep(0, sum(inside)))
  expect_true(all(fv$var[!inside] > 0))
  # the extra variance of a point held by one of two curves: sigma2 / 2
  s2 <- mean(apply(m[, 1:h], 2, stats::var))
  expect_equal(fv$point[(h + 1):T], rep(s2 / 2, T - h))
  q <- (T - T / 4 + 1):T
  obs[, q] <- FALSE
  fv2 <- wavevalid:::missing_fill_variance(m, obs, b$Psi)
  expect_true(all(fv2$point[q] > 1e5 * max(m^2)))
  expect_false(any(fv2$covered[q]))
})

test_that("curves cut short on a grid beyond them: the right model is not rejected and the inputs hold", {
  tb <- testbed_dosing(1, "none")
  t <- tb$A$runs$t
  m <- tb$A$field$curves$plasma
  ends <- withr::with_seed(1, stats::runif(nrow(m), 0.5, 1)) * max(t)
  for (r in seq_len(nrow(m))) m[r, t > ends[r]] <- NA
  f <- suppressMessages(field_runs(list(plasma = m), t))
  beyond <- t > max(ends) + diff(t[1:2])
  expect_true(any(beyond))
  expect_true(all(!f$observed$plasma[, beyond]))
  expect_message(fit <- suppressWarnings(validate(tb$A$runs, f, tb$iu, windows = tb$windows, chains = 1, seed = 1,
                                                  sampler = sampler_control(n_draws = 100, n_inner = 10,
                                                                            quiet = TRUE))),
                 class = "wavevalid_message_own_extent")
  mc <- misfit_check(fit)
  expect_false(any(mc$covered[beyond]))
  expect_false(any(mc$rejected))
  wf <- where_fails(fit)
  nd <- attr(wf, "no_data")
  expect_equal(nd$end, max(t))
  expect_lt(nd$start, min(t[beyond]) + 1e-9)
  expect_output(print(wf), "No field data")
  # a bias-variance group with no data is pooled with its neighbour: the bias stays the size of the data's
  expect_lt(max(abs(bias(fit)$mean)), 0.2 * diff(range(m, na.rm = TRUE)))
  ci <- summary(fit)$inputs
  u <- tb$truth$u
  ci <- ci[match(names(u), ci$input), ]
  expect_true(all(u >= ci$q2.5 & u <= ci$q97.5))
  # where no coefficient has data, a classed error says how to cut the runs
  tc <- testbed_units(2)
  tt <- tc$A$runs$t
  mm <- tc$A$field$curves$site1
  mm[, tt > 0.6 * max(tt)] <- NA
  fc <- suppressMessages(field_runs(mm, tt, units = tc$A$field$units))
  expect_error(suppressWarnings(validate(tc$A$runs, fc, tc$iu, chains = 1, seed = 1,
                                         sampler = sampler_control(n_draws = 20, n_inner = 2, quiet = TRUE))),
               class = "wavevalid_error_own_extent")
})

test_that("registration takes a replicate's landmarks only in windows its curve covers", {
  tt <- seq(0, 10, length.out = 128)
  bump <- function(c) exp(-(tt - c)^2)
  runs_t <- tt
  ref <- rbind(bump(3) + bump(7))
  d <- do.call(rbind, lapply(1:3, function(r) {
    keep <- if (r == 2) tt <= 5.5 else rep(TRUE, length(tt))
    data.frame(rep = r, t = tt[keep], y = (bump(3 + 0.1 * r) + bump(7 - 0.1 * r))[keep])
  }))
  f <- suppressMessages(field_runs(d, t = "t", y = "y", replicate = "rep", grid = tt))
  reg <- expect_no_warning(register_curves(f, reference = list(site1 = ref[1, ]), windows = list(c(1.5, 4.5), c(5.5, 8.5)),
                                                features = "max"))
  w <- reg$warps
  expect_false(any(w$replicate == 2 & w$window %in% 2))
  expect_true(any(w$replicate == 1 & w$window %in% 2))
  expect_true(all(!reg$observed$site1[2, tt > 6]))
})

test_that("a held-out field of its own extent is graded where it was measured", {
  fit <- example_fit()
  fld <- fit$field
  m <- fld$curves$site1
  m[1, (ncol(m) - 20):ncol(m)] <- NA
  f <- suppressMessages(field_runs(m, fld$t))
  expect_false(is.null(f$observed))
  g <- f
  g$curves$site1[!f$observed$site1] <- 1e6
  pred <- predict(fit, type = "field_run", seed = 1)
  expect_equal(wavevalid:::holdout_metrics(pred, g), wavevalid:::holdout_metrics(pred, f))
  fit2 <- example_fit(2)
  a <- suppressWarnings(compare_validations(fit, fit2, holdout = f, seed = 1, n_boot = 100))
  b <- suppressWarnings(compare_validations(fit, fit2, holdout = g, seed = 1, n_boot = 100))
  num <- function(x) {
    d <- as.data.frame(unclass(x)[c("before", "after")])
    d[] <- lapply(d, as.numeric)
    d
  }
  expect_equal(num(a), num(b))
  hr <- function(x) as.data.frame(attr(x, "holdout_ratio"))[c("ratio", "lower", "upper")]
  expect_equal(hr(a), hr(b))
})
