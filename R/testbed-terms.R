#' A term added to a test bed's simulator
#'
#' Describes a term to add to the equations of [simulate_suspension()],
#' [simulate_dosing()] or [simulate_units()]: a function `fun` of one state of the model, times a
#' strength, entering where a force or a rate enters. The strength is the
#' design column `s_term` (any finite number, negative allowed; 0 gives the
#' model without the term, exactly). A mechanism the model lacks can be
#' written as such a term, and the term can be on together with the
#' mechanisms of `mechanism`.
#'
#' `fun` is tabulated once, on `n_table` equally spaced points over `range`;
#' the simulator interpolates the table linearly between the points and
#' extrapolates it linearly beyond the ends (from the two end points). The
#' interpolation error at spacing `h = diff(range) / (n_table - 1)` is at most
#' `h^2 / 8` times the largest second derivative of `fun`: raise `n_table` or
#' narrow `range` for a sharply curved `fun`.
#'
#' Suspension states (the term acts at both axles, each with its own axle's
#' state and the same `fun`; the two axles' bump stops and friction are alike
#' in the model):
#'
#' | `state` | value of the state | `fun` returns | added to | default `range` |
#' | --- | --- | --- | --- | --- |
#' | `"compression"` | strut compression `d` (m) | force (kN) | the strut force | \[-0.25, 0.25\] |
#' | `"velocity"` | strut compression rate `v` (m/s) | force (kN) | the strut force | \[-14, 14\] |
#' | `"damper"` | damper force (kN, compression > 0) | velocity (m/s) | see below | \[-32, 32\] |
#' | `"tire"` | tire force before the term (kN) | force (kN) | the tire force | \[-70, 90\] |
#'
#' A term of the damper force is added to the damper's velocity at that force
#' (the inverse of the damper law).
#'
#' A term of the compression or the velocity is part of the strut force, so
#' it shows in the strut loads the simulator reports (the total force in the
#' strut).
#'
#' Dosing states (every term is an extra elimination rate from the central
#' compartment, `dAc/dt = ... - s_term fun(x)` mg/h; it does not go to the
#' bile):
#'
#' | `state` | value of the state | default `range` |
#' | --- | --- | --- |
#' | `"concentration"` | plasma concentration `C` (mg/L) | \[-5, 75\] |
#' | `"gut"` | amount in the gut `Ag` (mg) | \[-100, 1300\] |
#' | `"central"` | amount in the central compartment `Ac` (mg) | \[-150, 2200\] |
#' | `"peripheral"` | amount in the peripheral compartment `Ap` (mg) | \[-150, 2300\] |
#' | `"bile"` | amount in the bile `Ab` (mg) | \[-200, 2900\] |
#' | `"induction"` | induction state `E` (dimensionless) | \[-0.1, 1.5\] |
#'
#' Cooling state (the term is an extra heat loss of the specimen,
#' `m c dT/dt = ... - s_term fun(T)` W):
#'
#' | `state` | value of the state | default `range` |
#' | --- | --- | --- |
#' | `"temperature"` | specimen temperature `T` (K) | \[150, 650\] |
#'
#' The cooling bed's temperatures lie within 295 to 500 K over the design
#' ranges of its conditions A and B; its default range widens that span by
#' at least half of it on either side.
#'
#' The default ranges of the suspension and dosing states hold every value
#' the state takes in runs over the I/U
#' ranges of [testbed_suspension()] and [testbed_dosing()]: the design of
#' condition A and about 40 corners of the ranges (the dosing runs at 400 and
#' 1000 mg), without mechanisms and with each mechanism at strength 2 (the
#' lift-off at 1; the friction at 1 where 2 blows up). Those values span
#' compression -0.11 to 0.12 m, velocity -6.1 to 7.1 m/s, damper force -16 to
#' 12 kN, tire force -30 to 45 kN, concentration 0 to 47 mg/L, gut 0 to
#' 840 mg, central 0 to 1450 mg, peripheral 0 to 1520 mg, bile 0 to 1920 mg
#' and induction 0 to 0.64; each default widens that span by at least half of
#' it on either side, so that a term of moderate strength keeps the state on
#' the table, except below the dosing states, which cannot be negative: their
#' tables start at about a tenth of the largest value below zero (a
#' Michaelis-Menten `fun` of the concentration, `C / (10 + C)`, stays finite
#' on the table). A wide table is coarse: for a `fun` curved over a small part of
#' it (a smoothed friction, say) give a narrower `range` or a larger
#' `n_table`. `testbed_term()` does not know which simulator the term is
#' for; the simulator checks the state against its own list.
#'
#' @param state The state the term is a function of, a name from the tables
#'   above.
#' @param fun A vectorised function of the state's values (in the units above)
#'   returning the term's values, finite numbers of the same length.
#' @param range `NULL` (the default range of `state`, above) or two
#'   increasing finite numbers: the span of the table.
#' @param n_table Number of points of the table, a whole number of at least 3.
#' @return A `wv_testbed_term` object: a list with `state`, `fun`, `range`,
#'   `n_table`, `x` and `y` (the table).
#' @seealso [simulate_suspension()], [simulate_dosing()], [simulate_units()].
#' @export
#' @examples
#' # the progressive bump stop of testbed_mechanisms() at the nominal inputs
#' # (bump-stop stiffness 1.6e5 N/m, clearance 0.045 m), written as a term of
#' # the strut compression
#' bump <- testbed_term("compression", function(d) 1.6e5 * pmax(d - 0.045, 0)^2 / 0.03 / 1000)
#' bump
#' runs <- simulate_suspension(data.frame(s_term = c(0, 1)), term = bump, states = TRUE)
#' range(runs$curves$site1[2, ] - runs$curves$site1[1, ])
#' range(attr(runs, "states")$compression_front)
#' # saturable elimination at clearance 5 L/h, as a term of the concentration
#' sat <- testbed_term("concentration", function(C) -5 * C^2 / (10 + C))
#' simulate_dosing(data.frame(s_term = 1), term = sat)
testbed_term <- function(state, fun, range = NULL, n_table = 4001) {
  known <- term_states()
  if (!is.character(state) || length(state) != 1L || is.na(state) || !state %in% known$state) {
    wv_abort(c("{.arg state} must name one state of a test bed's simulator.",
               "i" = "Suspension: {.val {known$state[known$bed == 'suspension']}}.",
               "i" = "Dosing: {.val {known$state[known$bed == 'dosing']}}.",
               "i" = "Cooling (units): {.val {known$state[known$bed == 'units']}}."),
             class = c("term", "input"))
  }
  if (!is.function(fun)) {
    wv_abort("{.arg fun} must be a function of the state's values, not {.obj_type_friendly {fun}}.",
             class = c("term", "input"))
  }
  if (!is.numeric(n_table) || length(n_table) != 1L || !is.finite(n_table) ||
      n_table != round(n_table) ||
      n_table < 3) {
    wv_abort("{.arg n_table} must be a whole number of at least 3.", class = c("term", "input"))
  }
  info <- known[known$state == state, ]
  if (is.null(range)) range <- c(info$lower, info$upper)
  if (!is.numeric(range) || length(range) != 2L || any(!is.finite(range)) || range[2] <= range[1]) {
    wv_abort("{.arg range} must be two increasing finite numbers.", class = c("term", "input"))
  }
  range <- as.numeric(range)
  x <- seq(range[1], range[2], length.out = n_table)
  y <- tryCatch(fun(x), error = function(e) {
    wv_abort("{.arg fun} failed on the table's points.", parent = e, class = c("term", "input"))
  })
  if (!is.numeric(y) || length(y) != length(x) || any(!is.finite(y))) {
    wv_abort(c("{.arg fun} must return finite numbers, one per value of the state.",
               "x" = "On the {n_table} points of [{range[1]}, {range[2]}] it returned {.obj_type_friendly {y}} of length {length(y)}{if (is.numeric(y) && any(!is.finite(y))) ', not all finite' else ''}."),
             class = c("term", "input"))
  }
  structure(list(state = state, fun = fun, range = range, n_table = as.integer(n_table), x = x,
                 y = as.numeric(y)),
            class = "wv_testbed_term")
}

