test_that("pointwise bands cover the stated fraction of draws at each t", {
  withr::local_seed(1)
  Y <- matrix(stats::rnorm(2000 * 30, sd = rep(seq(0.5, 2, length.out = 30), each = 2000)), 2000, 30)
  q <- pointwise_quantiles(Y, c(0.05, 0.95))
  inside <- sweep(Y, 2, q[1, ], ">=") & sweep(Y, 2, q[2, ], "<=")
  expect_true(all(abs(colMeans(inside) - 0.9) < 0.002))
  expect_equal(q[1, ], unname(apply(Y, 2, stats::quantile, 0.05)))
  sim <- simultaneous_band(Y, 0.9)
  whole <- apply(sweep(Y, 2, sim$lower, ">=") & sweep(Y, 2, sim$upper, "<="), 1, all)
  expect_gte(mean(whole), 0.9)
  expect_true(all(sim$lower <= q[1, ] & sim$upper >= q[2, ]))
})

test_that("bias(), reality() and model_prediction() give tidy bands built from the draws", {
  ex <- example_problem()
  fit <- calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 2,
                   sampler = sampler_control(n_draws = 300, n_inner = 10, quiet = TRUE))
  b <- bias(fit)
  expect_named(b, c("site", "t", "mean", "lower", "upper", "lower_curve", "upper_curve"))
  expect_equal(nrow(b), length(fit$basis$t))
  expect_equal(b$mean, unname(colMeans(fit$wb$site1 %*% t(fit$basis$Psi))))
  expect_true(all(b$lower <= b$mean & b$mean <= b$upper))
  r <- reality(fit, level = 0.5, residual = FALSE)
  yR <- (fit$wM$site1 + fit$wb$site1) %*% t(fit$basis$Psi)
  expect_equal(r$upper, unname(apply(yR, 2, stats::quantile, 0.75)))
  expect_error(bias(fit, level = 1.2), class = "wavevalid_error_input")
  m <- model_prediction(fit)
  expect_true(all(c("site", "t", "mean", "lower", "upper", "error_lower", "error_upper") %in% names(m)))
  zhat <- colMeans(as.matrix(fit$draws)[, c("u1", "x1")])
  mhat <- gasp_bank_predict_cpp(fit$emulators$banks$site1, matrix(zhat, 1))$mean
  expect_equal(m$mean, drop(fit$basis$Psi %*% t(mhat)))
  expect_equal(m$lower, m$mean + m$error_lower)
  fr <- curve_draws(fit, "site1", "field_run", seed = 1)
  expect_identical(fr, curve_draws(fit, "site1", "field_run", seed = 1))
  expect_gt(mean(apply(fr, 2, stats::var)), mean(apply(yR, 2, stats::var)))
  # the bias plot: the 90% band (its ribbon and dashed edges), zero, and the mean, in the window only
  b90 <- bias(fit, 0.9)
  win <- b90[b90$t >= 0.1 & b90$t <= 0.5, ]
  pb <- plot_drawn(autoplot(fit, "bias", windows = list(c(0.1, 0.5))))
  expect_identical(pb$geoms, c("GeomRibbon", "GeomHline", "GeomLine", "GeomLine", "GeomLine"))
  expect_identical(nrow(pb$data[[1]]), nrow(win))
  expect_equal(pb$data[[1]]$ymin, win$lower)
  expect_equal(pb$data[[1]]$ymax, win$upper)
  expect_equal(pb$data[[2]]$yintercept, 0)
  expect_equal(pb$data[[3]]$y, win$lower)
  expect_equal(pb$data[[4]]$y, win$upper)
  expect_equal(pb$data[[5]]$y, win$mean)
  expect_identical(pb$labels$title, "Bias with 90% pointwise band")
  expect_identical(pb$labels$y, "bias")
  # the reality plot: the field's replicates, the band of reality, the model's prediction, the mean
  r90 <- reality(fit, 0.9)
  pr <- plot_drawn(autoplot(fit, "reality"))
  expect_identical(pr$geoms, c("GeomLine", "GeomRibbon", "GeomLine", "GeomLine", "GeomLine", "GeomLine"))
  expect_identical(nrow(pr$data[[1]]), length(fit$field$curves$site1))
  expect_identical(length(unique(pr$data[[1]]$group)), nrow(fit$field$curves$site1))
  expect_equal(pr$data[[2]]$ymin, r90$lower)
  expect_equal(pr$data[[2]]$ymax, r90$upper)
  expect_equal(pr$data[[3]]$y, model_prediction(fit, 0.9)$mean)
  expect_equal(pr$data[[6]]$y, r90$mean)
  expect_identical(pr$labels$title, "Bias-corrected prediction with 90% band")
})

