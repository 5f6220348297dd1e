# Peak memory of the curve summaries of a large fit: 4 sites x 4096 time
# points x 4000 posterior draws. Curves are rebuilt from the coefficient draws
# one site at a time, so the peak should stay a small multiple of one site's
# curve matrix (4096 x 4000 doubles = 125 MiB), well below all four sites'
# curves (500 MiB).
#
# The fit is synthesised cheaply: a problem with four sites on 4096 points and
# 12 runs is calibrated with a short chain, and its 40 saved draws (inputs,
# model and bias coefficients, field variances) are repeated and slightly
# perturbed up to 4000 draws.
#
# The peer, run side by side: the same summary of the bias in plain R, each
# site's curve draws built whole (coefficient draws %*% t(Psi)) and their
# pointwise mean and 5% and 95% quantiles taken; the ratio of the package's
# peak to the plain-R peak is printed.
#
# Two measures are printed for each call: R's own high-water mark of vector
# memory (gc(reset = TRUE) before, "max used" after, minus what was in use
# before the call) and the growth of the process's peak resident set
# (/proc/self/status VmHWM, reset through /proc/self/clear_refs where the
# kernel allows it).
#
# Measured on a 2-core machine (R 4.2, reference BLAS), growth of R's vector
# memory above what was in use before each call:
#   curves rebuilt whole per site, with whole-matrix summaries:
#     bias() 804 MiB, reality() 900 MiB, predict(field_run) 896 MiB,
#     where_fails() 803 MiB: up to 7.2 x one site's curves (1.8 x all four);
#   curves rebuilt on demand by blocks of time points (this version):
#     bias() 104 MiB, reality() 103 MiB, model_prediction() 104 MiB,
#     predict(reality / field_run) 131 MiB, where_fails() 134 MiB:
#     at most 1.07 x one site's curves (0.27 x all four). Most of it is
#     garbage from the blocks not yet collected; the curves held at any time
#     are one block of about 2^20 values (8 MiB).
#   (later, on a busier machine, the same version measured 330-366 MiB and
#   35-105 s per call: three passes over the blocks, each rebuilding them);
#   one pass over the blocks in C++ (the product from the basis functions not
#   zero on the block, the statistics written in place): bias() 190 MiB,
#   reality() 220 MiB, model_prediction() 227 MiB, predict() 246-329 MiB,
#   where_fails() 331 MiB, in 2.1-4.8 s each (bias() 0.08-0.16 x the time of
#   the plain-R peer).
#
# Run: Rscript bench/bench_memory.R [n_draws]
library(wavevalid)
options(wavevalid.quiet = TRUE)
args <- commandArgs(trailingOnly = TRUE)
H <- if (length(args) >= 1) as.integer(args[1]) else 4000L
n_t <- 4096L
sites <- paste0("site", 1:4)
mib <- function(bytes) bytes / 2^20

# --- a small real fit on the full grid ------------------------------------------
set.seed(1)
t <- 65 * (0:(n_t - 1L)) / n_t
iu <- iu_map(c("u1", "x1"), c("calibration", "variation"), lower = c(0, 0), upper = c(1, 1),
             nominal = c(0.5, 0.5))
model <- function(u, x, k) {
  (1 + 0.5 * x) * sin(2 * pi * t / (13 + k)) + u * exp(-((t - 7 - 8 * k) / 1.5)^2)
}
design <- data.frame(u1 = (0:11 + stats::runif(12)) / 12, x1 = (sample(12) - stats::runif(12)) / 12)
run_curves <- list()
curves <- list()
for (k in seq_along(sites)) {
  run_curves[[sites[k]]] <- t(apply(as.matrix(design), 1, function(z) model(z[1], z[2], k)))
  truth <- model(0.3, 0.55, k) + 0.1 * exp(-((t - 30 - 5 * k) / 0.8)^2)
  curves[[sites[k]]] <- t(replicate(4, truth + stats::rnorm(n_t, sd = 0.03)))
}
runs <- model_runs(design, run_curves, t)
field <- field_runs(curves, t, x_nom = c(x1 = 0.5))
basis <- wavelet_basis(runs, field)
emulators <- suppressWarnings(fit_emulators(runs, basis))
small <- suppressWarnings(calibrate(emulators, field, iu, chains = 1, seed = 1,
                                    sampler = sampler_control(n_draws = 40, n_inner = 5, burnin = 200)))

# --- repeat and perturb its draws up to H -------------------------------------
grow <- function(m, sd_rel = 0.02) {
  idx <- rep_len(seq_len(nrow(m)), H)
  out <- m[idx, , drop = FALSE]
  s <- apply(m, 2, stats::sd)
  out + sd_rel * matrix(stats::rnorm(length(out)), H) * rep(s, each = H)
}
fit <- small
fit$wM <- lapply(small$wM, grow)
fit$wb <- lapply(small$wb, grow)
fit$sigma2 <- lapply(small$sigma2, function(m) m[rep_len(seq_len(nrow(m)), H), , drop = FALSE])
dm <- as.matrix(small$draws)
draws <- dm[rep_len(seq_len(nrow(dm)), H), , drop = FALSE]
draws[, fit$inputs] <- pmin(pmax(grow(dm[, fit$inputs, drop = FALSE]), 0), 1)
fit$draws <- coda::mcmc.list(coda::mcmc(draws))
fit$chain <- rep(1L, H)
fit$settings$n_draws <- H
rm(small, draws, dm, curves, run_curves)

