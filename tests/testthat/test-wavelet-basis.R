# Small irregular curves: damped oscillations at two events plus AR noise.
small_bed <- function(n = 256, k = 6, r = 3) {
  t <- 10 * (0:(n - 1)) / n
  f <- function(a, b) {
    s1 <- pmax(t - 2, 0)
    s2 <- pmax(t - 6, 0)
    -a * (t > 2) * exp(-b * s1) * sin(2 * pi * s1) - 0.6 * a * (t > 6) * exp(-b * s2) * sin(2 * pi * s2)
  }
  design <- data.frame(a = seq(0.8, 1.2, length.out = k), b = seq(1.3, 0.7, length.out = k))
  runs1 <- t(mapply(f, design$a, design$b)) + 0.02 * t(replicate(k, cumsum(rnorm(n)) / 4))
  runs2 <- 0.5 * runs1 + 0.1
  field1 <- t(replicate(r, f(1, 1) + as.numeric(stats::filter(rnorm(n, sd = 0.03), 0.8, method = "recursive"))))
  field2 <- t(replicate(r, 0.5 * f(1, 1) + 0.1 + rnorm(n, sd = 0.02)))
  list(runs = model_runs(design, list(s1 = runs1, s2 = runs2), t),
       field = field_runs(list(s1 = field1, s2 = field2), t))
}

# Zero-filled transform with the given full coefficient vector, built with
# wavethresh's own accessors.
wr_of <- function(coef) {
  n <- length(coef)
  w <- wavethresh::wd(numeric(n), filter.number = 2, family = "DaubExPhase")
  w <- wavethresh::putC(w, 0, coef[1])
  for (l in 0:(log2(n) - 1)) w <- wavethresh::putD(w, l, coef[2^l + seq_len(2^l)])
  wavethresh::wr(w)
}

test_that("indices follow the wavethresh layout and the report's levels", {
  expect_equal(index_level(1:16), c(0, 1, 2, 2, 3, 3, 3, 3, rep(4, 8)))
  withr::local_seed(1)
  y <- cumsum(rnorm(64))
  w <- wavethresh::wd(y, filter.number = 2, family = "DaubExPhase")
  fc <- full_coef(y, list(filter.number = 2, family = "DaubExPhase"))
  expect_length(fc, 64)
  expect_equal(fc[1], wavethresh::accessC(w, 0))
  for (l in 0:5) expect_equal(fc[2^l + seq_len(2^l)], wavethresh::accessD(w, l))
  # orthonormal transform: energy is kept
  expect_equal(sum(fc^2), sum(y^2))
})

test_that("keeping every coefficient gives an exact round trip", {
  withr::local_seed(2)
  bed <- small_bed()
  b <- wavelet_basis(bed$runs, bed$field, fraction = 1)
  expect_equal(b$index, 1:256)
  m <- bed$runs$curves$s1
  expect_equal(basis_curves(b, basis_coef(b, m)), m, tolerance = 1e-9)
  expect_equal(wavelet_reconstruct(b, wavelet_coef(b, bed$field)), bed$field$curves, tolerance = 1e-9)
  chk <- reconstruction_check(b, bed$runs, bed$field)
  expect_lt(max(chk$rel_l2), 1e-9)
})

test_that("Psi has orthonormal columns and matches wavethresh's inverse transform", {
  withr::local_seed(3)
  bed <- small_bed()
  b <- wavelet_basis(bed$runs, bed$field)
  expect_equal(crossprod(b$Psi), diag(length(b$index)), tolerance = 1e-9)
  expect_equal(b$level, index_level(b$index))
  coef <- numeric(256)
  coef[b$index] <- rnorm(length(b$index))
  expect_equal(as.vector(b$Psi %*% coef[b$index]), wr_of(coef), tolerance = 1e-9)
  # basis_coef gives wavethresh's coefficients at the retained indices
  y <- bed$field$curves$s1[2, ]
  w <- wavethresh::wd(y, filter.number = 2, family = "DaubExPhase")
  full <- c(wavethresh::accessC(w, 0), unlist(lapply(0:7, function(l) wavethresh::accessD(w, l))))
  expect_equal(as.vector(basis_coef(b, y)), full[b$index], tolerance = 1e-9)
  expect_equal(unname(wavelet_coef(b, y)[1, ]), full[b$index], tolerance = 1e-9)
  expect_equal(colnames(wavelet_coef(b, y)), paste0("w", b$index))
})

