# Mutation check of the test suite: each mutant is a deliberate breakage of the
# package (a file, a fixed pattern found exactly once, its replacement). Each is
# applied, one at a time, to a copy of the repository, the copy is installed
# into a temporary library and the test file that should catch the breakage is
# run against it. A mutant is killed when that file has a failure or an error.
# Not part of R CMD check nor of CI.
#
# Usage (from the package's root):
#   Rscript tools/mutants.R              every mutant
#   Rscript tools/mutants.R NAME ...     the named mutants
#   Rscript tools/mutants.R --list       the mutants' names
#   Rscript tools/mutants.R --baseline   also run each test file on the unbroken copy
# The compiled code is built once, in a first copy; each mutant's copy reuses
# its object files (only R code is mutated), so an install takes seconds.
# Runs one R process at a time.

mutants <- list(
  list(name = "spanned_candidate_kept", file = "R/explain-bias.R",
       pattern = "spanned <- absorbed$candidate[absorbed$absorbed > 1 - 1e-8]", replacement = "spanned <- character()",
       test = "test-explain.R", what = "a candidate the shifts span weighed beside them"),
  list(name = "transform_levels_in_wd_order", file = "R/basis-transform.R",
       pattern = "      out[i, ] <- c(w$C, w$D)[at]", replacement = "      out[i, ] <- c(w$C, rev(w$D))[at]",
       test = "test-wavelet-basis.R", what = "the fast transform reading the detail levels in wavethresh's storage order"),
  list(name = "cores_never_used", file = "R/utils-futures.R",
       pattern = "  if (n < 2L) return(invisible(0L))", replacement = "  return(invisible(0L))",
       test = "test-plans.R", what = "validate() keeps every chain in one process under future's default plan"),
  list(name = "own_extent_groups_unpooled", file = "R/calibrate-spec.R",
       pattern = "if (!is.null(fill)) grp <- pool_data_free(grp, tau_group$level, fill$no_data)",
       replacement = "grp <- grp",
       test = "test-own-extent.R", what = "bias-variance groups without data left to wander"),
  list(name = "add_term_rate_fixed", file = "R/propose-add.R",
       pattern = "rate$op(X[i, ], runs$t, r[i])", replacement = "rate$op(X[i, ], runs$t, rate$value)",
       test = "test-propose-memory.R", what = "every run of an added filter at the proposal's time constant"),
  list(name = "own_extent_holdout_unmasked", file = "R/compare-holdout.R",
       pattern = "rowSums((E + shift)^2 * matrix(obs[at], n_boot))", replacement = "rowSums((E + shift)^2)",
       test = "test-own-extent.R", what = "a held-out curve graded beyond its end"),
  list(name = "refit_off_at_lower_bound", file = "R/explain-refits.R",
       pattern = "off <- unname(e$off[e$strength])", replacement = "off <- prior_iu$lower[idx]",
       test = "test-explain-strengths.R", what = "re-validated candidates weighed against the strength's lower bound, not its no-effect value"),
  list(name = "own_extent_fill_weighted", file = "R/calibrate-spec.R",
       pattern = "  if (is.null(observed)) return(NULL)\n  R <- nrow(curves)",
       replacement = "  return(NULL)\n  R <- nrow(curves)",
       test = "test-own-extent.R", what = "the part of a curve beyond its end weighs as data"),
  list(name = "own_extent_landmarks", file = "R/register.R",
       pattern = "  if (is.null(observed) || !nrow(lm)) return(lm)",
       replacement = "  return(lm)",
       test = "test-own-extent.R", what = "landmarks taken in windows beyond a curve's end"),
  list(name = "stopping_never_early", file = "R/calibrate-chains.R",
       pattern = "if (met || n >= sm$max_draws) break", replacement = "if (n >= sm$max_draws) break",
       test = "test-stopping.R", what = "the stopping rule never stops before the ceiling"),
  list(name = "stopping_first_round_20", file = "R/calibrate-chains.R",
       pattern = "min(sm$max_draws, max(20L, as.integer(ceiling(sm$ess / chains))))",
       replacement = "min(sm$max_draws, 20L)",
       test = "test-stopping.R", what = "the stopping rule's first round holds 20 draws"),
  list(name = "stopping_burnin_ceiling", file = "R/calibrate.R",
       pattern = "n <- sm$n_draws %||% first_round_draws(sm, chains)", replacement = "n <- sm$n_draws %||% sm$max_draws",
       test = "test-stopping.R", what = "the burn-in sized to the ceiling, not to the first round"),
  list(name = "stopping_no_resume", file = "R/calibrate-chains.R",
       pattern = "resume = runs[[ch]]$state)))", replacement = "resume = NULL)))",
       test = "test-stopping.R", what = "a further round starts each chain afresh instead of continuing it"),
  list(name = "stopping_walk_not_relearned", file = "R/calibrate-chains.R",
       pattern = "if (sm$proposal == \"adaptive\") runs <- lapply(runs, relearn_walk, priors = spec$priors)",
       replacement = "NULL",
       test = "test-stopping.R", what = "a continued chain keeps the burn-in's walk"),
  list(name = "propose_strength_doubled", file = "R/propose-terms.R",
       pattern = "c(mean(res$amp_m[, j]), stats::quantile(z, c(a, 1 - a), names = FALSE))",
       replacement = "2 * c(mean(res$amp_m[, j]), stats::quantile(z, c(a, 1 - a), names = FALSE))",
       test = "test-propose.R", what = "the proposed term's strength and its interval doubled"),
  list(name = "conflict_threshold_0", file = "R/fit-diagnostics.R",
       pattern = "beyond >= stats::qnorm(1 - alpha / (2 * p))", replacement = "beyond >= 0",
       test = "test-conflicts.R", what = "a pile at a bound needs its centre only at the bound, not z sd beyond"),
  list(name = "conflict_threshold_4", file = "R/fit-diagnostics.R",
       pattern = "beyond >= stats::qnorm(1 - alpha / (2 * p))", replacement = "beyond >= 4",
       test = "test-conflicts.R", what = "a pile at a bound needs its centre 4 sd beyond it"),
  list(name = "verdict_margin_1", file = "R/compare.R",
       pattern = "verdict_margin <- 1.05", replacement = "verdict_margin <- 1.0",
       test = "test-compare.R", what = "the verdict without its 5% margin"),
  list(name = "verdict_from_unmixed_chains", file = "R/compare.R",
       pattern = "if (!is.null(ratio) && length(unmixed)) \"not judged\" else holdout_verdict(ratio)",
       replacement = "holdout_verdict(ratio)",
       test = "test-compare.R", what = "a verdict from chains that did not mix"),
  list(name = "update_registers_to_new_runs", file = "R/validate-update.R",
       pattern = "settings <- keep_registration(settings, given$registered_to, over)",
       replacement = "settings <- settings",
       test = "test-update.R", what = "update() registers the field to the new runs, not the former fit's reference"),
  list(name = "holdout_registered_per_fit", file = "R/compare-holdout.R",
       pattern = "experiment_prediction(f, holdout, level, seed, call, field = field)",
       replacement = "experiment_prediction(f, holdout, level, seed, call)",
       test = "test-update.R", what = "the held-out experiment registered to each fit's own runs"),
  list(name = "model_rmse_gross_of_shifts", file = "R/compare.R",
       pattern = "y <- field_mean_curve(fit, s)", replacement = "y <- colMeans(fit_get(fit, \"field\")$curves[[s]])",
       test = "test-update.R", what = "model_rmse against the field mean without the registration's shifts"),
  list(name = "holdout_no_time_blocks", file = "R/compare-holdout.R",
       pattern = "as.vector(time[[j]])", replacement = "rep(seq_len(n_t), each = n_boot)",
       test = "test-compare.R", what = "the verdict's resampling without blocks of time within each curve"),
  list(name = "misfit_spread_ignored", file = "R/diagnose-misfit.R",
       pattern = "if (R >= 2L) {", replacement = "if (FALSE) {",
       test = "test-misfit-check.R", what = "misfit_check() reads the learned noise, not the replicates' spread"),
  list(name = "misfit_units_not_net", file = "R/diagnose-misfit.R",
       pattern = "    if (!is.null(Q)) {", replacement = "    if (FALSE) {",
       test = "test-misfit-check.R", what = "units judged without taking out what their own inputs explain"),
  list(name = "misfit_points_only", file = "R/diagnose-misfit.R",
       pattern = "lapply(2^(0:floor(log2(n))), function(w) {", replacement = "lapply(1, function(w) {",
       test = "test-misfit-check.R", what = "misfit_check() scans single points, no window's mean"),
  list(name = "misfit_units_no_floor", file = "R/diagnose-misfit.R",
       pattern = "E <- E + rep(sqrt(pmax(floor, 0)), each = n_sim)",
       replacement = "E <- E + 0 * rep(sqrt(pmax(floor, 0)), each = n_sim)",
       test = "test-misfit-check.R", what = "the unit means' error without their measurement noise as a floor"),
  list(name = "units_lost_in_registration", file = "R/register.R",
       pattern = "units = field$units, observed = observed))", replacement = "units = NULL, observed = observed))",
       test = "test-units.R", what = "registration drops the field's units"),
  list(name = "condition_bias_not_widened", file = "R/predict-condition.R",
       pattern = "centre + sqrt((J + 1) / (J - 1)) * (mixed - centre)", replacement = "mixed",
       test = "test-conditions.R", what = "a new condition's bias the tested conditions' mixture as it is"),
  list(name = "condition_model_mean_change", file = "R/predict-condition.R",
       pattern = "pa$mean + sqrt(pmax(pa$var, 0))", replacement = "pa$mean + 0 * sqrt(pmax(pa$var, 0))",
       test = "test-conditions.R", what = "a new condition's model moved by the emulators' conditional mean alone"),
  list(name = "add_term_not_added", file = "R/propose-add.R",
       pattern = "Y + s * matrix(fun(X), nrow(X))", replacement = "Y + 0 * s * matrix(fun(X), nrow(X))",
       test = "test-propose.R", what = "add_term() makes runs without the term"),
  list(name = "misfit_not_a_finding", file = "R/diagnose.R",
       pattern = "mc <- if (misfit) misfit_check(fit, level)", replacement = "mc <- NULL",
       test = "test-findings.R", what = "where_fails() leaves out the misfit the bias's band missed"),
  list(name = "adequate_despite_doubts", file = "R/report-verdict.R",
       pattern = "doubts <- adequacy_doubts(fails, expl)", replacement = "doubts <- character()",
       test = "test-report.R", what = "the report says adequate while a candidate is included at 0.95"),
  list(name = "landmarks_first_site_only", file = "R/register.R",
       pattern = "lm_sites <- function(s) if (pooled) sites else s", replacement = "lm_sites <- function(s) s",
       test = "test-register.R", what = "landmark_site = \"all\" ties the warp to the first site's landmarks only"),
  list(name = "noise_points_not_evidence", file = "R/calibrate-spec.R",
       pattern = "df <- nz$df + (nz$detail_df %||% 0)", replacement = "df <- nz$df",
       test = "test-noise-evidence.R", what = "the curve's own points do not enter as data on the noise"),
  list(name = "print_term_library_families", file = "R/propose-library.R",
       pattern = "paste(sprintf(\"%s %d\", names(fam), as.integer(fam)), collapse = \", \")",
       replacement = "paste(names(fam), collapse = \", \")",
       test = "test-propose.R", what = "the term library's print loses the families' counts"),
  list(name = "memory_filter_no_decay", file = "R/propose-memory.R",
       pattern = "x[k + 1L] <- a[k] * x[k] + inc[k]", replacement = "x[k + 1L] <- x[k] + inc[k]",
       test = "test-propose-memory.R", what = "the first-order filter forgets nothing (an integral)"),
  list(name = "explain_no_occam", file = "R/explain-regression.R",
       pattern = "logml[j + 1L] <- -length(S) / 2 * log1p(g) - n / 2 * log1p(-shrink * r2)",
       replacement = "logml[j + 1L] <- -n / 2 * log1p(-shrink * r2)",
       test = "test-bias-regression.R", what = "explain_bias() drops the g-prior's penalty on a subset's size"),
  list(name = "explain_evidence_x100", file = "R/explain-regression.R",
       pattern = "n <- g <- eta * n_all", replacement = "g <- eta * n_all\n  n <- 100 * g",
       test = "test-diagnose.R", what = "explain_bias() counts the bias's evidence a hundred times over"),
  list(name = "shared_weight_1", file = "R/calibrate-shared-errors.R",
       pattern = "list(weight = min(1, sum(ok) / tr), p = sum(ok)", replacement = "list(weight = 1, p = sum(ok)",
       test = "test-shared-errors.R", what = "the inputs' likelihood is not weighed for shared errors"),
  list(name = "autoplot_band_to_mean", file = "R/report-fit.R",
       pattern = "ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lower, ymax = .data$upper), fill = \"steelblue\"",
       replacement = "ggplot2::geom_ribbon(ggplot2::aes(ymin = .data$lower, ymax = .data$mean), fill = \"steelblue\"",
       test = "test-bands.R", what = "the fit's band plot draws its ribbon from the lower limit to the mean"),
  list(name = "autoplot_fails_no_intervals", file = "R/diagnose-methods.R",
       pattern = "  if (nrow(regions)) {", replacement = "  if (FALSE) {",
       test = "test-diagnose.R", what = "where_fails()'s plot no longer shades the intervals found"),
  list(name = "autoplot_levels_wrong_bars", file = "R/diagnose-methods.R",
       pattern = "ggplot2::aes(factor(.data$level), .data$share)",
       replacement = "ggplot2::aes(factor(.data$level), 1 - .data$share)",
       test = "test-diagnose.R", what = "the levels plot draws the wrong bar heights"),
  list(name = "autoplot_prior_density_unscaled", file = "R/inputs-methods.R",
       pattern = "data.frame(input = object$name[k], value = v, density = iu_prior_density(object, k, v))",
       replacement = "data.frame(input = object$name[k], value = v, density = 2 * iu_prior_density(object, k, v))",
       test = "test-iu-map.R", what = "the I/U map's plot draws twice the prior density"),
  list(name = "autoplot_runs_windows_ignored", file = "R/data-runs.R",
       pattern = "add_window <- function(df) with_windows(df, windows, whole = \"whole record\")",
       replacement = "add_window <- function(df) with_windows(df, NULL, whole = \"whole record\")",
       test = "test-runs.R", what = "the runs' plot ignores the windows"),
  list(name = "autoplot_trace_first_chain", file = "R/report-fit.R",
       pattern = "d <- do.call(rbind, lapply(seq_along(draws), function(ch) {",
       replacement = "d <- do.call(rbind, lapply(1L, function(ch) {",
       test = "test-calibrate.R", what = "the trace plot draws only the first chain"),
  list(name = "report_verdict_from_unmixed", file = "R/report-verdict.R",
       pattern = "unmixed <- unmixed_inputs(list(fit = fit))$fit", replacement = "unmixed <- NULL",
       test = "test-report.R", what = "the report gives a verdict from chains that did not mix"),
  list(name = "design_conditions_ignored", file = "R/inputs-design.R",
       pattern = "for (nm in names(conditions)) d[, nm] <- runs_at_values(d[, nm], conditions[[nm]])",
       replacement = "NULL", test = "test-conditions.R", what = "design_maximin() places no run at the tested conditions"),
  list(name = "reach_is_the_range", file = "R/experiments.R",
       pattern = "reach <- apply(des, 2L, design_gap)", replacement = "reach <- 0 * rng[1L, ]",
       test = "test-conditions.R", what = "a condition a hair beyond the runs is refused"),
  list(name = "base_field_is_an_experiment", file = "R/experiments.R",
       pattern = "if (is.null(base)) return(out)", replacement = "return(out)",
       test = "test-conditions.R", what = "experiments_at(base =) makes the base condition an experiment"),
  list(name = "condition_given_a_prior_distance", file = "R/fit-diagnostics.R",
       pattern = "condition <- nm %in% iu_conditions(fit$iu)", replacement = "condition <- FALSE",
       test = "test-conditions.R", what = "a test condition is given a distance in prior sds"),
  list(name = "ids_not_in_messages", file = "R/data-field.R",
       pattern = "if (!is.null(replicate)) labels <- lapply(long$ids, function(v) paste(replicate, v))",
       replacement = "NULL", test = "test-curves-input.R", what = "messages name curves by position, not the user's ids")
)

