# predict(type = "new_condition"): the system at a test condition, tested
# or not, and the seed of every prediction's set-up draws.

# The seed of the set-up draws of a prediction made with `seed`.
setup_seed_of <- function(seed) if (seed < .Machine$integer.max) seed + 1L else 1L

# predict(type = "new_condition"): the draws of the condition
# (new_condition_setup(), from the set-up stream), then the bands by base
# site.
predict_new_condition <- function(fit, condition, level, noise, keep_draws, seed,
                                  call = rlang::caller_env()) {
  setup <- with_rng_seed(setup_seed_of(seed), new_condition_setup(fit, condition, call = call))
  sites <- names(setup$sites)
  out <- with_rng_seed(seed,
                       lapply(sites,
                              function(s) new_condition_site(fit, s, setup, level, noise,
                                                             keep_draws)))
  names(out) <- sites
  structure(list(
    summary = do.call(rbind, lapply(out, `[[`, "summary")),
    draws = if (keep_draws) lapply(out, `[[`, "draws"),
    n_guarded = vapply(out, `[[`, 0, "n_guarded"),
    type = "new_condition", bias = "additive", level = level, noise = noise, residual = FALSE,
    seed = seed,
    condition = setup$condition, tested = setup$tested, bias_from = setup$bias_from
  ), class = "wv_prediction")
}

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
  conditions <- fit_get(fit, "conditions")
  if (is.null(conditions)) {
    wv_abort(c("The fit has no condition input, so a new condition cannot be predicted.",
               "i" = "Declare the test condition with {.code iu_map(type = \"condition\")} and calibrate with an experiment at each tested condition."),
             class = "condition", call = call)
  }
  if (is.null(condition)) {
    wv_abort(c("{.code type = \"new_condition\"} needs {.arg condition}, the value of every condition input.",
               "i" = "For example {.code condition = c({conditions$inputs[1]} = {signif(conditions$base[[1]], 4)})}."),
             class = "condition", call = call)
  }
  check_condition_values(condition, call = call)
  v <- check_condition_against_iu(condition, fit_get(fit, "iu"), "the prediction", call = call)
  tab <- conditions$values
  cond <- conditions$inputs
  inputs <- fit_get(fit, "inputs")
  tol <- 1e-9 * pmax(1, abs(v))
  hit <- which(vapply(seq_len(nrow(tab)), function(r) all(abs(unlist(tab[r, cond]) - v) <= tol),
                      logical(1)))
  ex <- fit_experiments(fit)
  base <- base_sites(fit)
  site_of <- function(e, s) if (e == "base") s else paste0(e, "/", s)
  if (length(hit)) {
    e <- tab$experiment[hit[1]]
    zbar <- matrix(posterior_mean_inputs(fit)[inputs], 1L, dimnames = list(NULL, inputs))
    out <- lapply(stats::setNames(base, base), function(s) {
      se <- site_of(e, s)
      list(M = fit_get(fit, "wM")[[se]], B = fit_get(fit, "wb")[[se]],
           S2 = fit_get(fit, "sigma2")[[se]],
           pure = drop(bank_predict(site_bank(fit_get(fit, "emulators"), se),
                                    shift_inputs(fit, se, zbar))$mean))
    })
    return(list(sites = out, tested = e, bias_from = "tested", condition = v))
  }
  delta <- v - conditions$base
  H <- nrow(fit_get(fit, "wM")[[base[1]]])
  exps <- tab$experiment
  shared <- identical(fit_get(fit, "settings")$experiment_bias, "shared") || length(exps) == 1L
  pick <- sample(rep_len(seq_along(exps), H))
  z <- posterior_mean_inputs(fit)[inputs]
  znew <- z
  znew[names(delta)] <- znew[names(delta)] + delta
  post <- fit_draws_matrix(fit)[, inputs, drop = FALSE]
  out <- lapply(stats::setNames(base, base), function(s) {
    from <- function(what) {
      X <- fit_get(fit, what)[[s]]
      for (k in seq_along(exps)[-1L]) {
        rows <- pick == k
        X[rows, ] <- fit_get(fit, what)[[site_of(exps[k], s)]][rows, , drop = FALSE]
      }
      X
    }
    list(M = moved_model_draws(fit, s, post, delta),
         B = if (shared) fit_get(fit, "wb")[[s]] else
           new_member_bias(from("wb"), lapply(exps, function(e) fit_get(fit, "wb")[[site_of(e, s)]])),
         S2 = from("sigma2"),
         pure = drop(bank_predict(site_bank(fit_get(fit, "emulators"), s), matrix(znew, 1L))$mean))
  })
  list(sites = out, tested = NA_character_, bias_from = if (shared) "shared" else "pooled",
       condition = v,
       experiment = exps[pick])
}

# The model's coefficients at the new condition, draw by draw: the
# emulators conditioned on the draw's model coefficients at the base
# condition (wM, at the same inputs) and predicted at the inputs moved by
# `delta`, their conditional variance drawn. The change from the base
# condition carries the emulators' uncertainty in it (the variances at both
# points less twice their covariance), not their mean change alone.
moved_model_draws <- function(fit, s, post, delta) {
  Z <- shift_inputs(fit, s, post)
  Znew <- Z
  for (p in names(delta)) Znew[, p] <- Znew[, p] + delta[[p]]
  wM <- fit_get(fit, "wM")[[s]]
  pa <- bank_predict_augmented(site_bank(fit_get(fit, "emulators"), s), Z, wM, Znew)
  out <- pa$mean + sqrt(pmax(pa$var, 0)) * matrix(stats::rnorm(length(wM)), nrow(wM))
  dimnames(out) <- dimnames(wM)
  out
}

# The bias at a condition not tested, from J tested conditions' biases
# (`each`, their draws by condition; `mixed`, draw h taken from one of them):
# a new member of the family the tested conditions are drawn from. The
# spread of J members about their mean understates a new member's by
# (J - 1) / J against its (J + 1) / J about that mean, so each draw's
# deviation from the conditions' mean of that draw is widened by
# sqrt((J + 1) / (J - 1)).
new_member_bias <- function(mixed, each) {
  J <- length(each)
  if (J < 2L) return(mixed)
  centre <- Reduce(`+`, each) / J
  centre + sqrt((J + 1) / (J - 1)) * (mixed - centre)
}

# Bands of a new condition at base site `s` from new_condition_setup()'s
# draws: the bias-corrected prediction (mean, lower, upper, lower_curve,
# upper_curve) and the model alone (model, model_lower, model_upper), both
# with the field noise when `noise`.
new_condition_site <- function(fit, s, setup, level, noise, keep_draws) {
  d <- setup$sites[[s]]
  Psi <- fit_get(fit, "basis")$Psi
  H <- nrow(d$M)
  eps <- if (noise) sqrt(d$S2) * matrix(stats::rnorm(length(d$M)), H)
  Wm <- if (noise) d$M + eps else d$M
  Wc <- Wm + d$B
  src <- curve_source(H, nrow(Psi), NULL, list(W = Wc, B = Psi, offset = numeric()))
  draws <- if (keep_draws) source_matrix(src)
  tb <- fit_get(fit, "basis")$t
  band <- band_frame(draws %||% src, tb, s, level)
  model <- band_frame(curve_source(H, nrow(Psi), NULL, list(W = Wm, B = Psi, offset = numeric())),
                      tb, s, level)
  band$model <- drop(Psi %*% d$pure)
  band$model_lower <- model$lower
  band$model_upper <- model$upper
  list(summary = band, draws = draws, n_guarded = 0)
}
