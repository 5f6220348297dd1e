#' Predictions from a validated model
#'
#' Everything an engineer asks of a validated model (sections 5.2 to 5.4 of
#' the method): the bias-corrected prediction of reality, a new field run of
#' the same system, the same vehicle with a known change of its nominal inputs
#' (added load), a new vehicle of the same type, and a new vehicle with other
#' nominal inputs, with the bias carried over additively or multiplicatively.
#'
#' All types are built from the joint posterior draws of the fit (inputs,
#' model and bias coefficients, field variances), draw by draw:
#' * `"reality"`: `y^R = Psi (w^M + w^b)`.
#' * `"field_run"`: reality plus a draw of the measurement error.
#' * `"added_load"`: reality translated by `D(t)`, the difference of the two
#'   model runs in `new_runs` (the nominal run first, then the changed run),
#'   plus measurement error. Without runs, give the change of the nominal
#'   inputs as `delta`: `D` is then the emulators' difference between each
#'   posterior draw of the inputs moved by `delta` and the draw itself, which
#'   follows the tested vehicle's inputs rather than the nominal ones.
#' * `"new_vehicle"`: the variation inputs drawn from their prior (or fixed by
#'   `x_new`), the calibration inputs from the posterior; the model output at
#'   them from the emulators augmented with the posterior model coefficients
#'   at the tested vehicle's inputs (eq. 26); plus bias and measurement error.
#' * `"new_nominal"`: new emulators fitted to `new_runs` (the runs under the
#'   new nominals) on the same wavelet basis; variation inputs drawn from their
#'   prior around `x_nom`, calibration inputs, bias and field variances carried
#'   over jointly from the fit's draws; plus measurement error.
#' * `"new_condition"`: the same system at the value `condition` of the test
#'   conditions of the I/U map (see [iu_map()], section Conditions), tested
#'   or not; see the section New conditions.
#'
#' @section New conditions:
#' At a tested condition (the base experiment's or that of an experiment of
#' the fit) the prediction is that experiment's own: its model and bias
#' coefficient draws and field variances, exactly the draws of `type =
#' "field_run"` (or `"reality"` without noise) at its sites, without the
#' field detail outside the basis. At an untested condition the model part
#' is the emulators' change, draw by draw, from the base condition to the
#' new one (the path of `"added_load"` with `delta`): each posterior draw of
#' the inputs moved by the change of the conditions.
#'
#' The bias there was never observed. It is carried from the tested
#' conditions by the bias model's own structure: with one bias shared by the
#' experiments (`bias_control(experiment_bias = "shared")`) it is that bias,
#' which the model already assumes the same at every condition; with a bias
#' per experiment (the default), it is the tested conditions' biases pooled
#' as an equal mixture: draw `h` takes the bias (and the field variance) of
#' draw `h` of one tested condition, the conditions sharing the draws equally
#' in a random order. The mixture carries the spread of the bias across the
#' tested conditions into the band, so that a bias that changes with the
#' condition widens the band rather than being extrapolated by a trend two or
#' three conditions cannot support; the nearest tested condition alone would
#' narrow the band to one condition's bias and hide that spread. The result
#' says which was used (`bias_from`: `"tested"`, `"shared"` or `"pooled"`).
#'
#' The summary then has, besides the bias-corrected band, the band of the
#' model alone (`model_lower`, `model_upper`, with the same noise).
#'
#' With `bias = "multiplicative"` the bias of each draw is carried over as a
#' ratio, `y^R / y^M - 1`, applied to the new model output; where the model
#' output of a draw is near zero (below `guard` times its largest absolute
#' value) the additive bias is used instead.
#'
#' @inheritParams bands
#' @inheritParams calibrate
#' @param object A `wv_fit`.
#' @param type What to predict; see Details.
#' @param bias How the bias carries over to new settings.
#' @param new_runs A `wv_runs`: for `"added_load"` the nominal run and the run
#'   with the changed inputs; for `"new_nominal"` the model runs under the new
#'   nominals.
#' @param delta For `"added_load"` without `new_runs`: the named change of the
#'   nominal inputs.
#' @param x_nom For `"new_nominal"`: named nominal values of the variation
#'   inputs of the new system (default: the centre of each input's range in
#'   `new_runs`).
#' @param x_new For `"new_vehicle"`: optional named values at which to fix the
#'   variation inputs of the new vehicle instead of drawing them.
#' @param condition For `"new_condition"`: the named value of every condition
#'   input of the fit's I/U map, inside its design range.
#' @param residual For the types that predict the tested vehicle
#'   (`"reality"`, `"field_run"`, `"added_load"`): add the detail of its field
#'   curves outside the retained basis, with its sampling error (see
#'   [reality()]). The other types predict another vehicle, whose detail is
#'   not observed, and ignore it.
#' @param noise Add measurement error draws (default: yes for every type but
#'   `"reality"`).
#' @param guard Threshold for the multiplicative bias, relative to the largest
#'   absolute model output of a draw.
#' @param keep_draws Keep the curve draws in the result (memory: draws x time
#'   points per site).
#' @param ... Must be empty: an unknown argument is an error.
#' @return A `wv_prediction`: a list with `summary` (data frame with columns
#'   `site`, `t`, `mean`, `lower`, `upper` (pointwise band), `lower_curve`,
#'   `upper_curve` (band holding a `level` share of whole curves), `model`
#'   (pure-model prediction)), `type`, `bias`, `level`, `draws` (if kept) and
#'   what was used to build it. `as.data.frame()` returns `summary`. For
#'   `"new_condition"` also `condition`, `tested` (the experiment whose
#'   condition it is, or `NA`), `bias_from`, and the columns `model_lower`,
#'   `model_upper` of `summary`.
#' @export
#' @examples
#' ex <- example_problem()
#' # x1 a test condition: 0.5 in the base experiment, 0.7 in a second one
#' iu <- iu_map(c("u1", "x1"), c("calibration", "condition"), lower = c(0, 0), upper = c(1, 1),
#'              nominal = c(0.5, 0.5))
#' hot <- example_problem(seed = 2)$field  # other measurements, at x1 = 0.7
#' fit <- calibrate(ex$emulators, ex$field, iu, chains = 1, seed = 1,
#'                  experiments = list(hot = experiment(hot, condition = c(x1 = 0.7))),
#'                  sampler = sampler_control(n_draws = 100, n_inner = 20, quiet = TRUE))
#' # x1 = 0.6 was never tested
#' p <- predict(fit, type = "new_condition", condition = c(x1 = 0.6), noise = FALSE)
#' p
#' head(as.data.frame(p))
predict.wv_fit <- function(object, type = c("reality", "field_run", "added_load", "new_vehicle",
                                            "new_nominal",
                                            "new_condition"),
                           bias = c("additive", "multiplicative"), level = 0.9, new_runs = NULL,
                           delta = NULL,
                           x_nom = NULL,
                           x_new = NULL, residual = TRUE, noise = NULL, guard = 0.01,
                           keep_draws = FALSE,
                           seed = NULL, condition = NULL, ...) {
  check_dots_none(...)
  type <- check_choice(type)
  bias <- check_choice(bias)
  check_level(level)
  check_flag(residual)
  residual <- residual && type %in% c("reality", "field_run", "added_load")
  check_number(guard, min = 0, max = 1)
  noise <- noise %||% (type != "reality")
  check_flag(noise)
  seed <- resolve_seed(seed)
  warn_unmixed(object)
  if (!is.null(condition) && type != "new_condition") {
    wv_abort("{.arg condition} is used only by {.code type = \"new_condition\"}.",
             class = "condition")
  }
  if (type == "new_condition") {
    if (bias != "additive") {
      wv_abort("A new condition carries the bias additively; use {.code bias = \"additive\"}.",
               class = "condition")
    }
    return(predict_new_condition(object, condition, level, noise, keep_draws, seed))
  }
  em <- fit_get(object, "emulators")
  # the other experiments' sites for the fit's own conditions only; a new
  # load, vehicle or nominal changes the base experiment
  sites <- if (type %in% c("reality", "field_run")) fit_sites(object) else base_sites(object)
  # the draws of the set-up (prior draws of the variations, emulators of new
  # runs) come from their own stream, fixed by the seed
  setup_seed <- setup_seed_of(seed)
  new_model <- with_rng_seed(setup_seed, switch(type,
    added_load = if (is.null(new_runs) && !is.null(delta)) {
      added_load_emulated(object, delta)
    } else {
      added_load_difference(object, new_runs)
    },
    new_nominal = new_nominal_setup(object, new_runs, x_nom, setup_seed),
    new_vehicle = new_vehicle_setup(object, x_new),
    NULL
  ))
  if (type %in% c("reality", "field_run") && !is.null(new_runs)) {
    wv_abort("{.arg new_runs} is used only by types {.val added_load} and {.val new_nominal}.")
  }
  out <- with_rng_seed(seed, lapply(sites, function(s) {
    predict_site(object, s, type, bias, level, new_model, noise, guard, keep_draws, residual)
  }))
  names(out) <- sites
  structure(list(
    summary = do.call(rbind, lapply(out, `[[`, "summary")),
    draws = if (keep_draws) lapply(out, `[[`, "draws"),
    n_guarded = vapply(out, `[[`, 0, "n_guarded"),
    type = type, bias = bias, level = level, noise = noise, residual = residual, seed = seed,
    runs = if (type == "new_nominal") new_runs,
    field = if (type %in% c("reality", "field_run", "new_vehicle")) fit_get(object, "field"),
    x_nom = new_model$x_nom
  ), class = "wv_prediction")
}

