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
#' @return A `wv_testbed` object (a list, layout above).
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
  hidden <- check_hidden(hidden)
  with_rng_seed(seed, build_testbed(seed, hidden, as.integer(n_added_mass)))
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
#' `mechanism`; its strength is the design column `s_<name>` in \[0, 1\], 1
#' being reality's strength.
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
#'   \[0, 1\] (1 = reality's strength).
#' @param nominal Named values for inputs missing from `design` (default 0.5
#'   for every input).
#' @return A `wv_runs` object with sites `site1` (front) and `site2` (rear) on
#'   the 4096-point grid; its design holds the columns of `design`. A run
#'   whose solution blows up (inputs far outside the I/U ranges) is dropped
#'   with a warning, as [model_runs()] does.
#' @export
#' @examples
#' runs <- simulate_suspension(data.frame(u1 = c(0.3, 0.7), u2 = 0.5))
#' runs
#' with_friction <- simulate_suspension(
#'   data.frame(s_strut_friction = c(0, 1)), mechanism = "strut_friction"
#' )
#' autoplot(with_friction, windows = list(c(6, 11), c(37, 41)))
simulate_suspension <- function(design, mechanism = NULL, nominal = NULL) {
  design <- check_testbed_design(design, mechanism, nominal)
  sim <- simulate_coded(design$full, design$strength)
  if (anyNA(sim$site1)) {
    return(model_runs(design$user, sim, testbed_grid()))
  }
  user <- design$user
  rownames(user) <- NULL
  new_wv_runs(user, testbed_grid(), sim)
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
#' @return A `wv_testbed` with the layout of [testbed_suspension()].
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

# --- building ----------------------------------------------------------------

testbed_iu <- function() {
  iu_map(
    name = c("u1", "u2", paste0("x", 1:7)),
    type = rep(c("calibration", "variation"), c(2, 7)),
    lower = c(0.125, 0.125, 0.1667, 0.1667, 0.2083, 0.1923, 0.3529, 0.1471, 0.1923),
    upper = c(0.875, 0.875, 0.8333, 0.8333, 0.7917, 0.8077, 0.6471, 0.8529, 0.8077),
    nominal = rep(0.5, 9)
  )
}

# Nominal x of condition B: a heavier vehicle on softer springs with less
# bump-stop clearance and a stiffer bump stop.
testbed_nominal_B <- function() {
  c(x1 = 0.65, x2 = 0.5, x3 = 0.35, x4 = 0.5, x5 = 0.6, x6 = 0.4, x7 = 0.65)
}

testbed_added_mass <- function() c(x1 = 0.15)

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

# Simulates a K x 9 matrix of coded inputs with a K x 4 matrix of strengths.
simulate_coded <- function(coded, strength = NULL) {
  coded <- as.matrix(coded)
  if (is.null(strength)) strength <- matrix(0, nrow(coded), 4L)
  params <- testbed_physical(coded)
  if (any(!is.finite(params)) || any(params <= 0)) {
    wv_abort("The coded inputs give non-positive physical parameters; keep them within about [-0.3, 1.3].")
  }
  suspension_simulate_cpp(params, as.matrix(strength), testbed_grid(), 4L)
}

check_hidden <- function(hidden, call = rlang::caller_env()) {
  if (!is.character(hidden) || length(hidden) == 0L || anyNA(hidden)) {
    wv_abort("{.arg hidden} must be {.val none} or names from {.fn testbed_mechanisms}.", call = call)
  }
  bad <- setdiff(hidden, c("none", testbed_mechanisms()))
  if (length(bad)) {
    wv_abort(c("Unknown hidden mechanism{?s} {.val {bad}}.",
               "i" = "Choose {.val none} or among {.val {testbed_mechanisms()}}."), call = call)
  }
  if ("none" %in% hidden && length(hidden) > 1L) {
    wv_abort("{.arg hidden} cannot combine {.val none} with mechanisms.", call = call)
  }
  unique(hidden)
}

# Checks a user design; returns the user's data frame, the full K x 9 coded
# matrix and the K x 4 strength matrix.
check_testbed_design <- function(design, mechanism, nominal, call = rlang::caller_env()) {
  if (is.matrix(design) && !is.null(colnames(design))) design <- as.data.frame(design)
  if (!is.data.frame(design) || nrow(design) == 0L) {
    wv_abort("{.arg design} must be a data frame with one row per run and named input columns.", call = call)
  }
  inputs <- testbed_iu()$name
  mechs <- testbed_mechanisms()
  if (!is.null(mechanism)) {
    bad <- setdiff(mechanism, mechs)
    if (!is.character(mechanism) || length(bad)) {
      wv_abort(c("{.arg mechanism} must be names from {.fn testbed_mechanisms}.",
                 "x" = "Unknown: {.val {bad}}."), call = call)
    }
  }
  scols <- if (length(mechanism)) paste0("s_", mechanism) else character()
  known <- c(inputs, paste0("s_", mechs))
  extra <- setdiff(names(design), known)
  if (length(extra)) {
    wv_abort(c("{.arg design} has column{?s} {.val {extra}} the test bed does not know.",
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
  strength <- matrix(0, nrow(design), 4L)
  for (j in seq_along(mechs)) if (mechs[j] %in% mechanism) strength[, j] <- design[[scols[match(mechs[j], mechanism)]]]
  list(user = design, full = full, strength = strength)
}

hidden_strength <- function(hidden, k = 1L) {
  matrix(as.numeric(testbed_mechanisms() %in% hidden), k, 4L, byrow = TRUE)
}

# Smooth monotone time warp: knots at the start, both events, between and at
# the end; the events are shifted by 0.05 to 0.2 time units either way.
draw_warp <- function() {
  knots <- c(0, 8, 23, 39, 52, 65)
  shift <- c(0, sample(c(-1, 1), 4, replace = TRUE) * stats::runif(4, 0.05, 0.2), 0)
  shift[c(3, 5)] <- shift[c(3, 5)] / 2
  data.frame(t = knots, w = knots + shift)
}

apply_warp <- function(y, t, warp) {
  w <- stats::splinefun(warp$t, warp$w, method = "monoH.FC")(t)
  stats::splinefun(t, y, method = "fmm")(pmin(pmax(w, t[1]), t[length(t)]))
}

ar1_noise <- function(n, sd = 0.03, phi = 0.95) {
  e <- stats::rnorm(n, sd = sd * sqrt(1 - phi^2))
  as.numeric(stats::filter(e, phi, method = "recursive", init = stats::rnorm(1, sd = sd)))
}

# Field replicates of noise-free curves `truth` (named list by site of
# vectors): one warp per replicate shared by the sites, independent noise.
make_field <- function(truth, n_rep, x_nom, condition) {
  t <- testbed_grid()
  warps <- lapply(seq_len(n_rep), function(r) draw_warp())
  curves <- lapply(truth, function(y) {
    t(vapply(warps, function(w) apply_warp(y, t, w) + ar1_noise(length(t)), numeric(length(t))))
  })
  curves <- lapply(curves, function(m) if (n_rep == 1L) matrix(m, nrow = 1L) else m)
  knots <- do.call(rbind, lapply(seq_len(n_rep), function(r) {
    cbind(data.frame(condition = condition, replicate = r), warps[[r]])
  }))
  list(field = new_wv_field(t, curves, x_nom), warps = knots)
}

# The field data of condition A of a test bed `tb` as a perfect registration
# would leave them: reality plus the same kind of noise as the replicates, one
# curve for each replicate, no time warps. With `warp` (a table of knots
# `t`, `w` as draw_warp() gives), reality is warped by it before the noise,
# the same warp for every replicate. For checks of what the registration
# costs.
unwarped_field <- function(tb, seed, warp = NULL) {
  f <- tb$A$field
  reality <- if (is.null(warp)) tb$truth$reality else lapply(tb$truth$reality, apply_warp, t = f$t, warp = warp)
  with_rng_seed(seed, for (s in names(f$curves)) {
    f$curves[[s]] <- t(vapply(seq_len(nrow(f$curves[[s]])),
                              function(r) reality[[s]] + ar1_noise(length(f$t)),
                              numeric(length(f$t))))
  })
  f
}

reality_curves <- function(coded, hidden) {
  sim <- simulate_coded(matrix(coded, nrow = 1L, dimnames = list(NULL, names(coded))), hidden_strength(hidden))
  lapply(sim, as.numeric)
}

build_testbed <- function(seed, hidden, n_added_mass = 1L) {
  iu <- testbed_iu()
  t <- testbed_grid()
  inputs <- iu$name
  xn <- iu$name[iu$type == "variation"]
  nom_A <- stats::setNames(iu$nominal, inputs)

  cube <- maximin_lhd(65L, length(inputs))
  to_range <- function(lower, upper) {
    d <- sweep(sweep(cube, 2L, upper - lower, `*`), 2L, lower, `+`)
    colnames(d) <- inputs
    d
  }
  design_A <- rbind(to_range(iu$lower, iu$upper), nom_A)
  nom_B <- nom_A
  nom_B[xn] <- testbed_nominal_B()[xn]
  design_B <- to_range(iu$lower + nom_B - nom_A, iu$upper + nom_B - nom_A)

  truth_draw <- iu_prior_draws(iu, 1L)[1, ]
  u_star <- truth_draw[c("u1", "u2")]
  delta <- truth_draw[xn] - nom_A[xn]
  x_star <- c(u_star, nom_A[xn] + delta)
  reality <- reality_curves(x_star, hidden)
  field_A <- make_field(reality, 7L, nom_A[xn], "A")

  delta_B <- iu_prior_draws(iu, 1L, nominal = nom_B[xn])[1, xn] - nom_B[xn]
  x_star_B <- c(u_star, nom_B[xn] + delta_B)
  reality_B <- reality_curves(x_star_B, hidden)
  field_B <- make_field(reality_B, 8L, nom_B[xn], "B")

  dm <- testbed_added_mass()
  design_m <- rbind(nom_A, nom_A)
  design_m[2L, names(dm)] <- design_m[2L, names(dm)] + dm
  x_star_m <- x_star
  x_star_m[names(dm)] <- x_star_m[names(dm)] + dm
  reality_m <- reality_curves(x_star_m, hidden)
  x_nom_m <- nom_A[xn]
  x_nom_m[names(dm)] <- x_nom_m[names(dm)] + dm
  field_m <- make_field(reality_m, n_added_mass, x_nom_m, "added_mass")

  as_runs <- function(d) {
    rownames(d) <- NULL
    new_wv_runs(as.data.frame(d), t, simulate_coded(d))
  }
  new_wv_testbed(list(
    iu = iu,
    A = list(runs = as_runs(design_A), field = field_A$field),
    B = list(runs = as_runs(design_B), field = field_B$field, x_nom = nom_B[xn]),
    added_mass = list(runs = as_runs(design_m), field = field_m$field, delta = dm),
    truth = list(u = u_star, delta = delta, delta_B = delta_B, x_nom_B = nom_B[xn],
                 reality = reality, reality_B = reality_B, reality_added_mass = reality_m,
                 warps = rbind(field_A$warps, field_B$warps, field_m$warps),
                 hidden = hidden, seed = as.integer(seed)),
    windows = testbed_windows()
  ))
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
  if (!is.numeric(inputs) || is.null(names(inputs)) || any(!is.finite(inputs))) {
    wv_abort("{.arg inputs} must be a named numeric vector of coded input values.")
  }
  mechanisms <- setdiff(check_hidden(mechanisms), "none")
  base <- as.data.frame(as.list(inputs))
  off <- simulate_suspension(base)
  out <- lapply(mechanisms, function(m) {
    d <- base
    d[[paste0("s_", m)]] <- 1
    on <- simulate_suspension(d, mechanism = m)
    Map(function(a, b) a[1, ] - b[1, ], on$curves, off$curves)
  })
  stats::setNames(out, mechanisms)
}
