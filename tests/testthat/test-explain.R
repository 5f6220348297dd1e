test_that("explain_bias weighs each coefficient by the tau2 of its group, pooled levels included", {
  ex <- example_problem()
  lv <- sort(unique(ex$emulators$basis$level))
  pool <- lv[1:2]
  fit <- calibrate(ex$emulators, ex$field, ex$iu, n_draws = 20, n_inner = 5, chains = 1, seed = 1,
                   pool_levels = pool, quiet = TRUE)
  d <- as.matrix(fit$draws)
  V <- wavevalid:::bias_level_variances(fit, d)
  name <- sprintf("tau2[site1:%d-%d]", pool[1], pool[2])
  pooled <- fit$basis$level %in% pool
  expect_equal(unname(V[, pooled]), matrix(d[, name], nrow(d), sum(pooled)))
  other <- which(!pooled)[1]
  expect_equal(unname(V[, other]), unname(d[, sprintf("tau2[site1:%d]", fit$basis$level[other])]))
  t <- ex$field$t
  out <- explain_bias(fit, list(bump = exp(-((t - 0.25) / 0.05)^2)), n_draws = 10, seed = 1)
  expect_s3_class(out, "wv_explain")
})
