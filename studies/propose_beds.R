# The test beds' simulators as propose_terms() takes them, shared by the
# proposal studies (propose_terms.R, propose_loop.R, propose_null_sources.R).

# The state histories of bed `bed` ("suspension" or "dosing") at the inputs
# `z` (a one-row data frame): the channels of term_library(states = ).
bed_states_at <- function(bed, z) {
  if (bed == "suspension") {
    st <- attr(simulate_suspension(z, states = TRUE), "states")
    lapply(c(compression = "compression", velocity = "velocity", damper = "damper", tire = "tire"),
           function(k) list(site1 = st[[paste0(k, "_front")]][1, ], site2 = st[[paste0(k, "_rear")]][1, ]))
  } else {
    st <- attr(simulate_dosing(z, states = TRUE), "states")
    lapply(st[c("concentration", "gut", "peripheral", "bile", "induction")], function(m) m[1, ])
  }
}

# propose_terms()' `simulate` hook at the inputs `z`: the output with the
# term `strength * fun(channel)` added through the equations (testbed_term()).
bed_simulator_at <- function(bed, z) {
  sim <- if (bed == "suspension") simulate_suspension else simulate_dosing
  function(channel, fun, strength) {
    z$s_term <- strength
    lapply(sim(z, term = testbed_term(channel, fun))$curves, function(m) m[1, ])
  }
}

# The same at the fit's calibrated inputs, coef(fit).
fit_inputs <- function(fit) as.data.frame(as.list(coef(fit)))
bed_states <- function(bed, fit) bed_states_at(bed, fit_inputs(fit))
bed_simulator <- function(bed, fit) bed_simulator_at(bed, fit_inputs(fit))
