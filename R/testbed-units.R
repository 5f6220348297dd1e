#' Synthetic cooling test bed, of units
#'
#' A third validation problem, of other physics than [testbed_suspension()]
#' and [testbed_dosing()]: metal specimens taken out of an oven cool in still
#' air. The output is the specimen's temperature (K, site `"site1"`) on 256
#' points `t = 600 * (0:255) / 256` seconds. The model is Newton cooling with
#' radiation (R, fixed-step RK4); see [simulate_units()] for its equation and
#' inputs.
#'
#' The four inputs are coded on \[0, 1\]: `u1`, `u2` (calibration: the
#' heat-transfer coefficient and the surface's emissivity) and `x1`, `x2`
#' (specimen-to-specimen variation: the initial temperature and the mass).
#'
#' Unlike the other test beds, the field replicates are **units**: `n_units`
#' specimens, each with its own variation inputs drawn from the prior of the
#' I/U map around the nominal (truncated normal, standard deviation 0.12 in
#' coded units: 12 K of initial temperature and 5 % of mass), all
#' sharing the true calibration inputs `u*` (uniform on the calibration
#' ranges), each tested `n_rep` times. A test is the unit's noise-free curve
#' (the simulator at `u*` and the unit's inputs with the `hidden` mechanisms
#' at full strength) plus AR(1) thermocouple noise (standard deviation
#' 0.2 K, lag-one correlation 0.6 per grid step). There are no time warps
#' and no event windows: cooling has no events, and the field is used
#' unregistered (`validate()` without `windows`). The spread between units is
#' that of the initial temperatures at first (about 12 K) and shrinks as every
#' specimen approaches the ambient 295 K: the standard deviation over the six
#' units' curves at the last point is 9 to 1100 times smaller than at the
#' first (median 100; more than tenfold for 39 of seeds 1 to 40).
#'
#' The returned list has the layout of [testbed_dosing()]:
#' * `iu`: the I/U map (a `wv_iu`).
#' * `A$runs`: 60 model runs ([design_maximin()] on the I/U ranges, 59
#'   points plus the nominal centre, last); `A$field`: `n_units * n_rep`
#'   tests, their units declared (`A$field$units$site1`, units `"A1"`,
#'   `"A2"`, ..., each repeated `n_rep` times in a row).
#' * `B$runs`: 40 model runs of specimens from a hotter oven, heavier
#'   (nominals `x_nom_B`; a maximin design on the I/U ranges shifted to the
#'   new nominals); `B$field`: `n_units` new specimens (units `"B1"`, ...)
#'   drawn around `x_nom_B`, tested `n_rep` times each, same `u*` and hidden
#'   mechanisms; `B$x_nom`.
#' * `truth`: `u` (named vector); `units_delta` and `units_delta_B`
#'   (matrices, one row per unit, named by unit, one column per variation
#'   input: each unit's offset from the nominal); `delta` and `delta_B`, the
#'   population's offsets, taken as the mean unit (the column means of
#'   `units_delta`, `units_delta_B`); `x_nom_B`; `reality` and `reality_B`
#'   (named lists by site of the noise-free curve of the mean unit:
#'   the simulator at `u*` and `x_nom + delta` with the hidden mechanisms;
#'   not the mean of the units' curves, which differs from it a little as
#'   the model is not linear); `reality_units` and `reality_units_B` (named
#'   lists by site of matrices, one noise-free curve per unit, rows named by
#'   unit); `warps` (`NULL`: none); `hidden`; `seed`.
#' * `windows`: `NULL` (no events).
#'
#' The result depends only on `seed` (and `n_units`, `n_rep`); the caller's
#' random number stream is left as it was.
#'
#' @inheritParams testbed_suspension
#' @param hidden `"none"` or one or several of `units_mechanisms()`: what
#'   reality has and the model lacks.
#' @param n_units Number of specimens (units) of each condition, at least 2.
#' @param n_rep Number of tests of each specimen, at least 1.
#' @return A `wv_testbed_units` object, also of class `wv_testbed` (a list,
#'   layout above).
#' @seealso [simulate_units()] to run the model at other inputs,
#'   [units_signatures()] for the mechanisms' effects.
#' @export
#' @examples
#' tb <- testbed_units(seed = 1, hidden = "ambient_drift")
#' tb
#' table(tb$A$field$units$site1)
#' # the spread between units, early and late
#' s <- apply(tb$truth$reality_units$site1, 2, sd)
#' s[c(1, 256)]
#' autoplot(tb)
testbed_units <- function(seed = 1, hidden = "none", n_units = 6, n_rep = 4) {
  check_number(seed, "seed", integer = TRUE)
  check_number(n_units, "n_units", min = 2, max = 1000, integer = TRUE)
  check_number(n_rep, "n_rep", min = 1, max = 1000, integer = TRUE)
  spec <- units_spec(as.integer(n_units), as.integer(n_rep))
  hidden <- spec_check_hidden(spec, hidden)
  with_rng_seed(seed, build_testbed_from_spec(spec, seed, hidden))
}

