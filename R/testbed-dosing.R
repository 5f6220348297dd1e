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
#' With `doses`, the same patient is also studied at other dose amounts, the
#' amount a test condition (see [iu_map()], section Conditions). The list
#' then has `doses`, made after everything above (which `doses` leaves as it
#' was):
#' * `iu`: the I/U map with the condition `dose` (mg; nominal 400, the amount
#'   of condition A, the base experiment; design range from 0.9 times the
#'   smallest amount to 1.1 times the largest, 400 included);
#' * `runs`: `n_dose_runs` model runs ([design_maximin()] on that map, the
#'   nominal centre last), the dose among their inputs;
#' * `fields`: one `wv_field` per amount, named `"dose_<mg>"`, of 6
#'   replicates of reality at that amount (same `u*`, `delta*` and hidden
#'   mechanisms as A, warps and noise of their own), and `amounts`;
#' * `truth`: `reality` (a list by amount, named as `fields`, of noise-free
#'   curves by site) and `warps`.
#'
#' @inheritParams testbed_suspension
#' @param hidden `"none"` or one or several of `dosing_mechanisms()`: what
#'   reality has and the model lacks.
#' @param doses `NULL` or dose amounts in mg other than 400 at which the
#'   patient is also studied (see above).
#' @param n_dose_runs With `doses`: the number of model runs over the inputs
#'   and the dose.
#' @return A `wv_testbed_dosing` object, also of class `wv_testbed` (a list,
#'   layout above).
#' @seealso [simulate_dosing()] to run the model at other inputs,
#'   [dosing_signatures()] for the mechanisms' effects.
#' @export
#' @examples
#' tb <- testbed_dosing(seed = 1, hidden = "enterohepatic_recycling")
#' tb
#' autoplot(tb, windows = NULL)
#' \donttest{
#' # the dose amount as a test condition: fields at 250 and 550 mg besides A's 400
#' tb <- testbed_dosing(seed = 1, doses = c(250, 550), n_dose_runs = 40)
#' tb$doses$iu
#' names(tb$doses$fields)
#' }
testbed_dosing <- function(seed = 1, hidden = "none", doses = NULL, n_dose_runs = 80) {
  check_number(seed, "seed", integer = TRUE)
  spec <- dosing_spec()
  hidden <- spec_check_hidden(spec, hidden)
  if (!is.null(doses)) {
    if (!is.numeric(doses) || !length(doses) || any(!is.finite(doses)) || any(doses <= 0) ||
        anyDuplicated(doses) || any(doses == 400)) {
      wv_abort(c("{.arg doses} must be distinct positive dose amounts in mg, other than 400 (condition A's).",
                 "x" = "It is {.code {deparse(doses)}}."), class = "condition")
    }
    check_number(n_dose_runs, "n_dose_runs", min = 10, max = 1000, integer = TRUE)
  }
  with_rng_seed(seed, {
    tb <- build_testbed_from_spec(spec, seed, hidden)
    if (!is.null(doses)) tb$doses <- dosing_conditions(spec, tb, sort(doses),
                                                       as.integer(n_dose_runs), seed, hidden)
    tb
  })
}

