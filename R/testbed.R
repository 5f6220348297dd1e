#' Synthetic suspension test bed
#'
#' Builds a validation problem shaped like the report's case study: a
#' half-car model (C++, fixed-step RK4) driven over a proving-ground course
#' with fixed road roughness, a pothole met in 6 < t < 11 and a bump met in
#' 37 < t < 41; the output is the strut load (kN) at the front (`site1`) and
#' rear (`site2`) suspension on 4096 points `t = 65 * (0:4095) / 4096`.
#'
#' The nine inputs are coded as the report's Table 1:
#' `u1`, `u2` (calibration: compression and rebound damping) and `x1`..`x7`
#' (manufacturing variation: sprung mass, tire stiffness, spring stiffness,
#' top-mount bushing stiffness, unsprung mass, bump-stop clearance, bump-stop
#' stiffness); see [simulate_suspension()] for the map to physical values.
#'
#' Reality is the simulator at `x_nom + delta*` and `u*` (`delta*` drawn from
#' the prior of the I/U map, `u*` uniform on the calibration ranges) with the
#' `hidden` mechanisms switched on at full strength. Field replicates are
#' reality seen through a smooth monotone time warp (each event shifted by
#' 0.05 to 0.2 time units, differently in every replicate) plus AR(1)
#' measurement noise (lag-one correlation 0.95 per grid step, standard
#' deviation 0.03 kN).
#'
#' The returned list holds:
#' * `iu`: the I/U map (a `wv_iu`).
#' * `A$runs`: 66 model runs (a 65-point maximin Latin hypercube on the I/U
#'   ranges plus the nominal centre, last); `A$field`: 7 field replicates.
#' * `B$runs`: 65 model runs of a different vehicle (nominals `x_nom_B`; the
#'   same unit-cube design mapped to the I/U ranges shifted to the new
#'   nominals); `B$field`: 8 held-out replicates at `x_nom_B + delta_B*`, same
#'   `u*` and hidden mechanisms; `B$x_nom`.
#' * `added_mass$runs`: the nominal run and the run with `x1` raised by
#'   `added_mass$delta` (calibration inputs at their centre);
#'   `added_mass$field`: `n_added_mass` replicates (one by default, as in the
#'   method's report) of the real vehicle with the added mass.
#' * `truth`: `u`, `delta`, `delta_B` (named vectors), `x_nom_B`, `reality`,
#'   `reality_B`, `reality_added_mass` (named lists by site of noise-free
#'   curves), `warps` (the knots of every replicate's time warp: condition,
#'   replicate, `t`, and `w`, the course time seen at `t`), `hidden`, `seed`.
#' * `windows`: the event windows `list(c(6, 11), c(37, 41))`.
#'
#' The result depends only on `seed`; the caller's random number stream is
#' left as it was.
#'
#' @param seed A whole number fixing the design, the true inputs, the warps
#'   and the noise.
#' @param hidden `"none"` or one or several of `testbed_mechanisms()`: what
#'   reality has and the model lacks.
#' @param n_added_mass Number of field replicates with the added mass. More
#'   than one makes the added mass a second experiment worth calibrating on
#'   ([experiment()]); the other parts of the test bed do not change with it.
#' @return A `wv_testbed_suspension` object, also of class `wv_testbed` (a
#'   list, layout above).
#' @seealso [load_testbed()] for the instance shipped with the package,
#'   [simulate_suspension()] to run the model at other inputs.
#' @export
#' @examples
#' tb <- testbed_suspension(seed = 1, hidden = "progressive_bumpstop")
#' tb
#' autoplot(tb)
testbed_suspension <- function(seed = 1, hidden = "none", n_added_mass = 1) {
  check_number(seed, "seed", integer = TRUE)
  check_number(n_added_mass, "n_added_mass", min = 1, max = 100, integer = TRUE)
  spec <- suspension_spec(as.integer(n_added_mass))
  hidden <- spec_check_hidden(spec, hidden)
  with_rng_seed(seed, build_testbed_from_spec(spec, seed, hidden))
}