test_that("the field detail outside the basis gets bands with their nominal coverage", {
  # a basis of 16 orthonormal columns in 128 points; truth with detail outside it
  set.seed(11)
  n_t <- 128
  Psi <- qr.Q(qr(matrix(stats::rnorm(n_t * 16), n_t)))
  truth <- stats::rnorm(n_t)
  detail <- truth - drop(Psi %*% crossprod(Psi, truth))
  band_cover <- function(R, H = 400) {
    Y <- matrix(truth, R, n_t, byrow = TRUE) + matrix(stats::rnorm(R * n_t, sd = 0.2), R)
    fit <- list(field = list(curves = list(a = Y)), basis = list(Psi = Psi),
                sigma2 = list(a = matrix(0.04, 10, 16)))
    E <- residual_draws(fit, "a", H)
    q <- apply(E, 2, stats::quantile, c(0.05, 0.95))
    mean(detail >= q[1, ] & detail <= q[2, ])
  }
  cover7 <- mean(replicate(150, band_cover(7)))
  cover3 <- mean(replicate(150, band_cover(3)))
  cover1 <- mean(replicate(150, band_cover(1)))
  # nominal 90%: Student t intervals with 7 and 3 replicates, known variance with one
  expect_gt(cover7, 0.87)
  expect_lt(cover7, 0.93)
  expect_gt(cover3, 0.86)
  expect_lt(cover3, 0.94)
  expect_gt(cover1, 0.87)
  expect_lt(cover1, 0.95)
  # replicates without spread: every draw is the mean's detail itself
  fit3 <- list(field = list(curves = list(a = matrix(truth, 3, n_t, byrow = TRUE))),
               basis = list(Psi = Psi), sigma2 = list(a = matrix(0.04, 10, 16)))
  expect_equal(colMeans(residual_draws(fit3, "a", 5)), detail)
})

test_that("curve summaries built by blocks of time points match the whole-matrix formulas", {
  withr::local_seed(4)
  # more values than one block holds
  Y <- matrix(stats::rnorm(2100 * 520), 2100)
  expect_gt(length(col_blocks(ncol(Y), nrow(Y))), 1L)
  expect_identical(unlist(col_blocks(ncol(Y), nrow(Y))), seq_len(ncol(Y)))
  sim <- simultaneous_band(Y, 0.9)
  centre <- colMeans(Y)
  s <- sqrt(colSums(sweep(Y, 2L, centre)^2) / (nrow(Y) - 1))
  score <- apply(abs(sweep(sweep(Y, 2L, centre), 2L, s, "/")), 1L, max)
  keep <- order(score)[seq_len(ceiling(0.9 * nrow(Y)))]
  expect_identical(sim$score, score)
  expect_identical(sim$lower, apply(Y[keep, ], 2L, min))
  expect_identical(sim$upper, apply(Y[keep, ], 2L, max))
  expect_equal(pointwise_quantiles(Y, 0.95)[1, ], unname(apply(Y, 2L, stats::quantile, 0.95)))

  # detail draws: G D scaled by draw, or white noise drawn block by block
  n_t <- 128
  H <- 9000
  Psi <- qr.Q(qr(matrix(stats::rnorm(n_t * 16), n_t)))
  truth <- stats::rnorm(n_t)
  outside <- function(M) M - M %*% Psi %*% t(Psi)
  reps <- matrix(truth, 3, n_t, byrow = TRUE) + matrix(stats::rnorm(3 * n_t, sd = 0.2), 3)
  fit <- list(field = list(curves = list(a = reps)), basis = list(Psi = Psi),
              sigma2 = list(a = matrix(0.04, 10, 16)))
  expect_gt(length(col_blocks(n_t, H)), 1L)
  E <- withr::with_seed(7, residual_draws(fit, "a", H))
  expected <- withr::with_seed(7, {
    G <- matrix(stats::rnorm(H * 3, sd = sqrt(1 / 3 / 2)), H)
    chi <- sqrt(2 / stats::rchisq(H, 2))
    D <- outside(sweep(reps, 2L, colMeans(reps)))
    sweep((G %*% D) * chi, 2L, drop(outside(matrix(colMeans(reps), 1L))), `+`)
  })
  expect_equal(E, expected)
  fit$field$curves$a <- reps[1, , drop = FALSE]
  E1 <- withr::with_seed(7, residual_draws(fit, "a", H, new_run = TRUE))
  expected1 <- withr::with_seed(7, matrix(stats::rnorm(H * n_t), H) * sqrt(2 * 0.04))
  expect_equal(E1, sweep(expected1, 2L, drop(outside(reps[1, , drop = FALSE])), `+`))
  # a second pass over the blocks gives the same draws, and the stream ends as after one pass
  withr::with_seed(7, {
    src <- curve_source(H, n_t, residual_source(fit, "a", H, new_run = TRUE))
    first <- source_matrix(src)
    second <- source_matrix(src)
    after <- stats::runif(1)
  })
  expect_identical(second, first)
  expect_identical(first, E1)
  expect_identical(after, withr::with_seed(7, {
    stats::rnorm(H * n_t)
    stats::runif(1)
  }))
})

