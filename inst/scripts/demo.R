# Validation demo on the shipped suspension test bed: validates the model on
# condition A (both sites), predicts condition B and the added-mass run, finds
# where the model fails (and which input covered it) and which mechanism is
# missing, adds it, validates again and judges the change at the added-mass
# run, held out of both fits; writes figures, a summary and an HTML report to
# the folder given as the first argument (default "out").
args <- commandArgs(trailingOnly = TRUE)
out <- if (length(args)) args[1] else "out"
dir.create(out, showWarnings = FALSE, recursive = TRUE)
suppressPackageStartupMessages(library(wavevalid))
message("wavevalid ", utils::packageVersion("wavevalid"), ": writing the demo to ", normalizePath(out))
started <- Sys.time()
save_plot <- function(p, name, width = 10, height = 5) {
  ggplot2::ggsave(file.path(out, name), p, width = width, height = height, dpi = 90)
}

tb <- load_testbed()
windows <- tb$windows
# every default: the field registered on the events' landmarks (knots every
# 1/32 of the record between them), the default basis and emulators
fit <- validate(tb$A$runs, tb$A$field, tb$iu, windows = windows, chains = 2, seed = 1,
                sampler = sampler_control(n_draws = 500, n_inner = 100))
print(fit)
field <- fit$field
knots <- diff(range(field$t)) / 32
save_plot(autoplot(tb$A$runs, field = field, windows = windows), "01-runs-and-field.png")
save_plot(autoplot(fit, type = "inputs"), "02-inputs.png", height = 6)
save_plot(autoplot(fit, type = "bias", windows = windows), "03-bias.png")
save_plot(autoplot(fit, type = "reality", windows = windows), "04-reality.png")

fails <- where_fails(fit)
print(fails)
save_plot(autoplot(fails), "05-where-it-fails.png", height = 7)
held <- attr(fails, "held")

candidates <- testbed_signatures(colMeans(as.matrix(fit$draws))[fit$inputs])
expl <- explain_bias(fit, candidates, seed = 1)
print(expl)
save_plot(autoplot(expl), "06-missing-effect.png")

field_B <- register_curves(tb$B$field, tb$A$runs, windows, knots_every = knots)
pred_B <- predict(fit, type = "new_nominal", new_runs = tb$B$runs, x_nom = tb$B$x_nom, seed = 1)
pred_mass <- predict(fit, type = "added_load", new_runs = tb$added_mass$runs, seed = 1)
field_mass <- register_curves(tb$added_mass$field, tb$A$runs, windows, knots_every = knots)
save_plot(autoplot(pred_B, field = field_B, windows = windows), "07-condition-B.png")
save_plot(autoplot(pred_mass, field = field_mass, windows = windows), "08-added-mass.png")

# the leading effect added: its strength a calibration input on [0, 1], the
# model run at 66 new points and at the former runs with the strength at 0
lead <- as.character(expl$candidate[1])
s_name <- paste0("s_", lead)
iu_m <- iu_add(tb$iu, s_name, lower = 0, upper = 1, nominal = 0.5)
off <- tb$A$runs$design
off[[s_name]] <- 0
runs_m <- c(model_runs(off, tb$A$runs$curves, tb$A$runs$t),
            simulate_suspension(design_maximin(iu_m, 66L, seed = 2), mechanism = lead))
# validated again with the fit's own settings, the raw field registered to the new runs
fit_m <- update(fit, runs = runs_m, iu = iu_m)
fails_m <- where_fails(fit_m)
print(fails_m)
# judged at the added-mass run, held out of both fits: each model predicts it
# at its inputs plus the added mass and registers it to its own runs
comparison <- compare_validations(fit, fit_m, holdout = experiment(tb$added_mass$field, change = tb$added_mass$delta),
                                  seed = 1)
print(comparison)
save_plot(autoplot(comparison), "09-before-and-after.png", height = 6)
save_plot(autoplot(comparison, type = "holdout"), "10-held-out-error.png", height = 6)

