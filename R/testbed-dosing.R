#' Synthetic dosing test bed
#'
#' A second validation problem, of other physics than the suspension of
#' [testbed_suspension()]: a pharmacokinetic study of a drug taken by mouth
#' in three doses of 400 mg at hours 2, 14 and 26. The output is the plasma
#' concentration (mg/L, site `"plasma"`) on 2048 points
#' `t = 48 * (0:2047) / 2048` hours: a sharp rise after each dose and a
#' two-phase decay. The model is a two-compartment model with first-order
#' absorption (C++, fixed-step RK4); see [simulate_dosing()] for its
#' equations and inputs.
#'
#' The six inputs are coded on \[0, 1\]: `u1`, `u2` (calibration: clearance
#' and absorption rate) and `x1`..`x4` (patient-to-patient variation: central
#' volume, bioavailability, body weight, intercompartmental clearance).
#'
#' Reality is the simulator at `x_nom + delta*` and `u*` (`delta*` drawn from
#' the prior of the I/U map, `u*` uniform on the calibration ranges) with the
#' `hidden` mechanisms switched on at full strength. Field replicates are
#' reality seen through a smooth monotone time warp (each dose time recorded
#' 0.03 to 0.12 hours off, differently in every replicate) plus AR(1) assay
#' noise (lag-one correlation 0.9 per grid step, standard deviation
#' 0.04 mg/L).
#'
#' The returned list has the layout of [testbed_suspension()] without its
#' added-mass condition:
#' * `iu`: the I/U map (a `wv_iu`).
#' * `A$runs`: 66 model runs ([design_maximin()] on the I/U ranges, 65 points
#'   plus the nominal centre, last); `A$field`: 6 field replicates.
#' * `B$runs`: 65 model runs of another patient group (heavier, with a larger
#'   central volume and a lower bioavailability: nominals `x_nom_B`; the same
#'   unit-cube design mapped to the I/U ranges shifted to the new nominals);
#'   `B$field`: 6 held-out replicates at `x_nom_B + delta_B*`, same `u*` and
#'   hidden mechanisms; `B$x_nom`.
#' * `truth`: `u`, `delta`, `delta_B` (named vectors), `x_nom_B`, `reality`,
#'   `reality_B` (named lists by site of noise-free curves), `warps` (the
#'   knots of every replicate's time warp: condition, replicate, `t`, and `w`,
#'   the study time seen at `t`), `hidden`, `seed`.
#' * `windows`: one window around each dose's rise,
#'   `list(c(1.5, 5), c(13.5, 17), c(25.5, 29))`.
#'
#' The result depends only on `seed`; the caller's random number stream is
#' left as it was.
#'
#' @inheritParams testbed_suspension
#' @param hidden `"none"` or one or several of `dosing_mechanisms()`: what
#'   reality has and the model lacks.
#' @return A `wv_testbed_dosing` object (a list, layout above).
#' @seealso [simulate_dosing()] to run the model at other inputs,
#'   [dosing_signatures()] for the mechanisms' effects.
#' @export
#' @examples
#' tb <- testbed_dosing(seed = 1, hidden = "enterohepatic_recycling")
#' tb
#' autoplot(tb, windows = NULL)
testbed_dosing <- function(seed = 1, hidden = "none") {
  check_number(seed, "seed", integer = TRUE)
  hidden <- check_dosing_hidden(hidden)
  with_rng_seed(seed, build_dosing(seed, hidden))
}

