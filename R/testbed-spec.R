# A test bed as a specification: the model's inputs (the I/U map), the
# mechanisms reality can have and the model lacks, the simulator with its
# grid and event windows, the designs of the model runs, the warps and noise
# of the field replicates, and the held-out conditions. One builder, one
# design check and one signature routine serve every test bed;
# testbed_suspension(), testbed_dosing() and testbed_units() are three
# specifications.

# `physical(coded)` maps a K x p matrix of coded inputs to the simulator's
# physical parameters; `simulator(params, strength, t, term = NULL, states =
# FALSE)` runs them with a K x m matrix of mechanism strengths and returns a
# named list by site of K x T matrices (a row of NA for a run that blew up);
# `term` is an added term as spec_check_term() gives it, and with `states`
# the list carries the attribute "states" (named list of K x T matrices).
# `designs(iu, nom_B, seed)` gives the designs of conditions A and B. `n_field` holds the number
# of field replicates of A and B. `warp` moves the knots `moved` of
# `knots` by a random sign times U(`shift`) times `scale`. `shifted` holds
# the conditions met by moving the inputs of A (list of `shift`, a named
# change of the coded inputs, `n_field` and `label`). `text` holds the words
# of messages and prints. `max_strength` names the mechanisms whose strength
# cannot exceed a physical limit below 2 (the largest strength otherwise).
# `known` holds the simulator's known inputs outside the I/U map with their
# default values (the dosing bed's dose amount, mg): a design may set them,
# and `physical()` receives them as columns. `units` (NULL for beds whose
# replicates repeat one unit) holds `n_units` and `n_rep`: the field
# replicates of A and B are then `n_units` units, each with its own
# variation inputs, tested `n_rep` times (build_units_testbed()).
new_testbed_spec <- function(name, iu, mechanisms, mechanisms_fn, physical, simulator, grid,
                             windows,
                             designs, nominal_B, n_field, warp, noise, shifted = list(), text,
                             max_strength = NULL, known = NULL, units = NULL) {
  structure(list(name = name, iu = iu, mechanisms = mechanisms, mechanisms_fn = mechanisms_fn,
                 max_strength = max_strength,
                 physical = physical, simulator = simulator, grid = grid, windows = windows,
                 designs = designs, nominal_B = nominal_B, n_field = n_field, warp = warp,
                 noise = noise, shifted = shifted, text = text, known = known, units = units),
            class = "wv_testbed_spec")
}

testbed_specs <- function() {
  list(suspension = suspension_spec, dosing = dosing_spec, units = units_spec)
}

# The specification of a built test bed (a bare "wv_testbed" is a suspension
# test bed built before the beds had their own classes).
testbed_spec_of <- function(x) {
  kind <- intersect(sub("^wv_testbed_", "", class(x)), names(testbed_specs()))
  testbed_specs()[[if (length(kind)) kind[1] else "suspension"]]()
}

new_wv_testbed <- function(x, kind) {
  structure(x, class = c(paste0("wv_testbed_", kind), "wv_testbed"))
}

# The conditions of a test bed: "A", "B" and any shifted ones.
testbed_conditions <- function(x) setdiff(names(x), c("iu", "truth", "windows", "doses"))

# --- checks --------------------------------------------------------------------

spec_check_hidden <- function(spec, hidden, call = rlang::caller_env()) {
  mechs <- spec$mechanisms
  if (!is.character(hidden) || length(hidden) == 0L || anyNA(hidden)) {
    wv_abort("{.arg hidden} must be {.val none} or names from {.fn {spec$mechanisms_fn}}.",
             call = call)
  }
  bad <- setdiff(hidden, c("none", mechs))
  if (length(bad)) {
    wv_abort(c("Unknown hidden mechanism{?s} {.val {bad}}.",
               "i" = "Choose {.val none} or among {.val {mechs}}."), call = call)
  }
  if ("none" %in% hidden && length(hidden) > 1L) {
    wv_abort("{.arg hidden} cannot combine {.val none} with mechanisms.", call = call)
  }
  unique(hidden)
}