test_that("predictions rebuilt by blocks of time points match the draws computed at once", {
  ex <- example_problem()
  fit <- calibrate(ex$emulators, ex$field, ex$iu, chains = 1, seed = 5,
                   sampler = sampler_control(n_draws = 40, n_inner = 5, quiet = TRUE))
  # repeat the draws so that one site's curves span several blocks
  H <- 40000
  idx <- rep_len(seq_len(nrow(fit$wM$site1)), H)
  for (w in c("wM", "wb", "sigma2")) fit[[w]]$site1 <- fit[[w]]$site1[idx, , drop = FALSE]
  Psi <- fit$basis$Psi
  expect_gt(length(col_blocks(nrow(Psi), H)), 1L)
  yM <- fit$wM$site1 %*% t(Psi)
  yR <- (fit$wM$site1 + fit$wb$site1) %*% t(Psi)
  re <- predict(fit, type = "reality", residual = FALSE, keep_draws = TRUE, seed = 1)
  expect_equal(unname(re$draws$site1), unname(yR))
  # bands from curves rebuilt on demand equal those of the kept draws
  expect_identical(predict(fit, type = "reality", residual = FALSE, seed = 1)$summary, re$summary)
  fr <- predict(fit, type = "field_run", keep_draws = TRUE, seed = 2)
  expect_identical(predict(fit, type = "field_run", seed = 2)$summary, fr$summary)
  cols <- c("lower", "upper", "lower_curve", "upper_curve")
  expect_identical(as.list(fr$summary[cols]),
                   as.list(band_frame(fr$draws$site1, fit$basis$t, "site1", 0.9)[cols]))
  model <- function(u, x) (1 + 0.5 * x) * sin(2 * pi * ex$field$t) + u * exp(-((ex$field$t - 0.6) / 0.08)^2)
  pair <- model_runs(data.frame(u1 = c(0.5, 0.5), x1 = c(0.5, 0.7)), rbind(model(0.5, 0.5), model(0.5, 0.7)),
                     ex$field$t, site = "site1")
  D <- pair$curves$site1[2, ] - pair$curves$site1[1, ]
  al <- predict(fit, type = "added_load", new_runs = pair, bias = "multiplicative", noise = FALSE,
                residual = FALSE, keep_draws = TRUE, seed = 1)
  yNew <- sweep(yM, 2L, D, `+`)
  small <- abs(yM) < 0.01 * apply(abs(yM), 1L, max)
  expected <- yNew * yR / yM
  expected[small] <- (yNew + yR - yM)[small]
  expect_equal(unname(al$draws$site1), unname(expected))
  expect_equal(unname(al$n_guarded), sum(small))
})