# The patient of test bed `tb` at other dose amounts (testbed_dosing(doses =
# )), with the RNG already seeded: the I/U map with the condition `dose`, the
# runs over it, and reality and its field replicates at each amount.
dosing_conditions <- function(spec, tb, amounts, n_runs, seed, hidden) {
  iu <- tb$iu
  xn <- iu$name[iu$type == "variation"]
  span <- range(c(amounts, 400))
  iu_d <- iu_add(iu, "dose", type = "condition", lower = 0.9 * span[1], upper = 1.1 * span[2],
                 nominal = 400)
  design <- design_maximin(iu_d, n_runs, seed = seed)
  runs <- new_wv_runs(design, spec$grid, spec_simulate_coded(spec, as.matrix(design)))
  nom <- stats::setNames(iu$nominal, iu$name)
  x_star <- c(tb$truth$u, nom[xn] + tb$truth$delta)
  labels <- paste0("dose_", format(amounts, trim = TRUE))
  made <- lapply(seq_along(amounts), function(j) {
    reality <- spec_reality(spec, c(x_star, dose = amounts[j]), hidden)
    c(list(reality = reality), make_field(spec, reality, spec$n_field[["A"]], nom[xn], labels[j]))
  })
  names(made) <- labels
  list(iu = iu_d, runs = runs, fields = lapply(made, `[[`, "field"),
       amounts = stats::setNames(amounts, labels),
       truth = list(reality = lapply(made, `[[`, "reality"),
                    warps = do.call(rbind, unname(lapply(made, `[[`, "warps")))))
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
#' its strength is the design column `s_<name>` in \[0, 2\], 1 being
#' reality's strength. Strengths above 1 carry the mechanism beyond
#' reality's: they let a model with the mechanism added give its strength a
#' range that holds reality's inside it, not on its bound.
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
#' `D` mg (400 unless the design's column `dose` says otherwise) at the dose
#' times `t_d` = 2, 14, 26 h, `phi` the normal
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
#'   run. Inputs it lacks take their value from `nominal`. A column `dose`
#'   sets each run's dose amount in mg (default 400), a known input of the
#'   model: a test condition (see [iu_map()], section Conditions, and
#'   `testbed_dosing(doses = )`).
#' @param mechanism `NULL` or names from [dosing_mechanisms()] to switch on;
#'   each needs a strength column `s_<name>` in `design`, with values in
#'   \[0, 2\] (1 = reality's strength).
#' @param nominal Named values for inputs missing from `design` (default 0.5
#'   for every input).
#' @param states `TRUE` to return the state histories of the runs too (see
#'   Value).
#' @param term `NULL` or an added term made by [testbed_term()] of a state
#'   `"concentration"`, `"gut"`, `"central"`, `"peripheral"`, `"bile"` or
#'   `"induction"`: an extra elimination `s_term f(x)` mg/h from the central
#'   compartment (`dAc/dt = ... - s_term f(x)`), its strength the design
#'   column `s_term` (any finite number). It may be on together with
#'   `mechanism`.
#' @return A `wv_runs` object with the site `plasma` on the 2048-point grid;
#'   its design holds the columns of `design`. A run whose solution blows up
#'   is dropped with a warning, as [model_runs()] does.
#'
#'   With `states = TRUE` it has the attribute `"states"`, a named list of
#'   matrices (one row per run, in the runs' order, on the curves' grid):
#'   `gut`, `central`, `peripheral`, `bile` (the amounts `Ag`, `Ac`, `Ap`,
#'   `Ab`, mg), `induction` (`E`) and `concentration` (`C`, mg/L, the same
#'   numbers as the curves). The curves are the same with or without the
#'   states.
#' @export
#' @examples
#' runs <- simulate_dosing(data.frame(u1 = c(0.3, 0.7), u2 = 0.5))
#' runs
#' # the same patient at two dose amounts
#' simulate_dosing(data.frame(dose = c(250, 550)))
#' recycled <- simulate_dosing(
#'   data.frame(s_enterohepatic_recycling = c(0, 1)),
#'   mechanism = "enterohepatic_recycling"
#' )
#' autoplot(recycled)
#' # the states, and an added term: a second clearance of 2 L/h
#' clearance <- testbed_term("concentration", function(C) 2 * C)
#' runs <- simulate_dosing(data.frame(s_term = c(0, 1)), term = clearance, states = TRUE)
#' apply(attr(runs, "states")$central, 1, max)
simulate_dosing <- function(design, mechanism = NULL, nominal = NULL, states = FALSE, term = NULL) {
  spec_simulate(dosing_spec(), design, mechanism, nominal, states = states, term = term)
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
  spec_signatures(dosing_spec(), inputs, mechanisms)
}

# --- specification ---------------------------------------------------------------

dosing_spec <- function() {
  doses <- c(2, 14, 26)
  new_testbed_spec(
    name = "dosing", iu = dosing_iu(),
    mechanisms = dosing_mechanisms(), mechanisms_fn = "dosing_mechanisms",
    physical = dosing_physical,
    simulator = function(params, strength, t, term = NULL, states = FALSE) {
      if (is.null(term)) term <- list(state = -1L, range = numeric(), table = numeric(),
                                      strength = numeric())
      dosing_simulate_cpp(params[, 1:6, drop = FALSE], strength, doses, params[, "dose"], t, 4L,
                          term$state, term$range, term$table, term$strength, states)
    },
    known = c(dose = 400),
    grid = 48 * (0:2047) / 2048, windows = list(c(1.5, 5), c(13.5, 17), c(25.5, 29)),
    designs = dosing_designs,
    # condition B: heavier patients with a larger central volume and a lower
    # bioavailability
    nominal_B = c(x1 = 0.65, x2 = 0.35, x3 = 0.7, x4 = 0.5),
    n_field = c(A = 6L, B = 6L),
    # knots at the start, at each dose, between the doses and at the end;
    # each dose is seen 0.03 to 0.12 hours off either way
    warp = list(knots = c(0, 2, 8, 14, 20, 26, 37, 48), moved = c(2L, 4L, 6L),
                shift = c(0.03, 0.12),
                scale = 1),
    noise = c(sd = 0.04, phi = 0.9),
    text = list(model = "dosing model", title = "Dosing test bed",
                header = "<wv_testbed_dosing> dosing test bed", span = "[0, 48) h",
                B = "another patient group", windows = "dose windows",
                range = "Concentration range of the model runs of A (mg/L):")
  )
}

dosing_iu <- function() {
  iu_map(
    name = c("u1", "u2", paste0("x", 1:4)),
    type = rep(c("calibration", "variation"), c(2, 4)),
    lower = c(0.125, 0.125, 0.2, 0.25, 0.2, 0.15),
    upper = c(0.875, 0.875, 0.8, 0.75, 0.8, 0.85),
    nominal = rep(0.5, 6)
  )
}

# A: design_maximin() on the I/U ranges (65 points and the nominal centre);
# B: the same unit cube on the ranges moved to B's nominals.
dosing_designs <- function(iu, nom_B, seed) maximin_designs(iu, nom_B, seed, 66L, 65L)

# Physical parameters (K x 6, order of ParamIndex in dosing.h) of coded
# inputs, and the dose amount in mg (the column `dose` of `coded`, else 400).
dosing_physical <- function(coded) {
  f <- function(v, g) 1 + g * (v - 0.5)
  w <- f(coded[, "x3"], 0.6)
  dose <- if ("dose" %in% colnames(coded)) coded[, "dose"] else rep(400, nrow(coded))
  cbind(cl = 5 * f(coded[, "u1"], 1.2) * w^0.75, ka = 1.5 * f(coded[, "u2"], 1.2),
        v = 40 * f(coded[, "x1"], 0.6) * w, f = 0.8 * f(coded[, "x2"], 0.4),
        q = 8 * f(coded[, "x4"], 1.2) * w^0.75, vp = 60 * w, dose = dose)
}
