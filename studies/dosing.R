# The dosing test bed (testbed_dosing()): how much of each mechanism's
# signature the model's inputs absorb, and whether explain_bias() names the
# hidden mechanism. For each case (hidden mechanism, seed):
#   simulator  at the true inputs z* of condition A, each mechanism's
#              signature (dosing_signatures()) regressed by least squares on
#              the model's response to small shifts of each input (central
#              differences, step 0.02 coded): absorbed, the share of the
#              signature's energy the six shifts span; absorbed_u, the share
#              the two calibration inputs alone span; best, the input whose
#              shift alone spans most, and best_share, that share (the
#              shifts of volume, bioavailability and weight are nearly
#              collinear, so the joint coefficients do not say which input
#              carries the signature). One row per mechanism, at the
#              z* of each seed (nothing hidden: the inputs do not depend on it).
#   explain    the case validated: field registered to the runs (the maximum
#              in each dose window, knots every 2 h; with register = FALSE the
#              replicates as measured), the default basis and
#              emulators, one chain (n_draws, n_inner), then explain_bias()
#              with the four signatures at the posterior mean inputs: top, the
#              leading candidate; incl, the hidden mechanism's inclusion
#              probability; decoy, the largest inclusion probability of the
#              other mechanisms; absorbed, explain_bias()'s share of the hidden
#              mechanism's signature spanned by the parameter shifts; dist, the
#              rms distance (coded) of the posterior mean calibration inputs
#              from u*.
#   Rscript studies/dosing.R [measure=simulator,explain] [seeds=1:3] [hidden=none,all]
#                            [n_draws=150] [n_inner=20] [register=TRUE]
# hidden: comma-separated, "all" for every mechanism.
suppressPackageStartupMessages(library(wavevalid))
source("studies/args.R")
args <- study_args(list(measure = "simulator,explain", seeds = "1:3", hidden = "none,all",
                        n_draws = "150", n_inner = "20", register = "TRUE"))
measure <- arg_names(args$measure)
seeds <- arg_numbers(args$seeds)
hidden <- arg_names(args$hidden)
hidden <- unique(unlist(lapply(hidden, function(h) if (h == "all") dosing_mechanisms() else h)))
options(wavevalid.quiet = TRUE)

true_z <- function(tb) c(tb$truth$u, 0.5 + tb$truth$delta)[tb$iu$name]

shift_share <- function(sig, sh) {
  qa <- qr(sh)
  share <- sum(qr.fitted(qa, sig)^2) / sum(sig^2)
  beta <- qr.coef(qa, sig)
  contrib <- abs(beta) * sqrt(colSums(sh^2))
  by <- order(contrib, decreasing = TRUE)
  list(share = share, inputs = paste(colnames(sh)[by[contrib[by] >= 0.25 * max(contrib)]], collapse = ", "))
}

if ("simulator" %in% measure) {
  rows <- list()
  for (seed in seeds) {
    tb <- testbed_dosing(seed = seed)
    z <- true_z(tb)
    h <- 0.02
    sh <- vapply(names(z), function(k) {
      up <- dn <- z
      up[k] <- up[k] + h
      dn[k] <- dn[k] - h
      y <- simulate_dosing(as.data.frame(rbind(up, dn)))$curves$plasma
      (y[1, ] - y[2, ]) / (2 * h)
    }, numeric(2048))
    sig <- dosing_signatures(z)
    for (m in names(sig)) {
      s <- sig[[m]]$plasma
      all6 <- shift_share(s, sh)
      u <- shift_share(s, sh[, c("u1", "u2")])
      one <- vapply(colnames(sh), function(k) shift_share(s, sh[, k, drop = FALSE])$share, numeric(1))
      rows[[length(rows) + 1L]] <- data.frame(seed = seed, mechanism = m, rms = sqrt(mean(s^2)),
                                              absorbed = all6$share, absorbed_u = u$share,
                                              best = names(which.max(one)), best_share = max(one))
    }
  }
  out <- do.call(rbind, rows)
  num <- c("rms", "absorbed", "absorbed_u", "best_share")
  out[num] <- lapply(out[num], round, 3)
  cat("\n== simulator: share of each signature the input shifts span, at z* ==\n")
  print(out, row.names = FALSE)
}

if ("explain" %in% measure) {
  rows <- list()
  for (hd in hidden) for (seed in seeds) {
    t0 <- proc.time()[["elapsed"]]
    tb <- testbed_dosing(seed = seed, hidden = hd)
    field <- if (arg_flag(args$register)) {
      register_curves(tb$A$field, tb$A$runs, tb$windows, features = "max", knots_every = 2)
    } else {
      tb$A$field
    }
    basis <- wavelet_basis(tb$A$runs, field)
    em <- fit_emulators(tb$A$runs, basis, seed = 1)
    fit <- suppressWarnings(calibrate(em, field, tb$iu, chains = 1, seed = 1,
                                      sampler = sampler_control(n_draws = as.integer(args$n_draws), n_inner = as.integer(args$n_inner), quiet = TRUE)))
    zh <- coef(fit)
    ex <- explain_bias(fit, dosing_signatures(zh), n_draws = 100, seed = 1)
    ex <- as.data.frame(unclass(ex))
    mech <- ex[ex$candidate %in% dosing_mechanisms(), ]
    ab <- attr(explain_bias(fit, dosing_signatures(zh), n_draws = 100, seed = 1), "absorbed")
    incl <- if (hd == "none") NA else mech$inclusion_prob[mech$candidate == hd]
    decoy <- max(mech$inclusion_prob[mech$candidate != hd])
    rows[[length(rows) + 1L]] <- data.frame(
      hidden = hd, seed = seed, top = ex$candidate[1], incl = round(incl, 2), decoy = round(decoy, 2),
      absorbed = if (hd == "none") NA else round(ab$absorbed[ab$candidate == hd], 2),
      by = if (hd == "none") "" else ab$inputs[ab$candidate == hd],
      dist = round(sqrt(mean((zh[c("u1", "u2")] - tb$truth$u)^2)), 3),
      secs = round(proc.time()[["elapsed"]] - t0, 1)
    )
    print(rows[[length(rows)]], row.names = FALSE)
  }
  cat("\n== explain: explain_bias() on each validated case ==\n")
  print(do.call(rbind, rows), row.names = FALSE)
}