test_that("I holds the whole kept levels and every curve's top coefficients, and nothing else", {
  withr::local_seed(4)
  bed <- small_bed()
  b <- wavelet_basis(bed$runs, bed$field, whole_levels = 0:3, fraction = 0.05, retain = "report")
  expect_true(all(1:8 %in% b$index))
  expected <- 1:8
  for (s in c("s1", "s2")) {
    for (m in list(bed$runs$curves[[s]], bed$field$curves[[s]])) {
      for (r in seq_len(nrow(m))) {
        a <- abs(full_coef(m[r, ], b$settings))
        top <- order(a, decreasing = TRUE)[seq_len(floor(0.05 * 256))]
        expect_true(all(top %in% b$index))
        expected <- union(expected, which(a >= stats::quantile(a, 0.95)))
      }
    }
  }
  expect_equal(b$index, sort(as.integer(expected)))
  expect_equal(b$index, sort(unique(unlist(b$by_site))))
  expect_true(all(lengths(b$by_site) <= length(b$index)))
  # with no thresholded coefficients, I is exactly the kept levels
  b0 <- wavelet_basis(bed$runs, bed$field, whole_levels = 0:4, fraction = 0, retain = "report")
  expect_equal(b0$index, 1:16)
  expect_equal(b0$level, c(0L, 1L, 2L, 2L, rep(3L, 4), rep(4L, 8)))
})

test_that("print and summary of a basis", {
  withr::local_seed(5)
  bed <- small_bed()
  b <- wavelet_basis(bed$runs, bed$field)
  expect_snapshot(print(b))
  expect_snapshot(print(summary(b)))
  # the levels: a point per retained coefficient at its level (the axis reversed: coarse at the top)
  pb <- plot_drawn(autoplot(b))
  expect_identical(pb$geoms, "GeomPoint")
  expect_identical(nrow(pb$data[[1]]), length(b$index))
  expect_equal(sort(-pb$data[[1]]$y), sort(b$level))
  expect_true(all(pb$data[[1]]$x >= min(b$t) & pb$data[[1]]$x <= max(b$t)))
  expect_identical(pb$labels$title, sprintf("%d retained wavelet coefficients", length(b$index)))
  # the reconstruction: the curve and its projection on the basis, with their relative L2 error
  y <- bed$field$curves$s1[1, ]
  pr <- plot_drawn(autoplot(b, type = "reconstruction", curve = y))
  expect_identical(pr$geoms, "GeomLine")
  expect_identical(nrow(pr$data[[1]]), 2L * length(b$t))
  expect_identical(length(unique(pr$data[[1]]$group)), 2L)
  yhat <- drop(b$Psi %*% c(basis_coef(b, y)))
  expect_equal(sort(pr$data[[1]]$y), sort(c(y, yhat)))
  expect_identical(pr$labels$title, sprintf("Relative L2 error %.3g", sqrt(sum((y - yhat)^2) / sum(y^2))))
})

test_that("reconstruction errors are the norm of the part outside the basis", {
  withr::local_seed(6)
  bed <- small_bed()
  b <- wavelet_basis(bed$runs, bed$field)
  chk <- reconstruction_check(b, bed$runs, bed$field)
  expect_equal(nrow(chk), 2 * (6 + 3))
  y <- bed$field$curves$s2[3, ]
  fc <- full_coef(y, b$settings)
  lost <- sqrt(sum(fc[-b$index]^2) / sum(y^2))
  row <- chk$site == "s2" & chk$source == "field" & chk$id == 3
  expect_equal(chk$rel_l2[row], lost, tolerance = 1e-9)
  # the plot of one reconstruction (by default the first field curve): the curve and its projection
  first <- which(chk$source == "field")[1]
  pc <- plot_drawn(autoplot(chk))
  expect_identical(pc$geoms, "GeomLine")
  expect_identical(nrow(pc$data[[1]]), 2L * length(b$t))
  expect_identical(pc$labels$title, sprintf("%s field %d: relative L2 error %.3g", chk$site[first], chk$id[first],
                                            chk$rel_l2[first]))
  y3 <- plot_drawn(autoplot(chk, which = which(row)))
  expect_equal(sort(y3$data[[1]]$y), sort(c(y, drop(b$Psi %*% c(basis_coef(b, y))))))
  expect_s3_class(summary(chk), "summary_wv_reconstruction")
})

