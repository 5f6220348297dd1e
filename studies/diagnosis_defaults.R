# The diagnosis with the package's defaults on both test beds, judged on the
# three criteria: where the model fails (C1), which effect is missing (C2),
# and whether adding it fixes the model (C3). For each case (test bed, seed,
# hidden mechanism or "none"):
#   fit        validate() with its defaults (registration with a knot every
#              1/32 of the record, the default basis and emulators), the
#              test bed's windows and the landmarks that mark when its events
#              happen (testbed_beds(), helper-protocol.R:
#              suspension, the load's minimum and maximum; dosing, each
#              dose's steepest rise), one chain of n_draws x n_inner.
#   C1         where_fails(fit) (the record-wide part reported apart):
#              overlap, whether a localised interval overlaps where the hidden
#              mechanism acts (its signature at the true inputs above a tenth
#              of its peak) at some site; longest, the longest localised
#              interval in grid steps; wide, whether the record-wide part is
#              credibly non-zero at some site; conflicts, the inputs in
#              conflict with their prior; held_overlap and held_longest, the
#              same for the intervals of the bias with them held to their
#              prior (where_fails()'s default). c1 hidden: overlap or
#              held_overlap. Nothing hidden passes with no credible
#              record-wide part, longest <= 5 and no conflict (c1_strict: no
#              conflict and longest <= 5, the record-wide part aside).
#   C2 screen  explain_bias() with each mechanism's signature at the
#              posterior mean inputs (and the shifts): top, its probability,
#              the largest other mechanism's (decoy).
#   C2 refits  the model re-validated with each mechanism (its strength a
#              calibration input on [0, 1], 66 runs at a maximin design and,
#              with off_runs, the fit's own 66 runs with the strength at 0, the
#              default emulators on the fit's basis, calibrated on the fit's
#              field), weighed by explain_bias(): top, its probability, decoy,
#              and P(none). This is the decider.
#   C3         the re-validated model with the leading mechanism against the
#              fit: bias_rms (fall, 1 - after / before) and the held-out
#              condition's holdout_rmse (predict(type = "new_nominal") at B,
#              the after-model's B runs spreading the strength over its 99%
#              posterior interval, B's replicates registered to the mean of
#              each model's B runs); local_fall, the same for the bias's
#              localised part (bias_rms_local); conflicts_after, the
#              inputs in conflict after; model_ratio and corrected_ratio, the
#              held-out error after / before of the model alone and of the
#              bias-corrected prediction. c3_held: the leading mechanism is
#              the hidden one, local_fall >= 0.7, no conflict after,
#              model_ratio <= 0.8 and corrected_ratio <= 1.05.
# With c2=FALSE the C2 screen and refits are skipped and only the hidden
# mechanism is re-validated (the lead is then the hidden mechanism); with
# c2=FALSE and c3=FALSE only C1 is measured.
# Rows are appended to `out` (CSV) as each case ends.
#   Rscript studies/diagnosis_defaults.R [beds=dosing,suspension] [seeds=1:5] [hidden=none,all]
#                                        [n_draws=150] [n_inner=20] [out=diagnosis_defaults.csv]
#                                        [knots=auto] [dosing_features=rise] [suspension_features=min,max]
#                                        [engine=gasp_level] [off_runs=TRUE] [pool_levels=NULL] [c2=TRUE]
#                                        [c3=TRUE]
# knots: "auto" (validate()'s default, 1/32 of the record), NULL (landmarks
# only) or a spacing in time units; features: the landmarks of each test
# bed's windows ("+"-free, comma-separated).
suppressPackageStartupMessages(library(wavevalid))
source("studies/common.R")
args <- study_args(list(beds = "dosing,suspension", seeds = "1:5", hidden = "none,all", n_draws = "150",
                        n_inner = "20", out = "diagnosis_defaults.csv", knots = "auto", dosing_features = "rise",
                        suspension_features = "min,max", engine = "gasp_level", off_runs = "TRUE",
                        pool_levels = "NULL", c2 = "TRUE", c3 = "TRUE"))
do_c2 <- arg_flag(args$c2)
do_c3 <- arg_flag(args$c3)
pool_levels <- arg_value(args$pool_levels)
off_runs <- arg_flag(args$off_runs)
knots_arg <- if (args$knots == "auto") "auto" else arg_value(args$knots)
beds <- arg_names(args$beds)
seeds <- arg_numbers(args$seeds)
n_draws <- as.integer(args$n_draws)
n_inner <- as.integer(args$n_inner)
options(wavevalid.quiet = TRUE)