# The prediction draws at one site and their bands. The coefficient draws of
# the new setting and of the measurement error are drawn first; the curves are
# then rebuilt from them block by block of time points (a curve source, see
# curve_bands()), so that they are held whole only with `keep_draws`.
predict_site <- function(fit, s, type, bias, level, new_model, noise, guard, keep_draws,
                         residual = FALSE) {
  Psi <- fit_get(fit, "basis")$Psi
  wM <- fit_get(fit, "wM")[[s]]
  wb <- fit_get(fit, "wb")[[s]]
  H <- nrow(wM)
  n_t <- nrow(Psi)
  pure <- pure_model_curve(fit, s)
  # added load: a curve added to every draw (runs given) or a change of the
  # model coefficients of every draw (change of inputs given)
  shift <- if (type == "added_load") new_model[["D"]][[s]]
  dW <- if (type == "added_load") new_model[["Dw"]][[s]]
  # new vehicle or nominals: the model coefficient draws of the new setting
  wNew <- if (type %in% c("new_vehicle", "new_nominal")) {
    new_model$mean[[s]] + sqrt(new_model$var[[s]]) * matrix(stats::rnorm(length(wM)), H)
  }
  if (type == "added_load") pure <- pure + (shift %||% drop(Psi %*% colMeans(dW)))
  if (type %in% c("new_vehicle", "new_nominal")) pure <- drop(Psi %*% new_model$pure[[s]])
  eps <- if (noise) sqrt(fit_get(fit, "sigma2")[[s]]) * matrix(stats::rnorm(length(wM)), H)
  detail <- if (residual) residual_source(fit, s, H, new_run = noise)
  additive <- bias == "additive" || type %in% c("reality", "field_run")
  model_block <- function(cols) basis_curves_block(wM, Psi, cols)
  n_guarded <- 0
  if (!additive) {
    # largest absolute model output of each draw, and the guarded points
    peak <- rep(-Inf, H)
    for (cols in col_blocks(n_t, H)) peak <- pmax(peak, apply(abs(model_block(cols)), 1L, max))
    for (cols in col_blocks(n_t, H)) n_guarded <- n_guarded +
      sum(abs(model_block(cols)) < guard * peak)
  }
  src <- curve_source(H, n_t, function(cols) {
    curves <- function(X) basis_curves_block(X, Psi, cols)
    yM <- curves(wM)
    yR <- yM + curves(wb)
    yNew <- switch(type,
      reality = , field_run = yM,
      added_load = if (is.null(dW)) yM + rep(shift[cols], each = H) else yM + curves(dW),
      new_vehicle = , new_nominal = curves(wNew)
    )
    if (additive) {
      y <- yNew + (yR - yM)
    } else {
      small <- abs(yM) < guard * peak
      y <- yNew * (yR / yM)
      y[small] <- (yNew + (yR - yM))[small]
    }
    if (noise) y <- y + curves(eps)
    if (residual) y <- y + detail(cols)
    y
  })
  # additive: the draws are linear in coefficient draws (the new setting's
  # model coefficients plus the bias, the measurement error, the weights of
  # the field detail when it has two or more replicates), rebuilt in C++
  det_lin <- if (residual) attr(detail, "linear")
  if (additive && (!residual || !is.null(det_lin))) {
    Wt <- switch(type,
      reality = , field_run = wM,
      added_load = if (is.null(dW)) wM else wM + dW,
      new_vehicle = , new_nominal = wNew
    ) + wb
    if (noise) Wt <- Wt + eps
    lin <- list(W = Wt, B = Psi,
                offset = if (type == "added_load" && is.null(dW)) shift else numeric())
    if (residual) {
      lin <- list(W = Wt, B = Psi, W2 = det_lin$W, B2 = det_lin$B,
                  offset = if (length(lin$offset)) lin$offset + det_lin$offset else det_lin$offset)
    }
    src <- curve_source(H, n_t, NULL, lin)
  }
  draws <- if (keep_draws) source_matrix(src)
  band <- band_frame(draws %||% src, fit_get(fit, "basis")$t, s, level)
  band$model <- pure
  list(
    summary = band,
    draws = draws,
    n_guarded = n_guarded
  )
}