# --- machinery ---------------------------------------------------------------

args <- commandArgs(trailingOnly = TRUE)
root <- normalizePath(".")
if (!file.exists(file.path(root, "DESCRIPTION")) || !dir.exists(file.path(root, "tools"))) {
  stop("Run from the package's root: Rscript tools/mutants.R [name ...]")
}
names(mutants) <- vapply(mutants, `[[`, "", "name")
if ("--list" %in% args) {
  for (m in mutants) cat(sprintf("%-30s %-22s %s\n", m$name, m$test, m$what))
  quit(status = 0)
}
baseline <- "--baseline" %in% args
chosen <- setdiff(args, c("--baseline", "--list"))
unknown <- setdiff(chosen, names(mutants))
if (length(unknown)) stop("Unknown mutant(s): ", paste(unknown, collapse = ", "))
if (length(chosen)) mutants <- mutants[chosen]

work <- tempfile("mutants-")
dir.create(work)
on.exit(unlink(work, recursive = TRUE), add = TRUE)
rscript <- file.path(R.home("bin"), "Rscript")
rcmd <- file.path(R.home("bin"), "R")
Sys.setenv(MAKEFLAGS = "-j2", NOT_CRAN = "true")

# the tracked files of the repository (with uncommitted changes), without .git
copy_repo <- function(to) {
  files <- system2("git", c("-C", shQuote(root), "ls-files", "--cached", "--others", "--exclude-standard"),
                   stdout = TRUE)
  files <- files[file.exists(file.path(root, files))]
  for (d in unique(dirname(files))) dir.create(file.path(to, d), recursive = TRUE, showWarnings = FALSE)
  ok <- file.copy(file.path(root, files), file.path(to, files), copy.date = TRUE)
  if (!all(ok)) stop("Could not copy ", paste(files[!ok], collapse = ", "))
}