#' Names of the mechanisms the cooling model can lack
#'
#' * `"ambient_drift"`: the room warms while the specimens cool, the ambient
#'   temperature rising linearly by 4 K over the 600 s record: the late record
#'   is warmer.
#' * `"natural_convection"`: the heat-transfer coefficient of still air falls
#'   with the temperature difference, `h (1 + 0.4 ((dT / 150)^0.25 - 1))` at
#'   `dT = T - T_amb` K instead of `h`: cooling slows as the specimen
#'   approaches the ambient (the middle and late record warmer).
#' * `"surface_oxidation"`: the surface oxidises as it cools, its emissivity
#'   growing as `eps (1 + 1.5 (1 - exp(-t / 200)))`, up to 2.5 times its initial
#'   value: more radiation in the middle of the record (cooler). Mostly a
#'   faster cooling, which the calibration inputs largely absorb: at seed 1
#'   the posterior mean of `u1` moves from 0.34 (nothing hidden) to 0.42 and a
#'   default [validate()] flags nothing at seeds 1 to 3
#'   (`studies/testbed_units.R`).
#'
#' At full strength each changes the curve by 2 to 4 K (of a range of about
#' 150 K), smoothly. In [simulate_units()] each is switched on by naming it
#' in `mechanism`; its strength is the design column `s_<name>` in \[0, 2\],
#' 1 being reality's strength.
#' @return A character vector.
#' @export
#' @examples
#' units_mechanisms()
units_mechanisms <- function() c("ambient_drift", "natural_convection", "surface_oxidation")