check_new_runs <- function(fit, new_runs, call = rlang::caller_env()) {
  if (is.null(new_runs)) wv_abort("This prediction needs {.arg new_runs}, a {.cls wv_runs}.",
                                  call = call)
  check_class(new_runs, "wv_runs", call = call)
  tb <- fit_get(fit, "basis")$t
  if (!isTRUE(all.equal(new_runs$t, tb))) {
    wv_abort(c(
      "{.arg new_runs} must be on the fit's time grid.",
      "x" = "It has {length(new_runs$t)} points on [{signif(min(new_runs$t), 4)}, {signif(max(new_runs$t), 4)}]; the fit has {length(tb)} on [{signif(min(tb), 4)}, {signif(max(tb), 4)}]."
    ), call = call)
  }
  inputs <- fit_get(fit, "emulators")$inputs
  if (!setequal(names(new_runs$design), inputs)) {
    extra <- setdiff(names(new_runs$design), inputs)
    miss <- setdiff(inputs, names(new_runs$design))
    wv_abort(c(
      "{.arg new_runs} must have the fit's inputs.",
      "x" = if (length(extra)) "Unknown input{?s}: {.val {extra}}.",
      "x" = if (length(miss)) "Missing input{?s}: {.val {miss}}."
    ), call = call)
  }
  miss_site <- setdiff(base_sites(fit), names(new_runs$curves))
  if (length(miss_site)) {
    wv_abort("{.arg new_runs} has no curves for site{?s} {.val {miss_site}}.", call = call)
  }
  invisible(new_runs)
}