test_that("error processes: residuals about the mean and draws from the coefficient model", {
  withr::local_seed(7)
  bed <- small_bed(r = 4)
  b <- wavelet_basis(bed$runs, bed$field)
  ep <- error_processes(b, bed$field, site = "s1", seed = 11)
  expect_identical(ep, error_processes(b, bed$field, site = "s1", seed = 11))
  d <- as.data.frame(ep)
  res <- d[d$process == "field residuals", ]
  expect_equal(as.vector(tapply(res$y, res$t, sum)), rep(0, 256), tolerance = 1e-9)
  w <- basis_coef(b, bed$field$curves$s1)
  expect_equal(attr(ep, "sigma2"), apply(w, 2, stats::var), tolerance = 1e-12)
  sim <- d[d$process == "simulated", ]
  sim_m <- unname(do.call(rbind, split(sim$y, sim$replicate)))
  # simulated processes lie in the span of the basis
  expect_equal(basis_curves(b, basis_coef(b, sim_m)), sim_m, tolerance = 1e-9)
  expect_s3_class(autoplot(ep), "ggplot")
  pr <- as.data.frame(error_processes(b, bed$field, site = "s1", seed = 11, project = TRUE))
  pr_m <- unname(do.call(rbind, split(pr$y[pr$process == "field residuals"], pr$replicate[pr$process == "field residuals"])))
  expect_equal(basis_coef(b, pr_m), sweep(w, 2, colMeans(w)), tolerance = 1e-9)
  one <- field_runs(bed$field$curves$s1[1, , drop = FALSE], bed$field$t)
  expect_error(error_processes(b, one), class = "wavevalid_error_input")
})

test_that("inputs are checked", {
  withr::local_seed(8)
  bed <- small_bed()
  cls <- "wavevalid_error_input"
  shifted <- field_runs(bed$field$curves, bed$field$t + 0.5)
  expect_error(wavelet_basis(bed$runs, shifted), class = cls)
  expect_snapshot(wavelet_basis(bed$runs, shifted), error = TRUE)
  short <- field_runs(lapply(bed$field$curves, function(m) m[, 1:128]), bed$field$t[1:128])
  expect_error(wavelet_basis(bed$runs, short), class = cls)
  odd <- new_wv_runs(bed$runs$design, bed$runs$t[1:100], lapply(bed$runs$curves, function(m) m[, 1:100]))
  expect_error(wavelet_basis(odd), class = cls)
  expect_error(wavelet_basis(bed$runs, whole_levels = 9), class = cls)
  # the old numbering of wavethresh's detail levels still works, one level lower, with a warning
  expect_warning(old <- wavelet_basis(bed$runs, bed$field, keep_levels = 0:1, retain = "report"),
                 class = "wavevalid_warning_deprecated")
  expect_identical(old$index, wavelet_basis(bed$runs, bed$field, whole_levels = 0:2, retain = "report")$index)
  expect_error(wavelet_basis(bed$runs, keep_lvls = 0:2), class = cls)
  expect_error(wavelet_basis(bed$runs, fraction = 1.5), class = cls)
  expect_error(wavelet_basis(bed$runs, family = "Haar"), class = cls)
  other_site <- field_runs(list(zz = bed$field$curves$s1), bed$field$t)
  expect_error(wavelet_basis(bed$runs, other_site), class = cls)
  expect_snapshot(wavelet_basis(bed$runs, other_site), error = TRUE)
  b <- wavelet_basis(bed$runs)
  expect_error(wavelet_coef(b, matrix(0, 2, 100)), class = cls)
  expect_error(wavelet_reconstruct(b, matrix(0, 2, length(b$index) + 1)), class = cls)
})

