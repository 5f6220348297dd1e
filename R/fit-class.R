# The calibration fit (class wv_fit): constructor, validator and accessors
# read by the bands, the diagnostics, predictions and explanations.

# The fields of a fit, in their order: name, type (checked by
# validate_wv_fit(), see fit_field_ok()) and what each holds. A "site list"
# is named by the fit's sites, the field's sites then one "<experiment>/<site>"
# per site of each further experiment (the names of `wb`); H is the number of
# saved draws of all chains, n the number of basis coefficients. A field marked
# optional ("opt."; a type ending in "?" below) may be NULL; calibrate() sets
# every other.
#
# | field               | type               | holds
# |---------------------|--------------------|------------------------------------------------
# | draws               | mcmc.list          | one coda::mcmc per chain: the inputs (own units),
# |                     |                    | then tau2[<group>] for each row of `groups`
# | wM, wb, sigma2      | site matrices      | draws (H x n, columns "w<index>") of the model's
# |                     |                    | and the bias's coefficients and of the field
# |                     |                    | noise variances
# | chain               | integer (H)        | the chain of each row of wM, wb, sigma2
# | emulators           | wv_emulators       | the emulators, a bank for every site of the fit
# | basis               | wv_basis           | the wavelet basis
# | field               | wv_field           | the field data calibrated to (registered)
# | iu                  | wv_iu              | the I/U map given
# | prior_iu            | wv_iu              | the I/U map the sampler used (conditions held)
# | inputs              | character          | the inputs, in the emulators' order
# | x_nom               | named numeric      | the nominal inputs
# | wbar, s2            | site list (n)      | the field mean's coefficients and the
# |                     |                    | replicates' sums of squares about it
# | n_rep               | site list          | the number of field replicates
# | groups              | data frame         | the bias-variance groups: name, site, level
# | bias_group          | site list (n)      | the group of each coefficient
# | acceptance          | data frame         | acceptance rates, one row per chain
# | start               | matrix             | the chains' starting inputs (chains x inputs)
# | proposal_cov        | list               | each chain's proposal covariance of the inputs
# | seed                | integer            | the seed the draws came from
# | settings            | list               | the sampler's and the bias's settings as run
# | registration_var    | site list, opt.    | the registration's variance of each coefficient
# |                     |                    | (with missing_var's)
# | missing_var         | site list, opt.    | what curves missing beyond their own extent add
# | noise_setting       | named character    | how each site's noise is known ("replicates", ...)
# | noise_prior         | list, opt.         | the prior of the learned noise scales
# | noise_evidence      | site list, opt.    | the measured evidence on the noise
# | registration_shifts | list, opt.         | the registration's shifts drawn: `variance`,
# |                     |                    | `draws` (H rows), `U` (by site)
# | rhat, ess           | named numeric      | R-hat by input; effective sample size by column
# |                     |                    | of the draws
# | flags               | list               | inputs piled at a bound (`boundary`), unmixed
# | shared_errors       | list, opt.         | the inputs' likelihood weight for shared errors
# | sampling_seconds    | number, opt.       | the chains' wall time
# | stopping            | list, opt.         | the rounds of the stopping rule
# | prior_sd            | named numeric      | the prior standard deviation of each input
# | conditions          | list, opt.         | the test conditions: `inputs`, their `base`
# |                     |                    | values, `values` by experiment (data frame)
# | experiments         | data frame, opt.   | site, experiment and field_site of every site of
# |                     |                    | a further experiment
# | shift               | site list, opt.    | the change of the inputs at an experiment's site
# | control             | list, opt.         | the control objects by kind (`bias`, `sampler`,
# |                     |                    | and for validate() `registration`, `emulation`),
# |                     |                    | replayed by update()
# | pipeline            | list, opt.         | the data validate() was given: `runs`, `field`
# |                     |                    | and `experiments` as given, `registered_to`
# | call_args           | list, opt.         | a fit made before `control` and `pipeline`:
# |                     |                    | validate()'s arguments (fit_controls(),
# |                     |                    | fit_pipeline())
# | timing              | data frame, opt.   | validate()'s time by phase
# | held                | list, opt.         | the inputs held (hold_inputs(), the re-reading)
wv_fit_fields <- c(
  draws = "mcmc.list", wM = "site matrices", wb = "site matrices", sigma2 = "site matrices",
  chain = "integer", emulators = "wv_emulators", basis = "wv_basis", field = "wv_field",
  iu = "wv_iu", prior_iu = "wv_iu", inputs = "character", x_nom = "named numeric",
  wbar = "site list", s2 = "site list", n_rep = "site list", groups = "data frame",
  bias_group = "site list", acceptance = "data frame", start = "matrix", proposal_cov = "list",
  seed = "integer", settings = "list", registration_var = "site list?", missing_var = "site list?",
  noise_setting = "named character", noise_prior = "list?", noise_evidence = "site list?",
  registration_shifts = "list?", rhat = "named numeric", ess = "named numeric", flags = "list",
  shared_errors = "list?", sampling_seconds = "number?", stopping = "list?",
  prior_sd = "named numeric", conditions = "list?", experiments = "data frame?",
  shift = "site list?", control = "list?", pipeline = "list?", call_args = "list?",
  timing = "data frame?",
  held = "list?"
)