#' @export
print.wv_testbed_term <- function(x, ...) {
  info <- term_states()
  info <- info[info$state == x$state, ]
  cat(sprintf("<wv_testbed_term> s_term * f(%s) [%s]: %s (%s)\n", x$state, info$unit, info$enters,
              info$bed))
  cat(sprintf("  f tabulated on %d points over [%s, %s], linear beyond\n", x$n_table,
              format(x$range[1], digits = 6), format(x$range[2], digits = 6)))
  invisible(x)
}

# The states a term can be a function of: the test bed, the simulator's
# index of the state (TermState in suspension.h, dosing.h), its unit, where
# the term enters, and the default range of the table.
term_states <- function() {
  strut <- "a force (kN) added to the strut force"
  elim <- "an extra elimination (mg/h) from the central compartment"
  data.frame(
    state = c("compression", "velocity", "damper", "tire",
              "concentration", "gut", "central", "peripheral", "bile", "induction",
              "temperature"),
    bed = rep(c("suspension", "dosing", "units"), c(4, 6, 1)),
    index = c(0:3, 0:5, 0L),
    unit = c("m", "m/s", "kN", "kN", "mg/L", "mg", "mg", "mg", "mg", "dimensionless", "K"),
    enters = c(strut, strut, "a velocity (m/s) added to the damper's velocity law",
               "a force (kN) added to the tire force", rep(elim, 6),
               "a heat loss (W) of the specimen"),
    lower = c(-0.25, -14, -32, -70, -5, -100, -150, -150, -200, -0.1, 150),
    upper = c(0.25, 14, 32, 90, 75, 1300, 2200, 2300, 2900, 1.5, 650),
    stringsAsFactors = FALSE
  )
}