test_that("curve draws rebuilt in stretches from the wavelets not zero there equal the dense product", {
  withr::local_seed(5)
  s <- basis_settings(512, 2, "DaubExPhase", 0:3, 0.025)
  idx <- sort(c(1:16, sample(17:512, 180)))
  Psi <- basis_matrix(idx, s)
  W <- matrix(stats::rnorm(7 * length(idx)), 7)
  for (cols in list(37:300, 1:512, 5L, 480:512)) {
    expect_equal(basis_curves_block(W, Psi, cols), tcrossprod(W, Psi[cols, , drop = FALSE]),
                 tolerance = 1e-13)
  }
  W2 <- matrix(stats::rnorm(7 * length(idx)), 7)
  expect_equal(linear_block(list(W = W, B = Psi, W2 = W2, B2 = Psi), 101:260),
               tcrossprod(W + W2, Psi[101:260, ]), tolerance = 1e-13)
})

test_that("curve summaries shared out among threads give the numbers of one thread to the bit", {
  withr::local_seed(6)
  s <- basis_settings(512, 2, "DaubExPhase", 0:3, 0.025)
  idx <- sort(c(1:16, sample(17:512, 180)))
  Psi <- basis_matrix(idx, s)
  H <- 400
  W <- matrix(stats::rnorm(H * length(idx)), H)
  W2 <- matrix(stats::rnorm(H * length(idx), sd = 0.1), H)
  offset <- stats::rnorm(512)
  none <- matrix(0, 0L, 0L)
  probs <- c(0.05, 0.5, 0.95)
  # a block whose length is not a multiple of the stretches of 32 points, a
  # block of fewer points than stretches for the threads, and a given block
  for (cols in list(23:411, 1:512, 470:500)) {
    run <- function(threads, given = FALSE) {
      out <- block_outputs(512, length(probs), 21L)
      st <- if (given) {
        Y <- tcrossprod(W, Psi[cols, , drop = FALSE])
        band_block_into_cpp(Y, none, none, none, none, cols, numeric(), probs, 21L, out, TRUE, threads)
      } else {
        band_block_into_cpp(none, W, Psi, W2, Psi, cols, offset, probs, 21L, out, TRUE, threads)
      }
      list(st = st, out = lapply(out, function(v) if (is.matrix(v)) v[, cols] else v[cols]))
    }
    for (given in c(FALSE, TRUE)) {
      one <- run(1L, given)
      expect_true(all(is.finite(one$st$zmax)))
      for (threads in c(2L, 3L, 7L)) expect_identical(run(threads, given), one)
    }
  }
  # the statistics themselves: the pointwise mean and quantiles of the rebuilt draws
  Y <- tcrossprod(W + W2, Psi[23:411, ]) + rep(offset[23:411], each = H)
  out <- block_outputs(512, length(probs), 0L)
  st <- band_block_into_cpp(none, W, Psi, W2, Psi, 23:411, offset, probs, 0L, out, TRUE, 3L)
  expect_equal(out$mean[23:411], colMeans(Y), tolerance = 1e-12)
  expect_equal(out$q[, 23:411], unname(apply(Y, 2L, stats::quantile, probs)), tolerance = 1e-12)
  sd <- sqrt(colSums(sweep(Y, 2L, colMeans(Y))^2) / (H - 1))
  expect_equal(st$zmax, apply(abs(sweep(sweep(Y, 2L, colMeans(Y)), 2L, sd, "/")), 1L, max), tolerance = 1e-10)
  expect_equal(st$smin, min(sd), tolerance = 1e-12)
  # a draw that is not a number, in any thread's stretch, is an error on R's thread
  for (j in c(30L, 400L)) {
    Yn <- tcrossprod(W, Psi[1:512, ])
    Yn[5, j] <- NaN
    expect_error(band_block_into_cpp(Yn, none, none, none, none, 1:512, numeric(), probs, 0L,
                                     block_outputs(512, length(probs), 0L), TRUE, 4L), "NaN")
  }
  # the threads: those set by options(wavevalid.workers = ), else the cores R may use
  withr::local_options(wavevalid.workers = 1)
  expect_identical(band_threads(), 1L)
  withr::local_options(wavevalid.workers = 3)
  expect_identical(band_threads(), 3L)
  withr::local_options(wavevalid.workers = "auto")
  expect_identical(band_threads(), max(1L, as.integer(future::availableCores())))
})