#' Names of the mechanisms the dosing model can lack
#'
#' * `"saturable_elimination"`: Michaelis-Menten elimination,
#'   `CL C / (1 + C / 10)` mg/h at concentration `C` mg/L instead of `CL C`.
#'   Mostly a lower clearance: the clearance input `u1` largely absorbs it.
#' * `"enterohepatic_recycling"`: half of the eliminated drug goes to the
#'   bile and returns to the gut when the gall bladder empties, about 4 hours
#'   after each dose: a secondary peak after each dose.
#' * `"absorption_lag"`: each dose reaches the gut 0.75 hours later: the rise
#'   is delayed.
#' * `"induction"`: the drug induces its own elimination; the clearance rises
#'   over the doses, up to 2.5 times at full induction (time constant 36 hours,
#'   half-effect at 3 mg/L): later doses decay faster.
#'
#' In [simulate_dosing()] each is switched on by naming it in `mechanism`;
#' its strength is the design column `s_<name>` in \[0, 1\], 1 being
#' reality's strength.
#' @return A character vector.
#' @export
#' @examples
#' dosing_mechanisms()
dosing_mechanisms <- function() {
  c("saturable_elimination", "enterohepatic_recycling", "absorption_lag", "induction")
}

#' Run the dosing model at chosen inputs
#'
#' Simulates the patient of [testbed_dosing()] for every row of a design in
#' the coded units of the I/U map. The model has five states, the amounts in
#' the gut `Ag`, the plasma `Ac`, the peripheral tissue `Ap` and the bile
#' `Ab` (mg), and an induction state `E`; with `C = Ac / V`:
#'
#' * `dAg/dt = F D sum_d phi(t - t_d - s_lag 0.75) + k_gb(t) Ab - ka Ag`
#' * `dAc/dt = ka Ag - e(t) - Q (C - Ap / Vp)`
#' * `dAp/dt = Q (C - Ap / Vp)`
#' * `dAb/dt = 0.5 s_rec e(t) - k_gb(t) Ab`
#' * `dE/dt = (C / (C + 3) - E) / 36`
#'
#' with the elimination rate `e(t) = CL (1 + 1.5 s_ind E) C / (1 + s_sat C / 10)`,
#' `D = 400` mg at the dose times `t_d` = 2, 14, 26 h, `phi` the normal
#' density of standard deviation 0.1 h (a tablet's dissolution) and the gall
#' bladder's emptying rate `k_gb(t) = 3 sum_d exp(-(t - t_d - 4)^2 / 0.18)`.
#' The strengths `s_sat`, `s_rec`, `s_lag`, `s_ind` are those of
#' [dosing_mechanisms()]; at 0 the model is the plain two-compartment model.
#' A coded value `c` maps to the physical value `p0 * (1 + g * (c - 0.5))`;
#' body weight `W` scales the volumes by `W / 70` and the clearances by
#' `(W / 70)^0.75`:
#'
#' | input | parameter | `p0` | `g` |
#' | --- | --- | --- | --- |
#' | `u1` | clearance `CL` | 5 L/h | 1.2 |
#' | `u2` | absorption rate `ka` | 1.5 1/h | 1.2 |
#' | `x1` | central volume `V` | 40 L | 0.6 |
#' | `x2` | bioavailability `F` | 0.8 | 0.4 |
#' | `x3` | body weight `W` | 70 kg | 0.6 |
#' | `x4` | intercompartmental clearance `Q` (`Vp` = 60 L) | 8 L/h | 1.2 |
#'
#' @param design A data frame (or named matrix) of coded inputs, one row per
#'   run. Inputs it lacks take their value from `nominal`.
#' @param mechanism `NULL` or names from [dosing_mechanisms()] to switch on;
#'   each needs a strength column `s_<name>` in `design`, with values in
#'   \[0, 1\] (1 = reality's strength).
#' @param nominal Named values for inputs missing from `design` (default 0.5
#'   for every input).
#' @return A `wv_runs` object with the site `plasma` on the 2048-point grid;
#'   its design holds the columns of `design`.
#' @export
#' @examples
#' runs <- simulate_dosing(data.frame(u1 = c(0.3, 0.7), u2 = 0.5))
#' runs
#' recycled <- simulate_dosing(
#'   data.frame(s_enterohepatic_recycling = c(0, 1)),
#'   mechanism = "enterohepatic_recycling"
#' )
#' autoplot(recycled)
simulate_dosing <- function(design, mechanism = NULL, nominal = NULL) {
  design <- check_dosing_design(design, mechanism, nominal)
  sim <- dosing_coded(design$full, design$strength)
  if (anyNA(sim$plasma)) {
    return(model_runs(design$user, sim, dosing_grid()))
  }
  user <- design$user
  rownames(user) <- NULL
  new_wv_runs(user, dosing_grid(), sim)
}