# A fit from its fields (a named list of some of wv_fit_fields): every
# declared field present, in the declared order, those not given NULL. A name
# that is not declared is an internal error. Cheap: no check (see
# validate_wv_fit()).
new_wv_fit <- function(x = list()) {
  check_fit_field_names(names(x))
  out <- stats::setNames(vector("list", length(wv_fit_fields)), names(wv_fit_fields))
  out[names(x)] <- x
  structure(out, class = "wv_fit")
}

# The one way to change fields of a fit outside its construction: `...` are
# named new values (NULL empties a field but keeps it); the fit is checked
# again.
fit_set <- function(fit, ..., call = rlang::caller_env()) {
  new <- list(...)
  check_fit_field_names(names(new))
  cls <- class(fit)
  fit <- unclass(fit)
  fit[names(new)] <- new
  class(fit) <- cls
  validate_wv_fit(fit, call = call)
}

# The one way other modules read a fit: the field `name` (one of
# wv_fit_fields; another name is an internal error). A declared field that a
# fit saved before it was declared lacks reads as NULL.
fit_get <- function(fit, name, call = rlang::caller_env()) {
  if (!is.character(name) || length(name) != 1L || !name %in% names(wv_fit_fields)) {
    wv_abort("{.field {name}} is not one field of a {.cls wv_fit}.", class = "internal",
             .internal = TRUE,
             call = call)
  }
  if (!inherits(fit, "wv_fit")) {
    wv_abort("{.arg fit} must be a {.cls wv_fit}, not {.obj_type_friendly {fit}}.",
             class = "internal",
             .internal = TRUE, call = call)
  }
  fit[[name]]
}

# The fit's sites: the field's, then those of its further experiments
# ("<experiment>/<site>"), in the order of its site lists.
fit_sites <- function(fit) names(fit_get(fit, "wb"))

# The draws of all chains in one matrix (H rows: the inputs, then the tau2).
fit_draws_matrix <- function(fit) as.matrix(fit_get(fit, "draws"))

check_fit_field_names <- function(nm, call = rlang::caller_env()) {
  if (length(nm) && (anyNA(nm) || any(!nzchar(nm)))) {
    wv_abort("Every field of a {.cls wv_fit} must be named.", class = "internal", .internal = TRUE,
             call = call)
  }
  unknown <- setdiff(nm, names(wv_fit_fields))
  if (length(unknown)) {
    wv_abort("{.field {unknown}} {?is not a field/are not fields} of a {.cls wv_fit}.",
             class = "internal", .internal = TRUE, call = call)
  }
  invisible(nm)
}

# Whether value v has the declared type `type` (see wv_fit_fields; a type
# ending in "?" is optional: NULL allowed).
fit_field_ok <- function(v, type) {
  if (endsWith(type, "?")) {
    if (is.null(v)) return(TRUE)
    type <- substr(type, 1L, nchar(type) - 1L)
  }
  named <- function(v) !is.null(names(v)) && !anyNA(names(v)) && all(nzchar(names(v)))
  switch(type,
         "mcmc.list" = inherits(v, "mcmc.list") && length(v) >= 1L,
         "site matrices" = is.list(v) && named(v) &&
           all(vapply(v, function(m) is.matrix(m) && is.numeric(m), TRUE)),
         "site list" = is.list(v) && (length(v) == 0L || named(v)),
         "integer" = is.numeric(v) && length(v) >= 1L && !anyNA(v) && all(v == round(v)),
         "character" = is.character(v) && !anyNA(v),
         "named numeric" = is.numeric(v) && (length(v) == 0L || named(v)),
         "named character" = is.character(v) && (length(v) == 0L || named(v)),
         "number" = is.numeric(v) && length(v) == 1L,
         "data frame" = is.data.frame(v),
         "matrix" = is.matrix(v),
         "list" = is.list(v),
         inherits(v, type))
}