test_that("the error rule reconstructs the runs (median) and every field curve to their tolerance, on top of the report's rule", {
  withr::local_seed(9)
  bed <- small_bed()
  report <- wavelet_basis(bed$runs, bed$field, retain = "report")
  tol <- c(runs = 0.004, field = 0.3)
  b <- wavelet_basis(bed$runs, bed$field, tolerance = tol)
  expect_true(all(report$index %in% b$index))
  expect_gt(length(b$index), length(report$index))
  chk <- reconstruction_check(b, bed$runs, bed$field)
  run_err <- chk$rel_l2[chk$source == "run"]
  expect_lte(stats::median(run_err), tol[["runs"]] + 1e-12)
  expect_true(all(chk$rel_l2[chk$source == "field"] <= tol[["field"]] + 1e-12))
  # the report's rule alone leaves the median above the tolerance
  expect_gt(stats::median(reconstruction_check(report, bed$runs, bed$field)$rel_l2[chk$source == "run"]),
            tol[["runs"]])
  # the stored errors are those of reconstruction_check()
  expect_equal(b$error$rel_l2, chk$rel_l2, tolerance = 1e-9)
  # what the report's rule misses on its worst run, the error rule adds from
  # that run's largest coefficients first: the added set holds no coefficient
  # smaller than one it leaves out, for a single run on its own
  one <- model_runs(bed$runs$design[1, , drop = FALSE][c(1, 1), ] + c(0, 1e-3),
                    bed$runs$curves$s1[c(1, 1), ], bed$runs$t)
  b1 <- wavelet_basis(one, tolerance = c(runs = 0.004))
  r1 <- wavelet_basis(one, retain = "report")
  a <- abs(full_coef(one$curves$site1[1, ], b1$settings))
  added <- setdiff(b1$index, r1$index)
  left <- setdiff(seq_along(a), b1$index)
  expect_gte(min(a[added]), max(a[left]))
  # one coefficient fewer would not do
  expect_gt(sqrt(sum(a[c(left, added[which.min(a[added])])]^2) / sum(a^2)), 0.004)
  # a tolerance the report's rule meets (its errors here are 23-53%) keeps the
  # report's basis
  expect_lt(max(report$error$rel_l2), 0.6)
  loose <- wavelet_basis(bed$runs, bed$field, tolerance = c(runs = 0.6, field = 0.6))
  expect_identical(loose$index, report$index)
})

test_that("a noisy field curve is kept to its noise level, not beyond", {
  withr::local_seed(10)
  t <- seq(0, 1, length.out = 256)
  design <- data.frame(a = seq(0.8, 1.2, length.out = 5))
  runs <- model_runs(design, t(sapply(design$a, function(a) sin(2 * pi * a * t))), t)
  field <- field_runs(rbind(sin(2 * pi * t) + rnorm(256, sd = 0.2)), t)
  b <- wavelet_basis(runs, field, tolerance = c(runs = 0.01, field = 0.001))
  runs_only <- wavelet_basis(runs, tolerance = c(runs = 0.01))
  # the noise (sd 0.2, relative size about 0.27) cannot be reconstructed to
  # 0.1%: the field adds nothing once what is left out is at the noise level
  e <- b$error
  expect_gt(e$rel_l2[e$source == "field"], 0.001)
  expect_lt(length(b$index), 64)
  lost <- sqrt(mean((field$curves$site1 - wavelet_reconstruct(b, wavelet_coef(b, field))$site1)^2))
  expect_lte(lost, finest_level_sd(field$curves$site1[1, ], b$settings) + 1e-12)
  expect_true(all(runs_only$index %in% b$index))
})

