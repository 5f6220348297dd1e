# Test conditions: inputs of type "condition" in the I/U map, known for
# every experiment. The sampler holds each at the base experiment's value;
# an experiment at another value is the base experiment's emulators at the
# inputs changed by the difference. A new condition's prediction: the model
# moved there, the bias of the tested conditions.

# The condition inputs of an I/U map.
iu_conditions <- function(iu) {
  if (is.null(iu) || is.null(iu$type)) return(character())
  iu$name[iu$type == "condition"]
}

# The base experiment's value of each condition input, named.
condition_base <- function(iu) {
  cond <- iu_conditions(iu)
  stats::setNames(iu$nominal[match(cond, iu$name)], cond)
}

# The I/U map the sampler sees: every condition held at its base value, a
# calibration input on a point-like range (as hold_inputs() holds an input).
conditions_held_iu <- function(iu) {
  cond <- iu_conditions(iu)
  if (!length(cond)) return(iu)
  hold_at(iu, condition_base(iu))
}

# `condition` of experiment(): NULL or a named numeric vector of finite values.
check_condition_values <- function(condition, arg = "condition", call = rlang::caller_env()) {
  if (is.null(condition)) return(invisible(NULL))
  if (!is.numeric(condition) || !length(condition) || is.null(names(condition)) || any(names(condition) == "") ||
      anyNA(condition) || any(!is.finite(condition)) || anyDuplicated(names(condition))) {
    wv_abort(c("{.arg {arg}} must be a named numeric vector of finite values, one per condition input.",
               "x" = "It is {.code {deparse(condition)}}.",
               "i" = "For example {.code c(dose = 250)}."), class = "condition", call = call)
  }
  invisible(condition)
}

# The values `values` of the conditions of `iu` checked: every condition
# given, none other, each inside its design range. `what` names whose values
# they are in the messages.
check_condition_against_iu <- function(values, iu, what, call = rlang::caller_env()) {
  cond <- iu_conditions(iu)
  other <- setdiff(names(values), cond)
  if (length(other)) {
    wv_abort(c("The condition of {what} names {cli::qty(length(other))}input{?s} that {?is not a condition/are not conditions} of the I/U map: {.val {other}}.",
               "i" = if (length(cond)) "Its conditions: {.val {cond}}." else "The I/U map has no condition input.",
               "i" = "Declare a condition with {.code iu_map(type = \"condition\")} or {.fn iu_add}, or give a known change of another input with {.arg change}."),
             class = "condition", call = call)
  }
  miss <- setdiff(cond, names(values))
  if (length(miss)) {
    wv_abort(c("The condition of {what} lacks the value of {.val {miss}}.",
               "i" = "Give every condition input of the I/U map, e.g. {.code condition = c({miss[1]} = {signif(condition_base(iu)[[miss[1]]], 4)})}."),
             class = "condition", call = call)
  }
  k <- match(cond, iu$name)
  v <- values[cond]
  out <- v < iu$lower[k] | v > iu$upper[k]
  if (any(out)) {
    wv_abort(c("The condition of {what} lies outside the design range of the model runs.",
               "x" = "{.val {cond[out]}} = {signif(v[out], 4)}; the range is [{signif(iu$lower[k][out], 4)}, {signif(iu$upper[k][out], 4)}].",
               "i" = "Run the model over a range that holds it, and widen the range of the condition in the I/U map."),
             class = "condition", call = call)
  }
  v
}

# Experiment `x` (named `e`) with its condition turned into the change of
# the condition inputs from their base values, added to the change it gives
# of other inputs. Idempotent: the change the user gave is kept in
# `change_given`. An I/U map with conditions needs every experiment's
# condition; an experiment with a condition needs one.
resolve_experiment_condition <- function(x, e, iu, call = rlang::caller_env()) {
  cond <- iu_conditions(iu)
  if (!length(cond) && is.null(x$condition)) return(x)
  what <- sprintf("experiment \"%s\"", e)
  if (!is.null(x$emulators)) {
    wv_abort(c("Experiment {.val {e}} has its own emulators; an I/U map with conditions needs every experiment made with {.arg condition}.",
               "i" = "Run the model over the conditions in one design and give each experiment its value: {.code experiment(field, condition = )}."),
             class = "condition", call = call)
  }
  if (is.null(x$condition)) {
    wv_abort(c("Experiment {.val {e}} has no condition, and the I/U map has condition input{?s} {.val {cond}}.",
               "i" = "Give its value{?s}: {.code experiment(field, condition = c({cond[1]} = ))}."),
             class = "condition", call = call)
  }
  given <- if (isTRUE(x$condition_resolved)) x$change_given else x$change
  sets <- intersect(names(given), cond)
  if (length(sets)) {
    wv_abort(c("The change of experiment {.val {e}} sets condition input{?s} {.val {sets}}.",
               "i" = "Give a condition's value with {.arg condition}, not as a change."),
             class = "condition", call = call)
  }
  v <- check_condition_against_iu(x$condition, iu, what, call = call)
  x$change_given <- given
  x$change <- c(given, v - condition_base(iu))
  x$condition_resolved <- TRUE
  x
}

# The conditions of a fit: the condition inputs, their base values and a
# table of every experiment's values ("base" first); NULL without
# conditions.
fit_condition_table <- function(iu, experiments) {
  cond <- iu_conditions(iu)
  if (!length(cond)) return(NULL)
  base <- condition_base(iu)
  rows <- c(list(base = base), lapply(experiments, function(x) x$condition[cond]))
  values <- as.data.frame(do.call(rbind, rows), stringsAsFactors = FALSE)
  values <- cbind(data.frame(experiment = names(rows), stringsAsFactors = FALSE), values)
  rownames(values) <- NULL
  list(inputs = cond, base = base, values = values)
}