# The term of a user's call against the design: checks `term` and the
# column `s_term`; returns the term as the simulator takes it (NULL without
# a term) and the design without `s_term`.
spec_check_term <- function(spec, design, term, call = rlang::caller_env()) {
  if (is.matrix(design) && !is.null(colnames(design))) design <- as.data.frame(design)
  has_col <- is.data.frame(design) && "s_term" %in% names(design)
  if (is.null(term)) {
    if (has_col) {
      wv_abort(c("{.arg design} has the strength column {.val s_term} but no {.arg term} is given.",
                 "i" = "Describe the term with {.fn testbed_term} and pass it as {.arg term}."),
               class = c("term", "input"), call = call)
    }
    return(list(design = design, term = NULL))
  }
  if (!inherits(term, "wv_testbed_term")) {
    wv_abort("{.arg term} must be {.code NULL} or made by {.fn testbed_term}, not {.obj_type_friendly {term}}.",
             class = c("term", "input"), call = call)
  }
  states <- term_states()
  states <- states[states$bed == spec$name, ]
  if (!term$state %in% states$state) {
    wv_abort(c("The {spec$text$model} has no state {.val {term$state}} for a term.",
               "i" = "Its states are {.val {states$state}}."),
             class = c("term", "input"), call = call)
  }
  if (!has_col) {
    wv_abort(c("A {.arg term} needs its strength column {.val s_term} in {.arg design}.",
               "i" = "E.g. {.code design$s_term <- 1}."),
             class = c("term", "input"), call = call)
  }
  s <- design$s_term
  if (!is.numeric(s) || any(!is.finite(s))) {
    wv_abort("The strength column {.val s_term} must hold finite numbers.",
             class = c("term", "input"), call = call)
  }
  design$s_term <- NULL
  list(design = design,
       term = list(state = states$index[states$state == term$state], range = term$range,
                   table = term$y,
                   strength = as.numeric(s)))
}

# The value of a tabulated term at `x`: linear between the `table`'s points,
# equally spaced over `range`, and linear beyond the ends from the two end
# points (as the compiled simulators read a term's table).
term_table_value <- function(x, range, table) {
  n <- length(table)
  pos <- (x - range[1]) / ((range[2] - range[1]) / (n - 1L))
  i <- pmin(pmax(floor(pos), 0), n - 2L)
  w <- pos - i
  table[i + 1L] * (1 - w) + table[i + 2L] * w
}
