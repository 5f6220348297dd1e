# The emulators' leave-one-out residuals: the long table (loo_residuals()),
# each bank's errors, and their sums by coefficient and by level.

#' Leave-one-out residuals of GASP emulators
#'
#' Studentised leave-one-out cross-validation residuals of every emulator in
#' closed form, with the hyperparameters and `mu` fixed at their estimates:
#' for run k, the prediction error is `e_k = [R^-1 (y - mu)]_k / [R^-1]_kk`
#' and its variance `1 / (lambda [R^-1]_kk)`.
#'
#' @inheritParams augment_emulators
#' @return A data frame with one row per site, coefficient and run: `site`,
#'   `index`, `level`, `run`, `observed`, `predicted` (LOO mean), `sd` (LOO
#'   standard deviation) and `residual` (`(observed - predicted) / sd`). Flat
#'   emulators give `NA` residuals.
#' @export
#' @examples
#' t <- seq(0, 1, length.out = 64)
#' design <- data.frame(a = seq(0, 1, length.out = 8), b = c(3, 7, 1, 5, 8, 2, 6, 4) / 8)
#' curves <- t(apply(design, 1, function(z) sin(2 * pi * t * (1 + z[1])) + z[2] * t))
#' runs <- model_runs(design, curves, t)
#' em <- fit_emulators(runs, wavelet_basis(runs))
#' head(loo_residuals(em))
loo_residuals <- function(emulators, ...) {
  if (...length()) {
    call <- renamed_arg(sys.call(), "object", "emulators", "loo_residuals")
    if (!is.null(call)) return(eval(call, parent.frame()))
    check_dots_none(...)
  }
  check_class(emulators, "wv_emulators")
  out <- lapply(names(emulators$banks), function(s) {
    b <- emulators$banks[[s]]
    p <- emulators$params[emulators$params$site == s, , drop = FALSE]
    k <- nrow(b$X)
    n <- length(b$mu)
    if (n == 0L) return(NULL)
    lo <- bank_loo(b)
    e <- as.vector(lo$e)
    sd <- as.vector(lo$sd)
    observed <- as.vector(b$y)
    flat <- rep(!is.finite(p$loglik), each = k)
    data.frame(site = s, index = rep(p$index, each = k), level = rep(p$level, each = k),
               run = rep(seq_len(k), n),
               observed = observed, predicted = observed - e, sd = sd,
               residual = ifelse(flat, NA_real_, e / sd), stringsAsFactors = FALSE)
  })
  out <- do.call(rbind, out)
  rownames(out) <- NULL
  out
}

# The leave-one-out errors `e` of a bank's coefficients at its design points
# and their standard deviations `sd` (runs x coefficients), from diag(R^-1)
# of each coefficient.
bank_loo <- function(b) {
  k <- nrow(b$X)
  n <- length(b$mu)
  # diag(R^-1) once per distinct factor, colSums(forwardsolve(L, diag(k))^2)
  # to the bit
  of <- b$chol_of %||% seq_len(n)
  own <- gasp_inverse_diag_cpp(b$chol)
  Ri_diag <- own[, of, drop = FALSE]
  list(e = b$weights / Ri_diag, sd = sqrt(1 / (rep(b$lambda, each = k) * Ri_diag)))
}

# The leave-one-out errors of an emulator bank's coefficients at its design
# points, studentised (runs x coefficients; 0 for flat emulators).
bank_loo_errors <- function(b) {
  if (length(b$mu) == 0L) return(matrix(0, nrow(b$X), 0L))
  lo <- bank_loo(b)
  out <- lo$e / lo$sd
  out[!is.finite(out)] <- 0
  out
}

# Studentised residuals (a data frame with columns site, level and residual,
# as from loo_residuals() or heldout_residuals()) summed up by the site and
# level groups of the emulator parameters `p` (level_stats()).
residual_stats_by_level <- function(p, res) {
  groups <- level_groups(p)
  ok <- is.finite(res$residual)
  g <- factor(paste(res$site, res$level, sep = "\r")[ok], levels = groups$key)
  r <- res$residual[ok]
  sum_by <- function(x) as.vector(tapply(x, g, sum, default = 0))
  level_stats(p, groups, as.vector(table(g)), sum_by(r^2), sum_by(abs(r) > 3))
}

# The site and level groups of the emulator parameters `p`, in the order of
# their first appearance: their keys and each one's first row.
level_groups <- function(p) {
  key <- paste(p$site, p$level, sep = "\r")
  groups <- unique(key)
  list(key = groups, of_row = match(key, groups), first = match(groups, key))
}

# By group: its site and level, the number n of finite residuals, their mean
# square and their share beyond 3 in absolute value (NA for a group without
# one), from the sums of squares `sq` and the counts beyond 3 `b3`.
level_stats <- function(p, groups, n, sq, b3) {
  per <- function(x) ifelse(n > 0, x / pmax(n, 1), NA_real_)
  data.frame(site = p$site[groups$first], level = p$level[groups$first], n = as.integer(n),
             mean_square = per(sq), beyond_3 = per(b3), stringsAsFactors = FALSE)
}

# The leave-one-out studentised residuals of every coefficient summed over
# its runs, from each bank's runs x coefficients matrix (the long table of
# loo_residuals(), 30 million rows at 16 sites x 500 runs x 3800
# coefficients, is not built): a matrix with one row per row of
# emulators$params and columns n (finite residuals), sq (their sum of
# squares), beyond_3 and within_90 (counts of |r| > 3 and |r| <= qnorm(0.95)).
loo_sums <- function(emulators) {
  p <- emulators$params
  out <- matrix(0, nrow(p), 4L, dimnames = list(NULL, c("n", "sq", "beyond_3", "within_90")))
  for (s in names(emulators$banks)) {
    b <- emulators$banks[[s]]
    if (!length(b$mu)) next
    at <- which(p$site == s)
    lo <- bank_loo(b)
    r <- lo$e / lo$sd
    r[, !is.finite(p$loglik[at])] <- NA
    ok <- is.finite(r)
    r[!ok] <- 0
    out[at, ] <- cbind(colSums(ok), colSums(r^2), colSums(abs(r) > 3),
                       colSums(ok & abs(r) <= stats::qnorm(0.95)))
  }
  out
}

# The leave-one-out studentised residuals summed up by site and level as
# residual_stats_by_level() sums those of loo_residuals().
loo_stats_by_level <- function(emulators) {
  p <- emulators$params
  groups <- level_groups(p)
  sums <- unname(rowsum(loo_sums(emulators), groups$of_row, reorder = TRUE))
  level_stats(p, groups, sums[, 1], sums[, 2], sums[, 3])
}

# Leave-one-out studentised residuals summed up by level (pooled over the
# sites): number, mean square and share inside +-1.645 (the 90% interval).
loo_check <- function(em) {
  sums <- rowsum(loo_sums(em), em$params$level, reorder = TRUE)
  sums <- sums[sums[, "n"] > 0, , drop = FALSE]
  if (!nrow(sums)) return(NULL)
  data.frame(level = as.integer(rownames(sums)), n = as.integer(sums[, "n"]),
             mean_square = unname(sums[, "sq"] / sums[, "n"]),
             cover90 = unname(sums[, "within_90"] / sums[, "n"]))
}
