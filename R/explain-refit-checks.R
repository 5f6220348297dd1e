# The checks of re-validated models given to explain_bias() as candidates,
# and the inputs each adds to `fit`'s: the mechanism's, each with its
# no-effect value (NA for a rate, which acts only while the others are on).

# For each candidate, a list: `added` (its inputs beyond `fit`'s), `off` (the
# no-effect value of each, NA for a rate) and `strength` (the added inputs
# with a no-effect value: the mechanism is off when all are at it). Checks
# that each was calibrated on the same field data and basis.
refit_strengths <- function(fit, refits, call = rlang::caller_env()) {
  nm <- names(refits)
  if (is.null(nm) || anyNA(nm) || any(!nzchar(nm)) || anyDuplicated(nm)) {
    wv_abort("{.arg candidates} must be a list with a unique name for every candidate.",
             call = call)
  }
  sites <- fit_sites(fit)
  fit_basis <- fit_get(fit, "basis")
  out <- lapply(nm, function(k) {
    rf <- refits[[k]]
    if (!setequal(fit_sites(rf), sites)) {
      wv_abort(c("Candidate {.val {k}} has sites {.val {fit_sites(rf)}}; {.arg fit} has {.val {sites}}.",
                 "i" = "Calibrate each candidate model on the field data of {.arg fit}."),
               call = call)
    }
    basis <- fit_get(rf, "basis")
    same_basis <- identical(basis$index, fit_basis$index) &&
      identical(dim(basis$Psi), dim(fit_basis$Psi)) &&
      isTRUE(all.equal(basis$Psi, fit_basis$Psi, tolerance = 1e-10))
    if (!same_basis) {
      wv_abort(c("Candidate {.val {k}} was not fitted on the wavelet basis of {.arg fit}.",
                 "i" = "Fit its emulators with {.code fit_emulators(runs, fit$basis)}."),
               call = call)
    }
    same_field <- all(vapply(sites, function(s) {
      isTRUE(all.equal(fit_get(rf, "wbar")[[s]], fit_get(fit, "wbar")[[s]], tolerance = 1e-8)) &&
        identical(fit_get(rf, "n_rep")[[s]], fit_get(fit, "n_rep")[[s]])
    }, logical(1)))
    if (!same_field) {
      wv_abort(c("Candidate {.val {k}} was not calibrated on the field data of {.arg fit}.",
                 "i" = "Use the same registered field data ({.code fit$field}) for every candidate."), call = call)
    }
    added_inputs(fit, rf, k, call)
  })
  stats::setNames(out, nm)
}

# The inputs candidate `rf` (named k) adds to those of `fit`, all calibration
# inputs, with their no-effect values: the attribute `off` of its I/U map
# ([iu_add()]), or for a single added input without one its lower bound.
added_inputs <- function(fit, rf, k, call) {
  extra <- setdiff(fit_get(rf, "inputs"), fit_get(fit, "inputs"))
  lacks <- setdiff(fit_get(fit, "inputs"), fit_get(rf, "inputs"))
  if (!length(extra) || length(lacks)) {
    wv_abort(c("Candidate {.val {k}} must have the inputs of {.arg fit} and one more at least, the mechanism's.",
               "x" = "Its inputs beyond those of {.arg fit}: {.val {if (length(extra)) extra else 'none'}}.",
               "x" = if (length(lacks)) "It lacks {.val {lacks}}."), call = call)
  }
  prior_iu <- fit_get(rf, "prior_iu")
  p <- prior_iu[match(extra, prior_iu$name), ]
  if (any(p$type != "calibration")) {
    bad <- extra[p$type != "calibration"]
    wv_abort(c("Every input candidate {.val {k}} adds must be a calibration input; not so for {.val {bad}}.",
               "i" = "Give each a range (the strength's holding its no-effect value) with {.fn iu_add}."),
             call = call)
  }
  given <- attr(fit_get(rf, "iu"), "off")
  if (length(extra) == 1L && !extra %in% names(given)) given <- stats::setNames(p$lower, extra)
  unknown <- setdiff(extra, names(given))
  if (length(unknown)) {
    wv_abort(c("Candidate {.val {k}} adds {.val {extra}}: give the no-effect value of each.",
               "x" = "None is given for {.val {unknown}}.",
               "i" = paste("Give them with {.code iu_add(..., off = )}: the value that switches the mechanism off,",
                           "{.code NA} for a rate that acts only while the others are on.")),
             call = call)
  }
  off <- given[extra]
  strength <- extra[!is.na(off)]
  if (!length(strength) || length(strength) > 2L) {
    wv_abort(c("Candidate {.val {k}} needs one or two added inputs with a no-effect value; it has {length(strength)}.",
               "i" = "The mechanism is off when they are at it; the others (rates) act only while it is on."),
             call = call)
  }
  q <- p[match(strength, p$name), ]
  if (any(off[strength] < q$lower | off[strength] > q$upper)) {
    wv_abort("The no-effect value of {.val {strength}} of candidate {.val {k}} lies outside its range.",
             call = call)
  }
  if (any(q$prior == "joint")) {
    wv_abort("The strength {.val {strength}} of candidate {.val {k}} must not be under a joint prior.",
             call = call)
  }
  list(added = extra, off = off, strength = strength)
}