bed <- testbed_beds()
bed$suspension$features <- arg_names(args$suspension_features)
bed$dosing$features <- arg_names(args$dosing_features)

run_case <- function(b, seed, hd) {
  t0 <- clock()
  B <- bed[[b]]
  tb <- B$make(seed = seed, hidden = hd)
  knots <- if (identical(knots_arg, "auto")) diff(range(tb$A$field$t)) / 32 else knots_arg
  fit <- testbed_default_fit(tb, B$features, n_draws, n_inner, knots_every = knots, engine = args$engine,
                             bias = bias_control(pool_levels = pool_levels))
  # C1
  wf <- where_fails(fit)
  rw <- attr(wf, "record_wide")
  longest <- longest_steps(wf)
  overlap <- NA
  if (hd != "none") {
    eff <- B$signatures(true_inputs(tb, fit$inputs), hd)[[1]]
    overlap <- any(flagged_share(wf, eff) > 0, na.rm = TRUE)
  }
  cf <- attr(wf, "conflicts")
  conflicts <- paste(cf$input[cf$conflict], collapse = "+")
  hd_w <- attr(wf, "held")
  held_overlap <- NA
  held_longest <- NA
  if (!is.null(hd_w)) {
    held_longest <- longest_steps(hd_w$fails)
    if (hd != "none") held_overlap <- any(flagged_share(hd_w$fails, eff) > 0, na.rm = TRUE)
  }
  c1 <- if (hd == "none") !any(rw$credible) && longest <= 5 && !any(cf$conflict) else overlap || isTRUE(held_overlap)
  c1_strict <- if (hd == "none") longest <= 5 && !any(cf$conflict) else NA
  mech <- B$mechanisms()
  verdict <- function(tab) {
    p_true <- if (hd == "none") NA else tab$inclusion_prob[tab$candidate == hd]
    other <- max(tab$inclusion_prob[tab$candidate != hd])
    ok <- if (hd == "none") other < 0.5 else tab$candidate[1] == hd && p_true >= 0.9 && other < 0.5
    list(top = tab$candidate[1], p_true = p_true, other = other, ok = ok)
  }
  none_v <- list(top = NA, p_true = NA, other = NA, ok = NA)
  if (do_c2) {
    # C2, the screen
    ex <- as.data.frame(unclass(explain_bias(fit, B$signatures(coef(fit)), n_draws = 100, seed = 1)))
    exm <- ex[ex$candidate %in% mech, ]
    # C2, the re-validated models
    refits <- testbed_default_refits(tb, fit, B$simulate, mech, n_draws, n_inner, engine = args$engine,
                                     off_runs = off_runs)
    ex_rf <- explain_bias(fit, refits)
    rf <- as.data.frame(unclass(ex_rf))
    p_none <- with(attr(ex_rf, "subsets"), probability[subset == "(none)"])
    v_sig <- verdict(exm)
    v_rf <- verdict(rf)
    lead <- rf$candidate[1]
  } else {
    if (hd == "none" || !do_c3) {
      return(data.frame(bed = b, seed = seed, hidden = hd, c1 = c1, c1_strict = c1_strict, overlap = overlap,
                        longest = longest, wide = any(rw$credible), conflicts = conflicts, held_overlap = held_overlap,
                        held_longest = held_longest, secs = round(clock() - t0), stringsAsFactors = FALSE))
    }
    refits <- testbed_default_refits(tb, fit, B$simulate, hd, n_draws, n_inner, engine = args$engine,
                                     off_runs = off_runs)
    v_sig <- v_rf <- none_v
    exm <- rf <- data.frame(inclusion_prob = NA)
    p_none <- NA
    lead <- hd
  }
  if (do_c2 && (!do_c3 || hd == "none")) {
    return(data.frame(bed = b, seed = seed, hidden = hd, c1 = c1, c1_strict = c1_strict, overlap = overlap,
                      longest = longest, wide = any(rw$credible), conflicts = conflicts, held_overlap = held_overlap,
                      held_longest = held_longest, sig_top = v_sig$top, sig_other = round(v_sig$other, 3),
                      c2_sig = v_sig$ok, rf_top = v_rf$top,
                      rf_p = round(if (hd == "none") rf$inclusion_prob[1] else v_rf$p_true, 3),
                      rf_other = round(v_rf$other, 3), p_none = round(p_none, 3), c2 = v_rf$ok,
                      secs = round(clock() - t0), stringsAsFactors = FALSE))
  }
  # C3, the leading mechanism added
  after <- refits[[lead]]
  s_name <- paste0("s_", lead)
  design_B <- tb$B$runs$design
  s_range <- stats::quantile(as.matrix(after$draws)[, s_name], c(0.005, 0.995))
  design_B[[s_name]] <- s_range[1] + diff(s_range) * (seq_len(nrow(design_B)) - 0.5) / nrow(design_B)
  design_B[[s_name]] <- design_B[[s_name]][testbed_with_seed(2, sample(nrow(design_B)))]
  runs_B <- B$simulate(design_B, mechanism = lead)
  p_before <- suppressWarnings(predict(fit, type = "new_nominal", new_runs = tb$B$runs, x_nom = tb$B$x_nom,
                                       seed = 1))
  p_after <- suppressWarnings(predict(after, type = "new_nominal", new_runs = runs_B, x_nom = tb$B$x_nom,
                                      seed = 1))
  reg_B <- function(ref) register_curves(tb$B$field, ref, tb$windows, features = B$features, knots_every = knots)
  cmp <- compare_validations(fit, after, holdout = list(field = list(before = reg_B(tb$B$runs), after = reg_B(runs_B)),
                                                         before = p_before, after = p_after))
  get <- function(m, w) cmp[[w]][cmp$metric == m]
  bias_fall <- 1 - get("bias_rms", "after") / get("bias_rms", "before")
  local_fall <- 1 - get("bias_rms_local", "after") / get("bias_rms_local", "before")
  hold_fall <- 1 - get("holdout_rmse", "after") / get("holdout_rmse", "before")
  c3 <- if (hd == "none") NA else lead == hd && bias_fall >= 0.7 && hold_fall > 0
  model_ratio <- get("holdout_rmse_model", "after") / get("holdout_rmse_model", "before")
  corrected_ratio <- get("holdout_rmse", "after") / get("holdout_rmse", "before")
  conflicts_after <- get("inputs_in_conflict", "after")
  c3_held <- if (hd == "none") NA else lead == hd && local_fall >= 0.7 && conflicts_after == 0 &&
    model_ratio <= 0.8 && corrected_ratio <= 1.05
  data.frame(bed = b, seed = seed, hidden = hd, c1 = c1, c1_strict = c1_strict, overlap = overlap,
             longest = longest, wide = any(rw$credible), wide_offset = by_site(rw$offset), conflicts = conflicts,
             held_overlap = held_overlap, held_longest = held_longest,
             sig_top = v_sig$top, sig_p = round(if (hd == "none") exm$inclusion_prob[1] else v_sig$p_true, 3),
             sig_other = round(v_sig$other, 3), c2_sig = v_sig$ok,
             rf_top = v_rf$top, rf_p = round(if (hd == "none") rf$inclusion_prob[1] else v_rf$p_true, 3),
             rf_other = round(v_rf$other, 3), p_none = round(p_none, 3), c2 = v_rf$ok,
             lead = lead, bias_fall = round(bias_fall, 3), local_fall = round(local_fall, 3),
             hold_before = signif(get("holdout_rmse", "before"), 3),
             hold_after = signif(get("holdout_rmse", "after"), 3), c3 = c3,
             conflicts_after = conflicts_after, model_ratio = round(model_ratio, 3),
             corrected_ratio = round(corrected_ratio, 3), c3_held = c3_held, secs = round(clock() - t0),
             stringsAsFactors = FALSE)
}

for (b in beds) {
  hidden <- arg_names(args$hidden)
  hidden <- unique(unlist(lapply(hidden, function(h) if (h == "all") bed[[b]]$mechanisms() else h)))
  for (hd in hidden) for (seed in seeds) {
    row <- tryCatch(run_case(b, seed, hd), error = function(e) {
      message(b, " ", hd, " ", seed, ": ", conditionMessage(e))
      NULL
    })
    if (is.null(row)) next
    print(row, row.names = FALSE)
    utils::write.table(row, args$out, sep = ",", row.names = FALSE, append = file.exists(args$out),
                       col.names = !file.exists(args$out))
  }
}