install <- function(src, lib, log) {
  dir.create(lib, showWarnings = FALSE)
  st <- system2(rcmd, c("CMD", "INSTALL", "--no-multiarch", "--strip", "--no-test-load", "-l", shQuote(lib),
                        shQuote(src)), stdout = log, stderr = log)
  if (!identical(st, 0L)) stop("Install of ", src, " failed; see ", log)
}

# failures + errors of one test file against the package in `lib`, or NA
run_test <- function(src, lib, test, log) {
  code <- sprintf(paste0("res <- as.data.frame(testthat::test_file(%s, package = 'wavevalid', ",
                         "load_package = 'installed', reporter = 'silent', stop_on_failure = FALSE)); ",
                         "cat('\\nRESULT', sum(res$failed) + sum(res$error), sum(res$passed), '\\n'); ",
                         "for (k in which(res$failed > 0 | res$error)) cat('FAILED', res$test[k], '\\n')"),
                  deparse(file.path(src, "tests", "testthat", test)))
  old <- Sys.getenv("R_LIBS")
  Sys.setenv(R_LIBS = paste(c(lib, if (nzchar(old)) old), collapse = .Platform$path.sep))
  on.exit(Sys.setenv(R_LIBS = old))
  out <- suppressWarnings(system2(rscript, c("-e", shQuote(code)), stdout = TRUE, stderr = TRUE))
  writeLines(out, log)
  line <- grep("^RESULT ", out, value = TRUE)
  if (!length(line)) return(NA_integer_)
  structure(as.integer(strsplit(line[length(line)], " ")[[1]][2]),
            failed = trimws(sub("^FAILED ", "", grep("^FAILED ", out, value = TRUE))))
}