# "dose = 250, temp = 300" for each row of the conditions table.
condition_labels <- function(conditions) {
  v <- conditions$values
  out <- vapply(seq_len(nrow(v)), function(r) {
    paste(sprintf("%s = %s", conditions$inputs, format(signif(unlist(v[r, conditions$inputs]), 4), trim = TRUE)),
          collapse = ", ")
  }, character(1))
  stats::setNames(out, v$experiment)
}

# --- prediction at a new condition ---------------------------------------------

# The draws of a new condition, by base site: `M` (model coefficients), `B`
# (bias coefficients), `S2` (field variances), `pure` (the model alone at the
# posterior mean inputs, coefficients), `tested` (the experiment whose
# condition it is, or NA) and `bias_from` (how the bias was carried).
# At a tested condition: that experiment's own draws. Elsewhere: the model
# coefficients of each posterior draw moved by the emulators' change from
# the base condition to the new one (as predict(type = "added_load", delta
# =) moves them); the bias and field variance of draw h those of draw h of
# one tested condition, the conditions taking the draws in equal shares in a
# random order (one bias when it is shared by the experiments).
new_condition_setup <- function(fit, condition, call = rlang::caller_env()) {
  if (is.null(fit$conditions)) {
    wv_abort(c("The fit has no condition input, so a new condition cannot be predicted.",
               "i" = "Declare the test condition with {.code iu_map(type = \"condition\")} and calibrate with an experiment at each tested condition."),
             class = "condition", call = call)
  }
  if (is.null(condition)) {
    wv_abort(c("{.code type = \"new_condition\"} needs {.arg condition}, the value of every condition input.",
               "i" = "For example {.code condition = c({fit$conditions$inputs[1]} = {signif(fit$conditions$base[[1]], 4)})}."),
             class = "condition", call = call)
  }
  check_condition_values(condition, call = call)
  v <- check_condition_against_iu(condition, fit$iu, "the prediction", call = call)
  tab <- fit$conditions$values
  cond <- fit$conditions$inputs
  tol <- 1e-9 * pmax(1, abs(v))
  hit <- which(vapply(seq_len(nrow(tab)), function(r) all(abs(unlist(tab[r, cond]) - v) <= tol), logical(1)))
  ex <- fit_experiments(fit)
  base <- base_sites(fit)
  site_of <- function(e, s) if (e == "base") s else paste0(e, "/", s)
  if (length(hit)) {
    e <- tab$experiment[hit[1]]
    zbar <- matrix(posterior_mean_inputs(fit)[fit$inputs], 1L, dimnames = list(NULL, fit$inputs))
    out <- lapply(stats::setNames(base, base), function(s) {
      se <- site_of(e, s)
      list(M = fit$wM[[se]], B = fit$wb[[se]], S2 = fit$sigma2[[se]],
           pure = drop(bank_predict(site_bank(fit$emulators, se),
                                    shift_inputs(fit, se, zbar))$mean))
    })
    return(list(sites = out, tested = e, bias_from = "tested", condition = v))
  }
  delta <- v - fit$conditions$base
  moved <- added_load_emulated(fit, delta, call = call)$Dw
  H <- nrow(fit$wM[[base[1]]])
  exps <- tab$experiment
  shared <- identical(fit$settings$experiment_bias, "shared") || length(exps) == 1L
  pick <- sample(rep_len(seq_along(exps), H))
  z <- posterior_mean_inputs(fit)[fit$inputs]
  znew <- z
  znew[names(delta)] <- znew[names(delta)] + delta
  out <- lapply(stats::setNames(base, base), function(s) {
    from <- function(what) {
      X <- fit[[what]][[s]]
      for (k in seq_along(exps)[-1L]) {
        rows <- pick == k
        X[rows, ] <- fit[[what]][[site_of(exps[k], s)]][rows, , drop = FALSE]
      }
      X
    }
    list(M = fit$wM[[s]] + moved[[s]], B = if (shared) fit$wb[[s]] else from("wb"), S2 = from("sigma2"),
         pure = drop(bank_predict(site_bank(fit$emulators, s), matrix(znew, 1L))$mean))
  })
  list(sites = out, tested = NA_character_, bias_from = if (shared) "shared" else "pooled", condition = v,
       experiment = exps[pick])
}

# Bands of a new condition at base site `s` from new_condition_setup()'s
# draws: the bias-corrected prediction (mean, lower, upper, lower_curve,
# upper_curve) and the model alone (model, model_lower, model_upper), both
# with the field noise when `noise`.
new_condition_site <- function(fit, s, setup, level, noise, keep_draws) {
  d <- setup$sites[[s]]
  Psi <- fit$basis$Psi
  H <- nrow(d$M)
  eps <- if (noise) sqrt(d$S2) * matrix(stats::rnorm(length(d$M)), H)
  Wm <- if (noise) d$M + eps else d$M
  Wc <- Wm + d$B
  src <- curve_source(H, nrow(Psi), NULL, list(W = Wc, B = Psi, offset = numeric()))
  draws <- if (keep_draws) source_matrix(src)
  band <- band_frame(draws %||% src, fit$basis$t, s, level)
  model <- band_frame(curve_source(H, nrow(Psi), NULL, list(W = Wm, B = Psi, offset = numeric())), fit$basis$t, s,
                      level)
  band$model <- drop(Psi %*% d$pure)
  band$model_lower <- model$lower
  band$model_upper <- model$upper
  list(summary = band, draws = draws, n_guarded = 0)
}