#' Names of the mechanisms reality can have and the model lacks
#'
#' * `"tire_liftoff"`: the tire cannot pull the wheel down (it leaves the
#'   ground at the pothole and the bump).
#' * `"strut_friction"`: smoothed Coulomb friction of 400 N in each strut
#'   (`400 v / sqrt(v^2 + 0.01^2)` at strut velocity `v` m/s), acting all
#'   along the rough road.
#' * `"digressive_damper"`: above 0.35 m/s the damping slope falls to 0.4 times
#'   (big events only).
#' * `"progressive_bumpstop"`: bump-stop force `k p (1 + p / 0.03)` at
#'   penetration `p` metres instead of `k p` (only in bump-stop contact, at
#'   the big events).
#'
#' In [simulate_suspension()] each is switched on by naming it in
#' `mechanism`; its strength is the design column `s_<name>` in \[0, 2\], 1
#' being reality's strength (the lift-off's in \[0, 1\]: at 1 the tire's
#' force in tension is gone). Strengths above 1 carry the mechanism beyond
#' reality's: they let a model with the mechanism added give its strength a
#' range that holds reality's inside it, not on its bound.
#' @return A character vector.
#' @export
#' @examples
#' testbed_mechanisms()
testbed_mechanisms <- function() {
  c("tire_liftoff", "strut_friction", "digressive_damper", "progressive_bumpstop")
}

#' Run the suspension model at chosen inputs
#'
#' Simulates the half-car of [testbed_suspension()] for every row of a design
#' in the coded units of the I/U map. A coded value `c` maps to the physical
#' value `p0 * (1 + g * (c - 0.5))`:
#'
#' | input | parameter | `p0` | `g` |
#' | --- | --- | --- | --- |
#' | `u1` | compression damping (front, rear) | 1700, 1600 N s/m | 1.2 |
#' | `u2` | rebound damping (front, rear) | 3600, 3300 N s/m | 1.2 |
#' | `x1` | sprung mass (pitch inertia scales with it) | 1150 kg | 0.6 |
#' | `x2` | tire stiffness per axle | 3.6e5 N/m | 0.6 |
#' | `x3` | spring stiffness (front, rear) | 3.6e4, 4.0e4 N/m | 0.6 |
#' | `x4` | top-mount bushing stiffness (in series with the damper) | 3e5 N/m | 0.9 |
#' | `x5` | unsprung mass (front, rear) | 80, 72 kg | 1.2 |
#' | `x6` | bump-stop clearance | 0.045 m | 0.6 |
#' | `x7` | bump-stop stiffness | 1.6e5 N/m | 0.9 |
#'
#' @param design A data frame (or named matrix) of coded inputs, one row per
#'   run. Inputs it lacks take their value from `nominal`.
#' @param mechanism `NULL` or names from [testbed_mechanisms()] to switch on;
#'   each needs a strength column `s_<name>` in `design`, with values in
#'   \[0, 2\] (1 = reality's strength; the lift-off's in \[0, 1\]).
#' @param nominal Named values for inputs missing from `design` (default 0.5
#'   for every input).
#' @param states `TRUE` to return the state histories of the runs too (see
#'   Value).
#' @param term `NULL` or an added term made by [testbed_term()] of a state
#'   `"compression"`, `"velocity"`, `"damper"` or `"tire"`: its strength is
#'   the design column `s_term` (any finite number). The term acts at both
#'   axles and may be on together with `mechanism`.
#' @return A `wv_runs` object with sites `site1` (front) and `site2` (rear) on
#'   the 4096-point grid; its design holds the columns of `design`. A run
#'   whose solution blows up (inputs far outside the I/U ranges) is dropped
#'   with a warning, as [model_runs()] does.
#'
#'   With `states = TRUE` it has the attribute `"states"`, a named list of
#'   matrices (one row per run, in the runs' order, on the curves' grid; the
#'   rows of dropped runs dropped too): `compression_front`,
#'   `compression_rear` (strut compression, m, from static equilibrium),
#'   `velocity_front`, `velocity_rear` (its rate, m/s of physical time; the
#'   grid is course time, a quarter of a second per unit), `damper_front`,
#'   `damper_rear` (damper force, kN) and `tire_front`, `tire_rear` (tire
#'   force, kN, an added tire term included). The curves are the same with
#'   or without the states.
#' @export
#' @examples
#' runs <- simulate_suspension(data.frame(u1 = c(0.3, 0.7), u2 = 0.5))
#' runs
#' with_friction <- simulate_suspension(
#'   data.frame(s_strut_friction = c(0, 1)), mechanism = "strut_friction"
#' )
#' autoplot(with_friction, windows = list(c(6, 11), c(37, 41)))
#' # the states, and an added term: extra damping of 1 kN per m/s
#' damping <- testbed_term("velocity", function(v) v)
#' runs <- simulate_suspension(data.frame(s_term = c(0, 1)), term = damping, states = TRUE)
#' names(attr(runs, "states"))
simulate_suspension <- function(design, mechanism = NULL, nominal = NULL, states = FALSE,
                                term = NULL) {
  spec_simulate(suspension_spec(), design, mechanism, nominal, states = states, term = term)
}