# the base copy, compiled once: its object files serve every mutant
base <- file.path(work, "base")
dir.create(base)
copy_repo(base)
cat("Building the unbroken copy (compiles the C++ code once) ...\n")
install(base, file.path(work, "lib-base"), file.path(work, "base-install.log"))

rows <- list()
if (baseline) {
  for (test in unique(vapply(mutants, `[[`, "", "test"))) {
    t0 <- proc.time()[["elapsed"]]
    bad <- run_test(base, file.path(work, "lib-base"), test, file.path(work, paste0("base-", test, ".log")))
    rows[[length(rows) + 1L]] <- data.frame(mutant = "(none)", test = test,
                                            result = if (is.na(bad)) "error" else if (bad > 0) "FAILS" else "passes",
                                            seconds = round(proc.time()[["elapsed"]] - t0))
    cat(sprintf("%-30s %-22s %-9s %5.0f s\n", "(none)", test, rows[[length(rows)]]$result, rows[[length(rows)]]$seconds))
  }
}

for (m in mutants) {
  t0 <- proc.time()[["elapsed"]]
  dir <- file.path(work, m$name)
  system2("cp", c("-a", shQuote(base), shQuote(dir)))
  path <- file.path(dir, m$file)
  caught <- character()
  txt <- paste(readLines(path, warn = FALSE), collapse = "\n")
  n_hits <- sum(gregexpr(m$pattern, txt, fixed = TRUE)[[1]] > 0)
  if (n_hits != 1L) {
    result <- sprintf("pattern found %d times", n_hits)
  } else {
    writeLines(sub(m$pattern, m$replacement, txt, fixed = TRUE), path)
    lib <- file.path(work, paste0("lib-", m$name))
    result <- tryCatch({
      install(dir, lib, file.path(work, paste0(m$name, "-install.log")))
      bad <- run_test(dir, lib, m$test, file.path(work, paste0(m$name, "-test.log")))
      caught <<- attr(bad, "failed")
      if (is.na(bad)) "killed (test file errored)" else if (bad > 0) "killed" else "survived"
    }, error = function(e) paste("error:", conditionMessage(e)))
    unlink(lib, recursive = TRUE)
  }
  unlink(dir, recursive = TRUE)
  rows[[length(rows) + 1L]] <- data.frame(mutant = m$name, test = m$test, result = result,
                                          seconds = round(proc.time()[["elapsed"]] - t0))
  cat(sprintf("%-30s %-22s %-9s %5.0f s\n", m$name, m$test, result, rows[[length(rows)]]$seconds))
  for (tt in caught) cat("    failed: ", tt, "\n", sep = "")
}

tab <- do.call(rbind, rows)
cat("\n")
print(tab, row.names = FALSE, right = FALSE)
cat(sprintf("\n%d of %d mutants killed\n", sum(startsWith(tab$result, "killed")), sum(tab$mutant != "(none)")))