test_that("wavelets on the interval: orthonormal, exact with every coefficient, no wrap-around", {
  withr::local_seed(11)
  bed <- small_bed()
  b <- wavelet_basis(bed$runs, bed$field, boundary = "interval", fraction = 1)
  expect_equal(b$index, 1:256)
  expect_equal(crossprod(b$Psi), diag(256), tolerance = 1e-9)
  m <- bed$runs$curves$s1
  expect_equal(basis_curves(b, basis_coef(b, m)), m, tolerance = 1e-9)
  y <- m[1, ]
  w <- wavethresh::wd(y, filter.number = 2, family = "DaubExPhase", bc = "interval", precond = FALSE)
  expect_equal(as.vector(basis_coef(b, y)), w$transformed.vector, tolerance = 1e-9)
  expect_equal(full_coef(y, b$settings), w$transformed.vector)
  # rises that end far from where they start: the periodic transform puts a
  # jump at the wrap-around, whose trace the reconstruction leaves at both ends
  t <- seq(0, 1, length.out = 256)
  rise <- model_runs(data.frame(a = 1:3), t(sapply(c(0.4, 0.5, 0.6), function(c) plogis((t - c) / 0.02))), t)
  ends <- c(1:4, 253:256)
  err <- vapply(c("periodic", "interval"), function(bc) {
    report <- wavelet_basis(rise, retain = "report", boundary = bc)
    bb <- wavelet_basis(rise, boundary = bc)
    rec <- wavelet_reconstruct(bb, wavelet_coef(bb, rise))$site1
    c(report = max(report$error$rel_l2), ends = max(abs(rec[, ends] - rise$curves$site1[, ends])))
  }, numeric(2))
  expect_lt(err["report", "interval"], err["report", "periodic"] / 3)
  expect_lt(err["ends", "interval"], err["ends", "periodic"] / 3)
  expect_match(paste(capture.output(print(wavelet_basis(rise, boundary = "interval"))), collapse = "\n"),
               "interval")
})

test_that("retention and boundary arguments are checked", {
  withr::local_seed(12)
  bed <- small_bed()
  cls <- "wavevalid_error_input"
  expect_error(wavelet_basis(bed$runs, retain = "all"), class = cls)
  expect_error(wavelet_basis(bed$runs, boundary = "symmetric"), class = cls)
  expect_error(wavelet_basis(bed$runs, tolerance = 0.01), class = cls)
  expect_error(wavelet_basis(bed$runs, tolerance = c(runs = 0)), class = cls)
  expect_error(wavelet_basis(bed$runs, tolerance = c(curves = 0.01)), class = cls)
  expect_error(wavelet_basis(bed$runs, family = "DaubLeAsymm", filter.number = 4, boundary = "interval"),
               class = cls)
  expect_snapshot(wavelet_basis(bed$runs, tolerance = c(runs = 2)), error = TRUE)
  # a partial tolerance keeps the other default
  expect_equal(wavelet_basis(bed$runs, tolerance = c(runs = 0.05))$settings$tolerance, c(runs = 0.05, field = 0.02))
})

test_that("large bases go through the transform and give the dense product's numbers", {
  withr::local_seed(13)
  for (b in c("periodic", "interval")) {
    s <- basis_settings(2048, 2, "DaubExPhase", 0:3, 0.025, boundary = b)
    idx <- sort(c(1:16, sample(17:2048, 600)))
    bas <- new_wv_basis(idx, index_level(idx), basis_matrix(idx, s), seq_len(2048), "a", s)
    expect_true(basis_uses_transform(bas))
    Y <- matrix(rnorm(3 * 2048), 3)
    W <- matrix(rnorm(3 * length(idx)), 3)
    expect_equal(basis_coef(bas, Y), Y %*% bas$Psi, tolerance = 1e-12)
    expect_equal(basis_curves(bas, W), tcrossprod(W, bas$Psi), tolerance = 1e-12)
    expect_equal(drop(basis_curves(bas, W[1, ])), drop(tcrossprod(W[1, ], bas$Psi)),
                 tolerance = 1e-12)
  }
  small <- new_wv_basis(1:8, index_level(1:8), basis_matrix(1:8, s), seq_len(2048), "a", s)
  expect_false(basis_uses_transform(small))
})