#' Signatures of the dosing mechanisms
#'
#' The change of the plasma concentration when a mechanism is switched on at
#' full strength in the model, at given inputs: the candidate curves that
#' [explain_bias()] takes.
#'
#' @param inputs Named coded values of the model's inputs (e.g. the posterior
#'   means of a fit); inputs not given take their nominal 0.5.
#' @param mechanisms Names from [dosing_mechanisms()].
#' @return A named list (one element per mechanism) of lists with one curve,
#'   `plasma`, on the test bed's grid.
#' @export
#' @examples
#' sig <- dosing_signatures(c(u1 = 0.5, u2 = 0.5), "absorption_lag")
#' range(sig$absorption_lag$plasma)
dosing_signatures <- function(inputs, mechanisms = dosing_mechanisms()) {
  if (!is.numeric(inputs) || is.null(names(inputs)) || any(!is.finite(inputs))) {
    wv_abort("{.arg inputs} must be a named numeric vector of coded input values.")
  }
  mechanisms <- setdiff(check_dosing_hidden(mechanisms), "none")
  base <- as.data.frame(as.list(inputs))
  off <- simulate_dosing(base)
  out <- lapply(mechanisms, function(m) {
    d <- base
    d[[paste0("s_", m)]] <- 1
    on <- simulate_dosing(d, mechanism = m)
    Map(function(a, b) a[1, ] - b[1, ], on$curves, off$curves)
  })
  stats::setNames(out, mechanisms)
}

# --- building ----------------------------------------------------------------

dosing_grid <- function() 48 * (0:2047) / 2048

dosing_times <- function() c(2, 14, 26)

dosing_windows <- function() list(c(1.5, 5), c(13.5, 17), c(25.5, 29))

dosing_iu <- function() {
  iu_map(
    name = c("u1", "u2", paste0("x", 1:4)),
    type = rep(c("calibration", "variation"), c(2, 4)),
    lower = c(0.125, 0.125, 0.2, 0.25, 0.2, 0.15),
    upper = c(0.875, 0.875, 0.8, 0.75, 0.8, 0.85),
    nominal = rep(0.5, 6)
  )
}

# Nominal x of condition B: heavier patients with a larger central volume and
# a lower bioavailability.
dosing_nominal_B <- function() c(x1 = 0.65, x2 = 0.35, x3 = 0.7, x4 = 0.5)

# Physical parameters (K x 6, order of ParamIndex in dosing.h) of coded inputs.
dosing_physical <- function(coded) {
  f <- function(v, g) 1 + g * (v - 0.5)
  w <- f(coded[, "x3"], 0.6)
  cbind(cl = 5 * f(coded[, "u1"], 1.2) * w^0.75, ka = 1.5 * f(coded[, "u2"], 1.2),
        v = 40 * f(coded[, "x1"], 0.6) * w, f = 0.8 * f(coded[, "x2"], 0.4),
        q = 8 * f(coded[, "x4"], 1.2) * w^0.75, vp = 60 * w)
}

# Simulates a K x 6 matrix of coded inputs with a K x 4 matrix of strengths.
dosing_coded <- function(coded, strength = NULL) {
  coded <- as.matrix(coded)
  if (is.null(strength)) strength <- matrix(0, nrow(coded), 4L)
  params <- dosing_physical(coded)
  if (any(!is.finite(params)) || any(params <= 0)) {
    wv_abort("The coded inputs give non-positive physical parameters; keep them within about [-0.3, 1.3].")
  }
  dosing_simulate_cpp(params, as.matrix(strength), dosing_times(), 400, dosing_grid(), 4L)
}