added_load_difference <- function(fit, new_runs, call = rlang::caller_env()) {
  check_new_runs(fit, new_runs, call = call)
  if (nrow(new_runs$design) != 2L) {
    wv_abort("For an added load, {.arg new_runs} must hold two runs: the nominal run, then the changed run.",
             call = call)
  }
  delta <- unlist(new_runs$design[2, ]) - unlist(new_runs$design[1, ])
  list(
    D = lapply(new_runs$curves[base_sites(fit)], function(m) m[2, ] - m[1, ]),
    delta = delta[delta != 0]
  )
}

# Emulated change of the model coefficients, draw by draw, when the inputs of
# each posterior draw move by delta.
added_load_emulated <- function(fit, delta, call = rlang::caller_env()) {
  inputs <- fit_get(fit, "emulators")$inputs
  if (!is.numeric(delta) || is.null(names(delta)) || any(!is.finite(delta)) ||
      !all(names(delta) %in% inputs)) {
    wv_abort(c(
      "{.arg delta} must be a named numeric change of the fit's inputs.",
      "i" = "The inputs are {.val {inputs}}."
    ), call = call)
  }
  post <- fit_draws_matrix(fit)[, inputs, drop = FALSE]
  moved <- post
  for (p in names(delta)) moved[, p] <- moved[, p] + delta[[p]]
  Dw <- lapply(base_sites(fit), function(s) {
    bank <- site_bank(fit_get(fit, "emulators"), s)
    bank_predict(bank, moved)$mean - bank_predict(bank, post)$mean
  })
  list(Dw = stats::setNames(Dw, base_sites(fit)), delta = delta)
}