#' The shipped suspension test bed
#'
#' Reads the instance of [testbed_suspension()] shipped with the package in
#' `inst/extdata` (seed 2007, hidden mechanism `"progressive_bumpstop"`),
#' stored as CSV files: the curves xz-compressed, one row per curve
#' (`condition`, `run` or `replicate`, `site`, then `y1` to `y4096`, the
#' values at the grid points `t = 65 * (0:4095) / 4096`, with 6 significant
#' digits), the designs, the I/U map and the truth.
#'
#' @param dir Folder holding the CSV files (default: the shipped instance).
#' @return A `wv_testbed_suspension` (also a `wv_testbed`) with the layout
#'   of [testbed_suspension()].
#' @export
#' @examples
#' tb <- load_testbed()
#' summary(tb)
load_testbed <- function(dir = system.file("extdata", package = "wavevalid")) {
  check_string(dir, "dir")
  files <- file.path(dir, testbed_files())
  missing <- !file.exists(files)
  if (any(missing)) {
    wv_abort(c("Cannot find the test bed files in {.path {dir}}.",
               "x" = "Missing: {.file {basename(files[missing])}}."))
  }
  read_testbed(dir)
}

#' Signatures of the test bed's mechanisms
#'
#' The change of the load at each site when a mechanism is switched on at full
#' strength in the model, at given inputs: the candidate curves that
#' [explain_bias()] takes.
#'
#' @param inputs Named coded values of the model's inputs (e.g. the posterior
#'   means of a fit); inputs not given take their nominal 0.5.
#' @param mechanisms Names from [testbed_mechanisms()].
#' @return A named list (one element per mechanism) of named lists by site of
#'   curves on the test bed's grid.
#' @export
#' @examples
#' sig <- testbed_signatures(c(u1 = 0.5, u2 = 0.5), "progressive_bumpstop")
#' range(sig$progressive_bumpstop$site1)
testbed_signatures <- function(inputs, mechanisms = testbed_mechanisms()) {
  spec_signatures(suspension_spec(), inputs, mechanisms)
}

# --- specification ---------------------------------------------------------------