# A fit's shape: exactly the declared fields, each of its type, and the
# draws, coefficients, chains, sites and inputs consistent with each other.
# Cheap (classes, lengths, names and dimensions); an error of class
# wavevalid_error_state otherwise.
validate_wv_fit <- function(x, call = rlang::caller_env()) {
  bad <- function(msg) {
    wv_abort(c("Not a valid {.cls wv_fit}.", "x" = msg), class = "state", call = call,
             .envir = parent.frame())
  }
  nm <- names(unclass(x))
  miss <- setdiff(names(wv_fit_fields), nm)
  extra <- setdiff(nm, names(wv_fit_fields))
  if (length(miss)) bad("It lacks the field{?s} {.field {miss}}.")
  if (length(extra)) bad("It has undeclared field{?s} {.field {extra}}.")
  if (!identical(nm, names(wv_fit_fields))) bad("Its fields are not in the declared order.")
  for (f in names(wv_fit_fields)) {
    type <- wv_fit_fields[[f]]
    want <- sub("[?]$", "", type)
    if (!fit_field_ok(x[[f]], type)) bad("Field {.field {f}} is not {.val {want}}.")
  }
  sites <- names(x$wb)
  H <- length(x$chain)
  n <- ncol(x$basis$Psi)
  for (f in c("wM", "sigma2", "wbar", "s2", "n_rep", "bias_group")) {
    if (!identical(names(x[[f]]), sites)) bad("The sites of {.field {f}} are not those of wb.")
  }
  cols <- paste0("w", x$basis$index)
  for (f in c("wM", "wb", "sigma2")) {
    for (s in sites) {
      m <- x[[f]][[s]]
      if (nrow(m) != H || ncol(m) != n || !identical(colnames(m), cols)) {
        bad("Site {.val {s}}: {.field {f}} is not {H} draws by the basis' {n} coefficients.")
      }
    }
  }
  for (s in sites) {
    if (length(x$wbar[[s]]) != n || length(x$s2[[s]]) != n || length(x$bias_group[[s]]) != n) {
      bad("Site {.val {s}}: the field summaries are not one value per basis coefficient.")
    }
  }
  if (!all(sites %in% emulator_sites(x$emulators))) bad("A site of the fit has no emulators.")
  if (!identical(x$inputs, x$emulators$inputs)) bad("The inputs are not those of the emulators.")
  chains <- length(x$draws)
  drawn <- c(x$inputs, paste0("tau2[", x$groups$name, "]"))
  for (k in seq_len(chains)) {
    d <- x$draws[[k]]
    if (!identical(colnames(d), drawn)) bad("Chain {k}'s draws are not the inputs and the tau2.")
  }
  if (sum(vapply(x$draws, nrow, 1L)) != H ||
      !identical(sort(unique(as.integer(x$chain))), seq_len(chains))) {
    bad("The draws' chains do not match {.field chain}.")
  }
  if (nrow(x$acceptance) != chains || nrow(x$start) != chains || length(x$proposal_cov) != chains ||
      !identical(colnames(x$start), x$inputs)) {
    bad("The acceptance rates, starting points and proposals are not one per chain.")
  }
  if (!identical(names(x$rhat), x$inputs) || !identical(names(x$ess), drawn)) {
    bad("The R-hat and effective sample sizes are not named by the draws' columns.")
  }
  if (!all(x$inputs %in% names(x$prior_sd))) bad("{.field prior_sd} lacks inputs.")
  if (!is.null(x$registration_shifts) && NROW(x$registration_shifts$draws) != H) {
    bad("The registration's shift draws are not {H} draws.")
  }
  ex <- x$experiments
  if (!is.null(ex) && (!all(c("site", "experiment", "field_site") %in% names(ex)) ||
                       !all(ex$site %in% sites))) {
    bad("{.field experiments} does not name sites of the fit.")
  }
  if (!all(names(x$shift) %in% sites)) bad("{.field shift} names sites the fit lacks.")
  x
}

# Posterior mean of the inputs (own units).
posterior_mean_inputs <- function(fit) {
  colMeans(as.matrix(fit$draws)[, fit$inputs, drop = FALSE])
}

# Variance of the field mean's wavelet coefficients at site `s` for the rows
# `rows` of the draws: sigma^2 / R plus the registration variance (rows x
# coefficients).
field_mean_variance <- function(fit, s, rows) {
  sweep(fit$sigma2[[s]][rows, , drop = FALSE] / fit$n_rep[[s]], 2L, fit$registration_var[[s]] %||%
        0, `+`)
}

# The field mean's coefficients at site `s` for the rows `rows` of the
# draws (rows x coefficients): moved by the registration's shifts drawn
# there when the fit samples them, else the same in every row.
field_mean_draws <- function(fit, s, rows) {
  rs <- fit$registration_shifts
  out <- matrix(fit$wbar[[s]], length(rows), length(fit$wbar[[s]]), byrow = TRUE)
  U <- rs$U[[s]]
  if (is.null(U)) return(out)
  out - tcrossprod(rs$draws[rows, , drop = FALSE], U)
}

# Names of the draws' columns holding the bias variance tau^2 of each
# coefficient's (site, level) group at site `s`.
tau2_columns <- function(fit, s) {
  paste0("tau2[", fit$bias_group[[s]] %||% paste0(s, ":", fit$basis$level), "]")
}

# The data validate() was given (`runs`, `field` and `experiments` as given,
# `registered_to`), or NULL for a fit of calibrate(); for a fit made before
# they were kept apart from the settings, read from its `call_args`.
fit_pipeline <- function(fit) {
  fit$pipeline %||%
    (if (!is.null(fit$call_args)) fit$call_args[c("runs", "field", "experiments", "registered_to")])
}