# Checks a user design; returns the user's data frame, the full K x p coded
# matrix and the K x m strength matrix.
spec_check_design <- function(spec, design, mechanism, nominal, call = rlang::caller_env()) {
  if (is.matrix(design) && !is.null(colnames(design))) design <- as.data.frame(design)
  if (!is.data.frame(design) || nrow(design) == 0L) {
    wv_abort("{.arg design} must be a data frame with one row per run and named input columns.",
             call = call)
  }
  known <- spec$known %||% numeric()
  inputs <- c(spec$iu$name, names(known))
  mechs <- spec$mechanisms
  scols <- check_mechanism_columns(spec, design, mechanism, call)
  nonnum <- !vapply(design, is.numeric, logical(1))
  if (any(nonnum) || any(!vapply(design, function(v) all(is.finite(v)), logical(1)))) {
    wv_abort("Every column of {.arg design} must be numeric and finite.", call = call)
  }
  for (s in scols) {
    top <- unname(spec$max_strength[sub("^s_", "", s)])
    if (!length(top) || is.na(top)) top <- 2
    if (any(design[[s]] < 0 | design[[s]] > top)) {
      wv_abort("Strength {.val {s}} must lie in [0, {top}] (1 = reality's strength).", call = call)
    }
  }
  for (v in intersect(names(known), names(design))) {
    if (any(design[[v]] <= 0)) {
      wv_abort("The column {.val {v}} of {.arg design} must be positive (default {known[[v]]}).",
               call = call)
    }
  }
  nom <- stats::setNames(c(rep(0.5, length(spec$iu$name)), known), inputs)
  if (!is.null(nominal)) {
    if (!is.numeric(nominal) || is.null(names(nominal)) || any(!names(nominal) %in% inputs) ||
        any(!is.finite(nominal))) {
      wv_abort("{.arg nominal} must be a named numeric vector over the inputs {.val {inputs}}.",
               call = call)
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

# The mechanisms switched on against the columns of the design: returns the
# strength columns of the mechanisms switched on.
check_mechanism_columns <- function(spec, design, mechanism, call) {
  inputs <- c(spec$iu$name, names(spec$known))
  mechs <- spec$mechanisms
  if (!is.null(mechanism)) {
    bad <- setdiff(mechanism, mechs)
    if (!is.character(mechanism) || length(bad)) {
      wv_abort(c("{.arg mechanism} must be names from {.fn {spec$mechanisms_fn}}.",
                 "x" = "Unknown: {.val {bad}}."), call = call)
    }
  }
  scols <- if (length(mechanism)) paste0("s_", mechanism) else character()
  extra <- setdiff(names(design), c(inputs, paste0("s_", mechs)))
  if (length(extra)) {
    wv_abort(c(paste0("{.arg design} has column{?s} {.val {extra}} the ", spec$text$model,
                      " does not know."),
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
  scols
}

# --- simulating ------------------------------------------------------------------

# Simulates a K x p matrix of coded inputs with a K x m matrix of strengths,
# an added term (NULL or as spec_check_term() gives it) and, with `states`,
# the state histories as the attribute "states" of the result.
spec_simulate_coded <- function(spec, coded, strength = NULL, term = NULL, states = FALSE,
                                call = rlang::caller_env()) {
  coded <- as.matrix(coded)
  if (is.null(strength)) strength <- matrix(0, nrow(coded), length(spec$mechanisms))
  params <- spec$physical(coded)
  if (any(!is.finite(params)) || any(params <= 0)) {
    wv_abort("The coded inputs give non-positive physical parameters; keep them within about [-0.3, 1.3].",
             call = call)
  }
  if (is.null(term) && !states) return(spec$simulator(params, as.matrix(strength), spec$grid))
  spec$simulator(params, as.matrix(strength), spec$grid, term = term, states = states)
}

# The model runs of a user design (simulate_suspension(), simulate_dosing()),
# with the state histories as the attribute "states" when `states` is TRUE
# (rows of failed runs dropped as model_runs() drops their curves).
spec_simulate <- function(spec, design, mechanism = NULL, nominal = NULL, states = FALSE,
                          term = NULL,
                          call = rlang::caller_env()) {
  check_flag(states, "states", call = call)
  termed <- spec_check_term(spec, design, term, call = call)
  checked <- spec_check_design(spec, termed$design, mechanism, nominal, call = call)
  user <- if (is.null(term)) checked$user else as.data.frame(design)
  sim <- spec_simulate_coded(spec, checked$full, checked$strength, term = termed$term,
                             states = states,
                             call = call)
  hist <- attr(sim, "states")
  attr(sim, "states") <- NULL
  if (anyNA(sim[[1L]])) {
    failed <- Reduce(`|`, lapply(sim, function(m) apply(m, 1L, function(r) any(!is.finite(r)))))
    runs <- model_runs(user, sim, spec$grid)
    hist <- lapply(hist, function(m) m[!failed, , drop = FALSE])
  } else {
    rownames(user) <- NULL
    runs <- new_wv_runs(user, spec$grid, sim)
  }
  if (states) attr(runs, "states") <- hist
  runs
}

hidden_strength <- function(hidden, mechanisms) {
  matrix(as.numeric(mechanisms %in% hidden), 1L, length(mechanisms))
}

spec_reality <- function(spec, coded, hidden) {
  coded <- matrix(coded, nrow = 1L, dimnames = list(NULL, names(coded)))
  lapply(spec_simulate_coded(spec, coded, hidden_strength(hidden, spec$mechanisms)), as.numeric)
}

# The change of each site's output when a mechanism is switched on at full
# strength at the coded `inputs` (testbed_signatures(), dosing_signatures()).
spec_signatures <- function(spec, inputs, mechanisms, call = rlang::caller_env()) {
  if (!is.numeric(inputs) || is.null(names(inputs)) || any(!is.finite(inputs))) {
    wv_abort("{.arg inputs} must be a named numeric vector of coded input values.", call = call)
  }
  mechanisms <- setdiff(spec_check_hidden(spec, mechanisms, call = call), "none")
  base <- as.data.frame(as.list(inputs))
  off <- spec_simulate(spec, base, call = call)
  out <- lapply(mechanisms, function(m) {
    d <- base
    d[[paste0("s_", m)]] <- 1
    on <- spec_simulate(spec, d, mechanism = m, call = call)
    Map(function(a, b) a[1, ] - b[1, ], on$curves, off$curves)
  })
  stats::setNames(out, mechanisms)
}

# --- building --------------------------------------------------------------------

# The designs of conditions A and B by design_maximin(): `n_A` points on the
# I/U ranges (the nominal centre among them), `n_B` on the ranges moved to
# B's nominals `nom_B`.
maximin_designs <- function(iu, nom_B, seed, n_A, n_B) {
  nom_A <- stats::setNames(iu$nominal, iu$name)
  iu_B <- iu
  iu_B$lower <- iu$lower + nom_B - nom_A
  iu_B$upper <- iu$upper + nom_B - nom_A
  iu_B$nominal <- unname(nom_B)
  list(A = design_maximin(iu, n_A, seed = seed),
       B = design_maximin(iu_B, n_B, nominal = FALSE, seed = seed))
}

# Model runs of the test bed's simulator at the coded design `d`.
spec_runs <- function(spec, d) {
  rownames(d) <- NULL
  d <- as.data.frame(d)
  new_wv_runs(d, spec$grid, spec_simulate_coded(spec, d))
}

# Builds a test bed from its specification with the RNG already seeded:
# the designs, the true inputs of A, reality and the field of A, then those
# of B, then the shifted conditions.
build_testbed_from_spec <- function(spec, seed, hidden) {
  if (!is.null(spec$units)) return(build_units_testbed(spec, seed, hidden))
  iu <- spec$iu
  inputs <- iu$name
  xn <- inputs[iu$type == "variation"]
  nom_A <- stats::setNames(iu$nominal, inputs)
  nom_B <- nom_A
  nom_B[xn] <- spec$nominal_B[xn]
  designs <- spec$designs(iu, nom_B, seed)

  truth_draw <- iu_prior_draws(iu, 1L)[1, ]
  u_star <- truth_draw[inputs[iu$type == "calibration"]]
  delta <- truth_draw[xn] - nom_A[xn]
  x_star <- c(u_star, nom_A[xn] + delta)
  reality <- spec_reality(spec, x_star, hidden)
  field_A <- make_field(spec, reality, spec$n_field[["A"]], nom_A[xn], "A")

  delta_B <- iu_prior_draws(iu, 1L, nominal = nom_B[xn])[1, xn] - nom_B[xn]
  reality_B <- spec_reality(spec, c(u_star, nom_B[xn] + delta_B), hidden)
  field_B <- make_field(spec, reality_B, spec$n_field[["B"]], nom_B[xn], "B")

  shifted <- Map(function(cd, sh) shifted_condition(spec, cd, sh, nom_A, x_star, hidden),
                 names(spec$shifted), spec$shifted)
  conditions <- c(
    list(A = list(runs = spec_runs(spec, designs$A), field = field_A$field),
         B = list(runs = spec_runs(spec, designs$B), field = field_B$field,
                  x_nom = nom_B[xn])),
    lapply(shifted, function(s) list(runs = spec_runs(spec, s$design), field = s$field,
                                     delta = s$delta))
  )
  truth <- c(
    list(u = u_star, delta = delta, delta_B = delta_B, x_nom_B = nom_B[xn], reality = reality,
         reality_B = reality_B),
    stats::setNames(lapply(shifted, `[[`, "reality"), sprintf("reality_%s", names(shifted))),
    list(warps = do.call(rbind,
                         c(list(field_A$warps, field_B$warps),
                           unname(lapply(shifted, `[[`, "warps")))),
         hidden = hidden, seed = as.integer(seed))
  )
  new_wv_testbed(c(list(iu = iu), conditions, list(truth = truth, windows = spec$windows)),
                 spec$name)
}

# A condition met by moving the inputs of A by `sh$shift`: the nominal run and
# the moved one, reality at the moved true inputs and its field replicates.
shifted_condition <- function(spec, condition, sh, nom_A, x_star, hidden) {
  dm <- sh$shift
  xn <- spec$iu$name[spec$iu$type == "variation"]
  design <- rbind(nom_A, nom_A)
  design[2L, names(dm)] <- design[2L, names(dm)] + dm
  x_star[names(dm)] <- x_star[names(dm)] + dm
  reality <- spec_reality(spec, x_star, hidden)
  x_nom <- nom_A[xn]
  x_nom[names(dm)] <- x_nom[names(dm)] + dm
  field <- make_field(spec, reality, sh$n_field, x_nom, condition)
  list(design = design, field = field$field, warps = field$warps, delta = dm, reality = reality)
}

# --- units ----------------------------------------------------------------------

# A test bed whose field replicates are units (spec$units), with the RNG
# already seeded: the designs, the true calibration inputs, then the units
# of A and those of B. The population's delta is the mean unit's.
build_units_testbed <- function(spec, seed, hidden) {
  iu <- spec$iu
  inputs <- iu$name
  xn <- inputs[iu$type == "variation"]
  nom_A <- stats::setNames(iu$nominal, inputs)
  nom_B <- nom_A
  nom_B[xn] <- spec$nominal_B[xn]
  designs <- spec$designs(iu, nom_B, seed)
  u_star <- iu_prior_draws(iu, 1L)[1, inputs[iu$type == "calibration"]]
  A <- make_units(spec, u_star, nom_A[xn], hidden, "A")
  B <- make_units(spec, u_star, nom_B[xn], hidden, "B")
  truth <- list(u = u_star, delta = A$delta, delta_B = B$delta, x_nom_B = nom_B[xn],
                reality = A$reality, reality_B = B$reality,
                units_delta = A$units_delta, units_delta_B = B$units_delta,
                reality_units = A$reality_units, reality_units_B = B$reality_units,
                warps = NULL, hidden = hidden, seed = as.integer(seed))
  new_wv_testbed(list(iu = iu, A = list(runs = spec_runs(spec, designs$A), field = A$field),
                      B = list(runs = spec_runs(spec, designs$B), field = B$field,
                               x_nom = nom_B[xn]),
                      truth = truth, windows = spec$windows),
                 spec$name)
}

# The units of one condition: each unit's variation inputs drawn from the
# I/U map's prior around `x_nom`, its noise-free curve at `u_star` with the
# hidden mechanisms, and `n_rep` tests of it with independent noise, in
# unit order. Units are labelled by the condition and their number.
make_units <- function(spec, u_star, x_nom, hidden, condition) {
  n_units <- spec$units[["n_units"]]
  n_rep <- spec$units[["n_rep"]]
  xn <- names(x_nom)
  labels <- paste0(condition, seq_len(n_units))
  draws <- iu_prior_draws(spec$iu, n_units, nominal = x_nom)[, xn, drop = FALSE]
  units_delta <- sweep(draws, 2L, x_nom)
  dimnames(units_delta) <- list(labels, xn)
  coded <- cbind(matrix(u_star, n_units, length(u_star), byrow = TRUE,
                        dimnames = list(NULL, names(u_star))), draws)
  strength <- hidden_strength(hidden, spec$mechanisms)[rep(1L, n_units), , drop = FALSE]
  real_units <- lapply(spec_simulate_coded(spec, coded, strength), function(m) {
    rownames(m) <- labels
    m
  })
  n_t <- length(spec$grid)
  curves <- lapply(real_units, function(m) {
    t(vapply(rep(seq_len(n_units), each = n_rep),
             function(j) unname(m[j, ]) + spec_noise(spec, n_t), numeric(n_t)))
  })
  ids <- rep(labels, each = n_rep)
  units <- check_units(stats::setNames(rep(list(ids), length(curves)), names(curves)), curves)
  delta <- colMeans(units_delta)
  list(field = new_wv_field(spec$grid, curves, x_nom, units = units),
       units_delta = units_delta, delta = delta, reality_units = real_units,
       reality = spec_reality(spec, c(u_star, x_nom + delta), hidden))
}

# --- field replicates ----------------------------------------------------------------

# Smooth monotone time warp: the knots `moved` are shifted either way by
# U(shift) times their `scale`.
draw_warp <- function(warp) {
  m <- length(warp$moved)
  shift <- numeric(length(warp$knots))
  shift[warp$moved] <- sample(c(-1, 1), m, replace = TRUE) * stats::runif(m, warp$shift[1],
                                                                          warp$shift[2]) *
    warp$scale
  data.frame(t = warp$knots, w = warp$knots + shift)
}

apply_warp <- function(y, t, warp) {
  w <- stats::splinefun(warp$t, warp$w, method = "monoH.FC")(t)
  stats::splinefun(t, y, method = "fmm")(pmin(pmax(w, t[1]), t[length(t)]))
}

ar1_noise <- function(n, sd = 0.03, phi = 0.95) {
  e <- stats::rnorm(n, sd = sd * sqrt(1 - phi^2))
  as.numeric(stats::filter(e, phi, method = "recursive", init = stats::rnorm(1, sd = sd)))
}

spec_noise <- function(spec, n) ar1_noise(n, sd = spec$noise[["sd"]], phi = spec$noise[["phi"]])

# Field replicates of noise-free curves `truth` (named list by site of
# vectors): one warp per replicate shared by the sites, independent noise.
make_field <- function(spec, truth, n_rep, x_nom, condition) {
  t <- spec$grid
  warps <- lapply(seq_len(n_rep), function(r) draw_warp(spec$warp))
  curves <- lapply(truth, function(y) {
    t(vapply(warps, function(w) apply_warp(y, t, w) + spec_noise(spec, length(t)),
             numeric(length(t))))
  })
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
  spec <- testbed_spec_of(tb)
  f <- tb$A$field
  reality <- if (is.null(warp)) tb$truth$reality else lapply(tb$truth$reality, apply_warp, t = f$t,
                                                             warp = warp)
  with_rng_seed(seed, for (s in names(f$curves)) {
    f$curves[[s]] <- t(vapply(seq_len(nrow(f$curves[[s]])),
                              function(r) reality[[s]] + spec_noise(spec, length(f$t)),
                              numeric(length(f$t))))
  })
  f
}