#' Run the cooling model at chosen inputs
#'
#' Simulates a specimen of [testbed_units()] for every row of a design in the
#' coded units of the I/U map. The specimen's temperature `T` (K) follows
#'
#' `m c dT/dt = -h A (T - T_a) - eps sigma A (T^4 - T_a^4) - s_term f(T)`
#'
#' from `T(0) = T0`, with heat capacity `c` = 900 J/(kg K) (aluminium),
#' surface area `A` = 0.02 m^2, ambient `T_a` = 295 K and `sigma` the
#' Stefan-Boltzmann constant; the mechanisms of [units_mechanisms()] change
#' `T_a`, `h` and `eps` as described there (at strength 0 the model is the
#' equation above). It is solved by fixed-step RK4, two steps per grid
#' interval, vectorised over the runs. A coded value `c` maps to the
#' physical value `p0 * (1 + g * (c - 0.5))`, the initial temperature to
#' `450 + 100 (c - 0.5)` K:
#'
#' | input | parameter | `p0` | `g` |
#' | --- | --- | --- | --- |
#' | `u1` | heat-transfer coefficient `h` | 25 W/(m^2 K) | 1.2 |
#' | `u2` | emissivity `eps` | 0.5 | 1.2 |
#' | `x1` | initial temperature `T0` | 450 K | (above) |
#' | `x2` | mass `m` | 0.06 kg | 0.4 |
#'
#' @param design A data frame (or named matrix) of coded inputs, one row per
#'   run. Inputs it lacks take their value from `nominal`.
#' @param mechanism `NULL` or names from [units_mechanisms()] to switch on;
#'   each needs a strength column `s_<name>` in `design`, with values in
#'   \[0, 2\] (1 = reality's strength).
#' @param nominal Named values for inputs missing from `design` (default 0.5
#'   for every input).
#' @param states `TRUE` to return the state histories of the runs too (see
#'   Value).
#' @param term `NULL` or an added term made by [testbed_term()] of the state
#'   `"temperature"`: an extra heat loss `s_term f(T)` W (the equation's last
#'   term), its strength the design column `s_term` (any finite number). It
#'   may be on together with `mechanism`.
#' @return A `wv_runs` object with the site `site1` on the 256-point grid;
#'   its design holds the columns of `design`.
#'
#'   With `states = TRUE` it has the attribute `"states"`, a named list of
#'   matrices (one row per run, on the curves' grid): `temperature` (`T`, K,
#'   the same numbers as the curves), `ambient` (`T_a`, K), `convection` and
#'   `radiation` (the heat flows `h A (T - T_a)` and
#'   `eps sigma A (T^4 - T_a^4)`, W, the mechanisms' changes included).
#' @export
#' @examples
#' runs <- simulate_units(data.frame(u1 = c(0.3, 0.7), x1 = 0.5))
#' runs
#' drift <- simulate_units(data.frame(s_ambient_drift = c(0, 1)), mechanism = "ambient_drift")
#' autoplot(drift)
#' # an added term: a conduction loss of 0.02 W/K to the 295 K stand
#' stand <- testbed_term("temperature", function(T) 0.02 * (T - 295))
#' runs <- simulate_units(data.frame(s_term = c(0, 1)), term = stand, states = TRUE)
#' range(runs$curves$site1[2, ] - runs$curves$site1[1, ])
simulate_units <- function(design, mechanism = NULL, nominal = NULL, states = FALSE, term = NULL) {
  spec_simulate(units_spec(), design, mechanism, nominal, states = states, term = term)
}

#' Signatures of the cooling mechanisms
#'
#' The change of the specimen's temperature when a mechanism is switched on
#' at full strength in the model, at given inputs: the candidate curves that
#' [explain_bias()] takes.
#'
#' @param inputs Named coded values of the model's inputs (e.g. the posterior
#'   means of a fit); inputs not given take their nominal 0.5.
#' @param mechanisms Names from [units_mechanisms()].
#' @return A named list (one element per mechanism) of lists with one curve,
#'   `site1`, on the test bed's grid.
#' @export
#' @examples
#' sig <- units_signatures(c(u1 = 0.5, u2 = 0.5), "ambient_drift")
#' range(sig$ambient_drift$site1)
units_signatures <- function(inputs, mechanisms = units_mechanisms()) {
  spec_signatures(units_spec(), inputs, mechanisms)
}

# --- specification ---------------------------------------------------------------

# The cooling test bed: `n_units` specimens per condition, each tested
# `n_rep` times.
units_spec <- function(n_units = 6L, n_rep = 4L) {
  new_testbed_spec(
    name = "units", iu = units_iu(),
    mechanisms = units_mechanisms(), mechanisms_fn = "units_mechanisms",
    physical = units_physical, simulator = units_simulate,
    grid = 600 * (0:255) / 256, windows = NULL,
    designs = units_designs,
    # condition B: specimens from a hotter oven, heavier
    nominal_B = c(x1 = 0.7, x2 = 0.65),
    n_field = c(A = n_units * n_rep, B = n_units * n_rep),
    warp = NULL,
    noise = c(sd = 0.2, phi = 0.6),
    units = c(n_units = n_units, n_rep = n_rep),
    text = list(model = "cooling model", title = "Cooling test bed (units)",
                header = "<wv_testbed_units> cooling test bed", span = "[0, 600) s",
                B = "new specimens from a hotter oven", windows = "event windows",
                range = "Temperature range of the model runs of A (K):")
  )
}