check_dosing_hidden <- function(hidden, call = rlang::caller_env()) {
  if (!is.character(hidden) || length(hidden) == 0L || anyNA(hidden)) {
    wv_abort("{.arg hidden} must be {.val none} or names from {.fn dosing_mechanisms}.", call = call)
  }
  bad <- setdiff(hidden, c("none", dosing_mechanisms()))
  if (length(bad)) {
    wv_abort(c("Unknown hidden mechanism{?s} {.val {bad}}.",
               "i" = "Choose {.val none} or among {.val {dosing_mechanisms()}}."), call = call)
  }
  if ("none" %in% hidden && length(hidden) > 1L) {
    wv_abort("{.arg hidden} cannot combine {.val none} with mechanisms.", call = call)
  }
  unique(hidden)
}

# Checks a user design; returns the user's data frame, the full K x 6 coded
# matrix and the K x 4 strength matrix.
check_dosing_design <- function(design, mechanism, nominal, call = rlang::caller_env()) {
  if (is.matrix(design) && !is.null(colnames(design))) design <- as.data.frame(design)
  if (!is.data.frame(design) || nrow(design) == 0L) {
    wv_abort("{.arg design} must be a data frame with one row per run and named input columns.", call = call)
  }
  inputs <- dosing_iu()$name
  mechs <- dosing_mechanisms()
  if (!is.null(mechanism)) {
    bad <- setdiff(mechanism, mechs)
    if (!is.character(mechanism) || length(bad)) {
      wv_abort(c("{.arg mechanism} must be names from {.fn dosing_mechanisms}.",
                 "x" = "Unknown: {.val {bad}}."), call = call)
    }
  }
  scols <- if (length(mechanism)) paste0("s_", mechanism) else character()
  extra <- setdiff(names(design), c(inputs, paste0("s_", mechs)))
  if (length(extra)) {
    wv_abort(c("{.arg design} has column{?s} {.val {extra}} the dosing model does not know.",
               "i" = "Inputs are {.val {inputs}}; mechanism strengths are {.val {paste0('s_', mechs)}}."),
             call = call)
  }
  unused <- setdiff(intersect(names(design), paste0("s_", mechs)), scols)
  if (length(unused)) {
    wv_abort(c("Strength column{?s} {.val {unused}} given but the mechanism is not switched on.",
               "i" = "Name it in {.arg mechanism}, e.g. {.code mechanism = {.val {sub('^s_', '', unused[1])}}}."),
             call = call)
  }
  lacking <- setdiff(scols, names(design))
  if (length(lacking)) {
    wv_abort(c("Every mechanism switched on needs its strength column in {.arg design}.",
               "x" = "Missing {.val {lacking}}."), call = call)
  }
  nonnum <- !vapply(design, is.numeric, logical(1))
  if (any(nonnum) || any(!vapply(design, function(v) all(is.finite(v)), logical(1)))) {
    wv_abort("Every column of {.arg design} must be numeric and finite.", call = call)
  }
  for (s in scols) {
    if (any(design[[s]] < 0 | design[[s]] > 1)) {
      wv_abort("Strength {.val {s}} must lie in [0, 1] (1 = reality's strength).", call = call)
    }
  }
  nom <- stats::setNames(rep(0.5, length(inputs)), inputs)
  if (!is.null(nominal)) {
    if (!is.numeric(nominal) || is.null(names(nominal)) || any(!names(nominal) %in% inputs) ||
        any(!is.finite(nominal))) {
      wv_abort("{.arg nominal} must be a named numeric vector over the inputs {.val {inputs}}.", call = call)
    }
    nom[names(nominal)] <- nominal
  }
  full <- matrix(nom, nrow(design), length(inputs), byrow = TRUE, dimnames = list(NULL, inputs))
  for (v in intersect(inputs, names(design))) full[, v] <- design[[v]]
  strength <- matrix(0, nrow(design), length(mechs))
  for (j in seq_along(mechs)) {
    if (mechs[j] %in% mechanism) strength[, j] <- design[[paste0("s_", mechs[j])]]
  }
  list(user = design, full = full, strength = strength)
}