new_nominal_setup <- function(fit, new_runs, x_nom, seed, call = rlang::caller_env()) {
  check_new_runs(fit, new_runs, call = call)
  inputs <- fit_get(fit, "emulators")$inputs
  iu <- fit_get(fit, "iu")
  var_inputs <- intersect(iu$name[iu$type == "variation"], inputs)
  if (is.null(x_nom)) {
    x_nom <- vapply(var_inputs, function(p) mean(range(new_runs$design[[p]])), numeric(1))
    wv_inform("Nominal inputs of the new system taken as the centre of {.arg new_runs}' design.")
  }
  if (!is.numeric(x_nom) || is.null(names(x_nom)) || !all(names(x_nom) %in% var_inputs)) {
    wv_abort("{.arg x_nom} must be a named numeric vector of variation inputs ({.val {var_inputs}}).", call = call)
  }
  new_runs$design <- new_runs$design[inputs]
  em_new <- fit_emulators(new_runs, fit_get(fit, "basis"),
                          engine = fit_get(fit, "emulators")$engine, seed = seed)
  predict_at_draws(fit, em_new, x_nom, x_new = NULL, augmented = FALSE)
}

new_vehicle_setup <- function(fit, x_new, call = rlang::caller_env()) {
  nominal <- fit_get(fit, "x_nom")
  if (!is.null(x_new)) {
    iu <- fit_get(fit, "iu")
    var_inputs <- intersect(iu$name[iu$type == "variation"], fit_get(fit, "emulators")$inputs)
    if (!is.numeric(x_new) || is.null(names(x_new)) || !all(names(x_new) %in% var_inputs)) {
      wv_abort("{.arg x_new} must be a named numeric vector of variation inputs ({.val {var_inputs}}).", call = call)
    }
  }
  predict_at_draws(fit, fit_get(fit, "emulators"), nominal, x_new = x_new, augmented = TRUE)
}

# Emulator means and variances, draw by draw, at the new vehicle's inputs:
# variation inputs from their prior around `nominal` (or fixed at x_new),
# calibration inputs from the posterior draws; `em` the emulators to predict
# with.
predict_at_draws <- function(fit, em, nominal, x_new, augmented) {
  inputs <- fit_get(fit, "emulators")$inputs
  iu <- fit_get(fit, "iu")
  post <- fit_draws_matrix(fit)[, inputs, drop = FALSE]
  H <- nrow(post)
  var_inputs <- intersect(iu$name[iu$type == "variation"], inputs)
  Znew <- post
  prior <- iu_prior_draws(iu, H, nominal = nominal)
  Znew[, var_inputs] <- prior[, var_inputs]
  if (!is.null(x_new)) for (p in names(x_new)) Znew[, p] <- x_new[[p]]
  zpure <- colMeans(post)
  nom_full <- iu$nominal[match(var_inputs, iu$name)]
  names(nom_full) <- var_inputs
  given <- intersect(names(nominal), var_inputs)
  nom_full[given] <- nominal[given]
  zpure[var_inputs] <- if (is.null(x_new)) nom_full else replace(nom_full, names(x_new), x_new)
  res <- lapply(base_sites(fit), function(s) {
    bank <- site_bank(em, s)
    pr <- if (augmented) {
      bank_predict_augmented(bank, post, fit_get(fit, "wM")[[s]], Znew)
    } else {
      bank_predict(bank, Znew)
    }
    pr$pure <- drop(bank_predict(bank, matrix(zpure, 1))$mean)
    pr
  })
  names(res) <- base_sites(fit)
  list(
    mean = lapply(res, `[[`, "mean"), var = lapply(res, `[[`, "var"),
    pure = lapply(res, `[[`, "pure"),
    x_nom = nominal
  )
}

# A prediction from chains that did not mix: a classed warning naming the
# inputs, so that its bands are not read as if they held their level.
warn_unmixed <- function(fit) {
  um <- unmixed_inputs(list(fit = fit))$fit
  if (length(um)) {
    wv_warn(c("The chains did not mix (R-hat {paste(sprintf('%s %.2f', names(um), um), collapse = ', ')}, above 1.1): the prediction's bands are not to be trusted.",
              "i" = "Draw more ({.code sampler_control(max_draws = )}), narrow the input's prior or reparametrise it, and validate again."),
            class = "mixing")
  }
  invisible(fit)
}