# The suspension test bed; `n_added_mass` replicates of the added-mass
# condition.
suspension_spec <- function(n_added_mass = 1L) {
  new_testbed_spec(
    name = "suspension", iu = testbed_iu(),
    mechanisms = testbed_mechanisms(), mechanisms_fn = "testbed_mechanisms",
    # the tire's force in tension is gone at strength 1: nothing beyond
    max_strength = c(tire_liftoff = 1),
    physical = testbed_physical,
    simulator = function(params, strength, t, term = NULL, states = FALSE) {
      if (is.null(term)) term <- list(state = -1L, range = numeric(), table = numeric(),
                                      strength = numeric())
      suspension_simulate_cpp(params, strength, t, 4L, term$state, term$range, term$table,
                              term$strength, states)
    },
    grid = testbed_grid(), windows = testbed_windows(),
    designs = suspension_designs,
    # condition B: a heavier vehicle on softer springs with less bump-stop
    # clearance and a stiffer bump stop
    nominal_B = c(x1 = 0.65, x2 = 0.5, x3 = 0.35, x4 = 0.5, x5 = 0.6, x6 = 0.4, x7 = 0.65),
    n_field = c(A = 7L, B = 8L),
    # knots at the start, both events, between and at the end; the events
    # move by 0.05 to 0.2 time units, the knots between them by half that
    warp = list(knots = c(0, 8, 23, 39, 52, 65), moved = 2:5, shift = c(0.05, 0.2),
                scale = c(1, 0.5, 1, 0.5)),
    noise = c(sd = 0.03, phi = 0.95),
    shifted = list(added_mass = list(shift = c(x1 = 0.15), n_field = n_added_mass,
                                     label = "added mass")),
    text = list(model = "test bed", title = "Suspension test bed",
                header = "<wv_testbed> suspension test bed", span = "[0, 65)",
                B = "new nominals", windows = "event windows",
                range = "Load range of the model runs of A (kN):")
  )
}

testbed_iu <- function() {
  iu_map(
    name = c("u1", "u2", paste0("x", 1:7)),
    type = rep(c("calibration", "variation"), c(2, 7)),
    lower = c(0.125, 0.125, 0.1667, 0.1667, 0.2083, 0.1923, 0.3529, 0.1471, 0.1923),
    upper = c(0.875, 0.875, 0.8333, 0.8333, 0.7917, 0.8077, 0.6471, 0.8529, 0.8077),
    nominal = rep(0.5, 9)
  )
}

# A: a 65-point maximin Latin hypercube on the I/U ranges and the nominal
# centre; B: the same unit cube on the ranges moved to B's nominals.
suspension_designs <- function(iu, nom_B, seed) {
  nom_A <- stats::setNames(iu$nominal, iu$name)
  cube <- maximin_lhd(65L, nrow(iu))
  to_range <- function(lower, upper) {
    d <- sweep(sweep(cube, 2L, upper - lower, `*`), 2L, lower, `+`)
    colnames(d) <- iu$name
    d
  }
  list(A = rbind(to_range(iu$lower, iu$upper), nom_A),
       B = to_range(iu$lower + nom_B - nom_A, iu$upper + nom_B - nom_A))
}

# Physical parameters (K x 18, order of ParamIndex in suspension.h) of coded inputs.
testbed_physical <- function(coded) {
  f <- function(v, g) 1 + g * (v - 0.5)
  ms <- 1150 * f(coded[, "x1"], 0.6)
  kt <- 3.6e5 * f(coded[, "x2"], 0.6)
  ks <- f(coded[, "x3"], 0.6)
  kb <- 3e5 * f(coded[, "x4"], 0.9)
  mu <- f(coded[, "x5"], 1.2)
  gap <- 0.045 * f(coded[, "x6"], 0.6)
  kbs <- 1.6e5 * f(coded[, "x7"], 0.9)
  cc <- f(coded[, "u1"], 1.2)
  cr <- f(coded[, "u2"], 1.2)
  cbind(ms = ms, iy = 1.45 * ms, muf = 80 * mu, mur = 72 * mu, ktf = kt, ktr = kt,
        ksf = 3.6e4 * ks, ksr = 4.0e4 * ks, kbf = kb, kbr = kb,
        ccf = 1700 * cc, crf = 3600 * cr, ccr = 1600 * cc, crr = 3300 * cr,
        kbsf = kbs, kbsr = kbs, gapf = gap, gapr = gap)
}