# Smooth monotone time warp: knots at the start, at each dose, between the
# doses and at the end; each dose is seen 0.03 to 0.12 hours off either way.
draw_dosing_warp <- function() {
  knots <- c(0, 2, 8, 14, 20, 26, 37, 48)
  shift <- numeric(length(knots))
  shift[c(2, 4, 6)] <- sample(c(-1, 1), 3, replace = TRUE) * stats::runif(3, 0.03, 0.12)
  data.frame(t = knots, w = knots + shift)
}

# Field replicates of the noise-free curve `truth` (list(plasma = vector)).
dosing_field <- function(truth, n_rep, x_nom, condition) {
  t <- dosing_grid()
  warps <- lapply(seq_len(n_rep), function(r) draw_dosing_warp())
  curves <- lapply(truth, function(y) {
    m <- vapply(warps, function(w) apply_warp(y, t, w) + ar1_noise(length(t), sd = 0.04, phi = 0.9),
                numeric(length(t)))
    t(matrix(m, ncol = n_rep))
  })
  knots <- do.call(rbind, lapply(seq_len(n_rep), function(r) {
    cbind(data.frame(condition = condition, replicate = r), warps[[r]])
  }))
  list(field = new_wv_field(t, curves, x_nom), warps = knots)
}

dosing_reality <- function(coded, hidden) {
  strength <- matrix(as.numeric(dosing_mechanisms() %in% hidden), 1L, 4L)
  sim <- dosing_coded(matrix(coded, nrow = 1L, dimnames = list(NULL, names(coded))), strength)
  lapply(sim, as.numeric)
}

build_dosing <- function(seed, hidden) {
  iu <- dosing_iu()
  t <- dosing_grid()
  inputs <- iu$name
  xn <- inputs[iu$type == "variation"]
  nom_A <- stats::setNames(iu$nominal, inputs)
  nom_B <- nom_A
  nom_B[xn] <- dosing_nominal_B()[xn]
  iu_B <- iu
  iu_B$lower <- iu$lower + nom_B - nom_A
  iu_B$upper <- iu$upper + nom_B - nom_A
  iu_B$nominal <- unname(nom_B)
  design_A <- design_maximin(iu, 66L, seed = seed)
  design_B <- design_maximin(iu_B, 65L, nominal = FALSE, seed = seed)

  truth_draw <- iu_prior_draws(iu, 1L)[1, ]
  u_star <- truth_draw[c("u1", "u2")]
  delta <- truth_draw[xn] - nom_A[xn]
  reality <- dosing_reality(c(u_star, nom_A[xn] + delta), hidden)
  field_A <- dosing_field(reality, 6L, nom_A[xn], "A")

  delta_B <- iu_prior_draws(iu, 1L, nominal = nom_B[xn])[1, xn] - nom_B[xn]
  reality_B <- dosing_reality(c(u_star, nom_B[xn] + delta_B), hidden)
  field_B <- dosing_field(reality_B, 6L, nom_B[xn], "B")

  as_runs <- function(d) new_wv_runs(d, t, dosing_coded(d))
  new_wv_testbed_dosing(list(
    iu = iu,
    A = list(runs = as_runs(design_A), field = field_A$field),
    B = list(runs = as_runs(design_B), field = field_B$field, x_nom = nom_B[xn]),
    truth = list(u = u_star, delta = delta, delta_B = delta_B, x_nom_B = nom_B[xn],
                 reality = reality, reality_B = reality_B,
                 warps = rbind(field_A$warps, field_B$warps),
                 hidden = hidden, seed = as.integer(seed)),
    windows = dosing_windows()
  ))
}