one_site <- mib(8 * n_t * H)
cat(sprintf("Fit: %d sites x %d time points x %d draws, %d coefficients per site; fit object %.1f MiB\n",
            length(fit$wb), n_t, H, ncol(fit$wb[[1]]), mib(as.numeric(utils::object.size(fit)))))
cat(sprintf("One site's curve matrix (%d x %d doubles): %.1f MiB; all %d sites: %.1f MiB\n\n",
            n_t, H, one_site, length(sites), length(sites) * one_site))

# --- peak memory of each call -------------------------------------------------
vm_hwm <- function() {
  st <- readLines("/proc/self/status")
  as.numeric(sub("^VmHWM:\\s*(\\d+).*", "\\1", grep("^VmHWM", st, value = TRUE))) / 1024
}
vm_rss <- function() {
  st <- readLines("/proc/self/status")
  as.numeric(sub("^VmRSS:\\s*(\\d+).*", "\\1", grep("^VmRSS", st, value = TRUE))) / 1024
}
reset_hwm <- function() {
  ok <- tryCatch({
    writeLines("5", "/proc/self/clear_refs")
    TRUE
  }, error = function(e) FALSE, warning = function(w) FALSE)
  ok
}
measure <- function(label, expr) {
  invisible(gc())
  g0 <- gc(reset = TRUE)
  base_r <- sum(g0[, 2])                 # Mb in use now (Ncells + Vcells)
  rss0 <- vm_rss()
  hwm_ok <- reset_hwm()
  el <- system.time(res <- force(expr))[["elapsed"]]
  g1 <- gc()
  peak_r <- sum(g1[, ncol(g1)]) - base_r  # Mb: max used since the reset, above the baseline
  peak_rss <- vm_hwm() - rss0
  cat(sprintf("%-32s R peak %7.1f MiB (%4.2f x one site)   RSS peak %s   %5.1f s\n", label, peak_r,
              peak_r / one_site,
              if (hwm_ok) sprintf("%7.1f MiB (%4.2f x)", peak_rss, peak_rss / one_site) else "   n/a",
              el))
  rm(res)
  invisible(c(r = peak_r, rss = if (hwm_ok) peak_rss else NA, sec = el))
}

# the peer: bias() in plain R, the curves of each site built whole
plain_bias <- function(fit) {
  lapply(names(fit$wb), function(s) {
    Y <- tcrossprod(fit$wb[[s]], fit$basis$Psi)
    rbind(mean = colMeans(Y), apply(Y, 2L, stats::quantile, c(0.05, 0.95)))
  })
}
plain <- measure("bias(), plain R (peer)", plain_bias(fit))

out <- rbind(
  `bias()` = measure("bias()", bias(fit)),
  `reality()` = measure("reality()", reality(fit)),
  `model_prediction()` = measure("model_prediction()", model_prediction(fit)),
  `predict(type = "reality")` = measure("predict(type = \"reality\")", predict(fit, seed = 1)),
  `predict(type = "field_run")` = measure("predict(type = \"field_run\")", predict(fit, "field_run", seed = 1)),
  `where_fails()` = measure("where_fails()", where_fails(fit))
)
cat(sprintf("\nbias() against the plain-R peer: R peak ratio %.2f\n", out["bias()", "r"] / plain[["r"]]))
cat(sprintf("bias() against the plain-R peer: time ratio %.2f (%.1f s against %.1f s)\n",
            out["bias()", "sec"] / plain[["sec"]], out["bias()", "sec"], plain[["sec"]]))
cat(sprintf("Slowest summary: %s, %.1f s (target: at most 5 s each)\n", rownames(out)[which.max(out[, "sec"])],
            max(out[, "sec"])))
cat(sprintf("\nLargest peak: R %.1f MiB = %.2f x one site's curves (%.2f x all four sites' curves)\n",
            max(out[, "r"]), max(out[, "r"]) / one_site, max(out[, "r"]) / (length(sites) * one_site)))

# --- the summaries on one thread and on the cores R may use, alternated -------
# the package's threads for them: future::availableCores() with
# wavevalid.workers "auto" (the default), one with options(wavevalid.workers =
# 1); each call three times in each setting, the settings alternated; the
# results must be identical.
threads_all <- max(1L, as.integer(future::availableCores()))
cat(sprintf("\nThe same calls on 1 thread and on %d (the cores R may use), alternated, seconds:\n", threads_all))
calls <- list(`bias()` = function() bias(fit), `reality()` = function() reality(fit),
              `where_fails()` = function() where_fails(fit))
for (nm in names(calls)) {
  secs <- list(one = numeric(), all = numeric())
  res <- list()
  for (rep in 1:3) for (mode in c("one", "all")) {
    options(wavevalid.workers = if (mode == "one") 1L else "auto")
    secs[[mode]] <- c(secs[[mode]], system.time(res[[mode]] <- calls[[nm]]())[["elapsed"]])
  }
  options(wavevalid.workers = "auto")
  cat(sprintf("%-14s 1 thread: %s   %d threads: %s   ratio of medians %.2f   identical: %s\n", nm,
              paste(sprintf("%.2f", secs$one), collapse = ", "), threads_all,
              paste(sprintf("%.2f", secs$all), collapse = ", "),
              stats::median(secs$one) / stats::median(secs$all), identical(res$one, res$all)))
}