coverage <- function(pred, field) {
  d <- as.data.frame(pred)
  vapply(names(field$curves), function(s) {
    ps <- d[d$site == s, ]
    y <- field$curves[[s]]
    mean(sweep(y, 2, ps$lower, ">=") & sweep(y, 2, ps$upper, "<="))
  }, numeric(1))
}
summary_lines <- c(
  sprintf("wavevalid demo on the shipped test bed (hidden mechanism: %s)", paste(tb$truth$hidden, collapse = ", ")),
  sprintf("retained wavelet coefficients: %d", length(fit$basis$index)),
  top_finding(fails),
  if (any(fails$kind == "interval")) {
    iv <- fails[fails$kind == "interval", ]
    sprintf("localised failure intervals: %d; the largest at %s t in [%.2f, %.2f], %s", nrow(iv), iv$site[1],
            iv$start[1], iv$end[1],
            if (any(vapply(windows, function(w) iv$start[1] < w[2] && iv$end[1] > w[1], logical(1)))) {
              "in an event window"
            } else {
              "outside the event windows"
            })
  } else {
    "localised failure intervals: none"
  },
  {
    cf <- attr(fails, "conflicts")
    if (any(cf$conflict)) {
      sprintf("inputs in conflict with their prior: %s", paste(sprintf("%s (median %.3f, %.1f prior sd from its prior mean)",
              cf$input[cf$conflict], cf$median[cf$conflict], cf$prior_sds[cf$conflict]), collapse = ", "))
    } else {
      "inputs in conflict with their prior: none"
    }
  },
  if (!is.null(held) && any(held$fails$kind == "interval")) {
    h <- held$fails[held$fails$kind == "interval", ]
    sprintf("with %s held to the prior, the largest interval: %s t in [%.2f, %.2f], %s, the misfit %s covered",
            paste(held$inputs, collapse = ", "), h$site[1], h$start[1], h$end[1],
            if (any(vapply(windows, function(w) h$start[1] < w[2] && h$end[1] > w[1], logical(1)))) {
              "in an event window"
            } else {
              "outside the event windows"
            }, paste(held$inputs, collapse = ", "))
  },
  sprintf("record-wide bias (levels %s): %s", attr(fails, "record_wide")$levels[1],
          paste(with(attr(fails, "record_wide"),
                     sprintf("%s mean %.3f [%.3f, %.3f]%s", site, offset, offset_lower, offset_upper,
                             ifelse(credible, ", credible", ", not credible"))), collapse = "; ")),
  sprintf("leading candidate effect: %s (inclusion probability %.2f)", expl$candidate[1], expl$inclusion_prob[1]),
  sprintf("condition B held-out replicates inside the 90%% band: %s",
          paste(sprintf("%s %.1f%%", names(field_B$curves), 100 * coverage(pred_B, field_B)), collapse = ", ")),
  sprintf("added-mass field run inside the 90%% band: %s",
          paste(sprintf("%s %.1f%%", names(field_mass$curves), 100 * coverage(pred_mass, field_mass)), collapse = ", ")),
  {
    m <- stats::setNames(comparison$after / comparison$before, comparison$metric)
    sprintf("with %s added: inputs in conflict %d (before %d); localised bias x%.2f; at the held-out added-mass run the model alone errs x%.2f and the bias-corrected prediction x%.2f",
            lead, as.integer(comparison$after[comparison$metric == "inputs_in_conflict"]),
            as.integer(comparison$before[comparison$metric == "inputs_in_conflict"]), m[["bias_rms_local"]],
            m[["holdout_rmse_model"]], m[["holdout_rmse"]])
  },
  sprintf("with %s added: %s", lead, top_finding(fails_m)),
  {
    hr <- attr(comparison, "holdout_ratio")
    sprintf("verdict at the added-mass run: %s (90%% intervals of the ratios: model alone [%.2f, %.2f], bias-corrected [%.2f, %.2f])",
            attr(comparison, "verdict"), hr$lower[1], hr$upper[1], hr$lower[2], hr$upper[2])
  },
  sprintf("elapsed: %.1f minutes", as.numeric(difftime(Sys.time(), started, units = "mins")))
)
writeLines(summary_lines, file.path(out, "summary.txt"))
writeLines(summary_lines)
validation_report(fit, file.path(out, "validation-report.html"), runs = tb$A$runs, candidates = candidates,
                  predictions = list(`condition B` = pred_B, `added mass` = pred_mass), windows = windows,
                  comparison = comparison)