# --- class -------------------------------------------------------------------

new_wv_testbed_dosing <- function(x) structure(x, class = "wv_testbed_dosing")

#' @export
print.wv_testbed_dosing <- function(x, ...) {
  cli::cat_line(sprintf("<wv_testbed_dosing> dosing test bed (seed %s, hidden mechanism: %s)", x$truth$seed,
                        paste(x$truth$hidden, collapse = ", ")))
  cli::cat_line(sprintf("  %d inputs: %s; site %s; %d time points in [0, 48) h", nrow(x$iu),
                        paste(x$iu$name, collapse = ", "), paste(names(x$A$runs$curves), collapse = ", "),
                        length(x$A$runs$t)))
  n_field <- function(f) nrow(f$curves[[1]])
  cli::cat_line(sprintf("  A: %d model runs, %d field replicates", nrow(x$A$runs$design), n_field(x$A$field)))
  cli::cat_line(sprintf("  B: %d model runs, %d held-out field replicates (another patient group)",
                        nrow(x$B$runs$design), n_field(x$B$field)))
  cli::cat_line("  dose windows: ", paste(vapply(x$windows, function(w) sprintf("%s < t < %s", w[1], w[2]),
                                                 character(1)), collapse = ", "))
  invisible(x)
}

#' @export
summary.wv_testbed_dosing <- function(object, ...) {
  structure(list(
    seed = object$truth$seed,
    hidden = object$truth$hidden,
    truth = c(object$truth$u, object$truth$delta),
    delta_B = object$truth$delta_B,
    x_nom_B = object$truth$x_nom_B,
    runs = c(A = nrow(object$A$runs$design), B = nrow(object$B$runs$design)),
    replicates = c(A = nrow(object$A$field$curves[[1]]), B = nrow(object$B$field$curves[[1]])),
    range_A = vapply(object$A$runs$curves, function(m) c(min = min(m), max = max(m)), numeric(2))
  ), class = "summary_wv_testbed_dosing")
}

#' @export
print.summary_wv_testbed_dosing <- function(x, ...) {
  cli::cat_line(sprintf("Dosing test bed, seed %s, hidden mechanism: %s", x$seed,
                        paste(x$hidden, collapse = ", ")))
  print(data.frame(condition = names(x$runs), model_runs = x$runs, field_replicates = x$replicates,
                   row.names = NULL), row.names = FALSE)
  cli::cat_line("True u* and delta* (condition A):")
  print(signif(x$truth, 3))
  cli::cat_line("Nominal x and delta* of condition B:")
  print(signif(rbind(x_nom_B = x$x_nom_B, delta_B = x$delta_B), 3))
  cli::cat_line("Concentration range of the model runs of A (mg/L):")
  print(signif(x$range_A, 4))
  invisible(x)
}

#' Plot the dosing test bed
#'
#' @param object A `wv_testbed_dosing`.
#' @param condition `"A"` or `"B"`.
#' @param windows Time windows to zoom into (default the three dose windows;
#'   `NULL` for the whole record).
#' @param ... Unused.
#' @return A ggplot of the model runs (grey) and field replicates of that
#'   condition.
#' @export
#' @examples
#' tb <- testbed_dosing(seed = 2, hidden = "absorption_lag")
#' autoplot(tb, "B")
autoplot.wv_testbed_dosing <- function(object, condition = c("A", "B"), windows = object$windows, ...) {
  condition <- check_choice(condition)
  autoplot(object[[condition]]$runs, field = object[[condition]]$field, windows = windows)
}

#' @export
plot.wv_testbed_dosing <- function(x, ...) {
  print(autoplot(x, ...))
  invisible(x)
}