units_iu <- function() {
  iu_map(
    name = c("u1", "u2", "x1", "x2"),
    type = rep(c("calibration", "variation"), c(2, 2)),
    lower = c(0.125, 0.125, 0.2, 0.2),
    upper = c(0.875, 0.875, 0.8, 0.8),
    nominal = rep(0.5, 4),
    prior_sd = c(NA, NA, 0.12, 0.12)
  )
}

# A: design_maximin() on the I/U ranges (59 points and the nominal centre);
# B: 40 points on the ranges moved to B's nominals.
units_designs <- function(iu, nom_B, seed) maximin_designs(iu, nom_B, seed, 60L, 40L)

# Physical parameters of coded inputs: h (W/m^2/K), eps, T0 (K), m (kg).
units_physical <- function(coded) {
  f <- function(v, g) 1 + g * (v - 0.5)
  cbind(h = 25 * f(coded[, "u1"], 1.2), eps = 0.5 * f(coded[, "u2"], 1.2),
        T0 = 450 + 100 * (coded[, "x1"] - 0.5), m = 0.06 * f(coded[, "x2"], 0.4))
}

# The cooling model (simulate_units()) for K runs: params K x 4, strength
# K x 3 (the order of units_mechanisms()), fixed-step RK4 with `nsub` steps
# per grid interval. Returns list(site1 = K x T) with, when `states`, the
# attribute "states".
units_simulate <- function(params, strength, t, term = NULL, states = FALSE, nsub = 2L) {
  k_runs <- nrow(params)
  area <- 0.02
  cap <- params[, "m"] * 900
  ta0 <- 295
  sb <- 5.670374e-8
  s_drift <- strength[, 1L]
  s_conv <- strength[, 2L]
  s_ox <- strength[, 3L]
  ambient <- function(tt) ta0 + s_drift * 4 * tt / 600
  flows <- function(tt, temp) {
    ta <- ambient(tt)
    h <- params[, "h"] * (1 + s_conv * 0.4 * ((pmax(temp - ta, 0) / 150)^0.25 - 1))
    eps <- params[, "eps"] * (1 + s_ox * 1.5 * (1 - exp(-tt / 200)))
    list(convection = h * area * (temp - ta), radiation = eps * sb * area * (temp^4 - ta^4))
  }
  rate <- function(tt, temp) {
    q <- flows(tt, temp)
    loss <- q$convection + q$radiation
    if (!is.null(term)) {
      loss <- loss + term$strength * term_table_value(temp, term$range, term$table)
    }
    -loss / cap
  }
  temp <- params[, "T0"]
  out <- matrix(NA_real_, k_runs, length(t))
  out[, 1L] <- temp
  for (i in seq_len(length(t) - 1L)) {
    dt <- (t[i + 1L] - t[i]) / nsub
    for (k in seq_len(nsub)) {
      tt <- t[i] + (k - 1L) * dt
      k1 <- rate(tt, temp)
      k2 <- rate(tt + dt / 2, temp + dt / 2 * k1)
      k3 <- rate(tt + dt / 2, temp + dt / 2 * k2)
      k4 <- rate(tt + dt, temp + dt * k3)
      temp <- temp + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    }
    out[, i + 1L] <- temp
  }
  out[!apply(is.finite(out), 1L, all), ] <- NA_real_
  res <- list(site1 = out)
  if (states) {
    tt <- matrix(t, k_runs, length(t), byrow = TRUE)
    q <- lapply(seq_along(t), function(i) flows(t[i], out[, i]))
    by_time <- function(name) matrix(vapply(q, `[[`, numeric(k_runs), name), k_runs)
    attr(res, "states") <- list(temperature = out, ambient = ta0 + s_drift * 4 * tt / 600,
                                convection = by_time("convection"),
                                radiation = by_time("radiation"))
  }
  res
}
