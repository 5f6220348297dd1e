# The calibration fit (class wv_fit): constructor, validator and accessors
# read by the bands, the diagnostics, predictions and explanations.

new_wv_fit <- function(x) structure(x, class = "wv_fit")

validate_wv_fit <- function(x, call = rlang::caller_env()) {
  need <- c("draws", "wM", "wb", "sigma2", "chain", "basis", "field", "iu", "inputs")
  miss <- setdiff(need, names(x))
  if (length(miss)) wv_abort("A {.cls wv_fit} needs {.field {miss}}.", class = "state", call = call)
  H <- length(x$chain)
  for (s in names(x$wb)) {
    if (nrow(x$wb[[s]]) != H || nrow(x$wM[[s]]) != H || ncol(x$wb[[s]]) != ncol(x$basis$Psi)) {
      wv_abort("Site {.val {s}}: coefficient draws do not match the chains and the basis.",
               class = "state", call = call)
    }
  }
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
  sweep(fit$sigma2[[s]][rows, , drop = FALSE] / fit$n_rep[[s]], 2L, fit$registration_var[[s]] %||% 0, `+`)
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
  fit$pipeline %||% (if (!is.null(fit$call_args)) fit$call_args[c("runs", "field", "experiments", "registered_to")])
}
