# The emulator banks behind one door: every other file reads a fit's
# emulators through these functions.

# --- the door to the emulator banks ---------------------------------------------
# A bank holds one site's emulators (see fit_emulators(), Value). Other modules
# take a bank from a `wv_emulators` object with site_bank(), hand it on (to
# the sampler, to the functions below) and never read its fields nor call the
# compiled emulator functions themselves.

# The sites a `wv_emulators` object emulates (character).
emulator_sites <- function(em) names(em$banks)

# The bank of site `s` of a `wv_emulators` object (NULL for a site it does
# not emulate).
site_bank <- function(em, s) em$banks[[s]]

# The emulators `em` with `bank` as the bank of site `s` and the rows
# `params` (columns as em$params; their `site` set to `s`) added to its
# parameters: how a fit's emulators gain a site per experiment.
emulators_add_site <- function(em, s, bank, params) {
  em$banks[[s]] <- bank
  params$site <- rep(s, nrow(params))
  em$params <- rbind(em$params, params[, names(em$params), drop = FALSE])
  em
}

# Predictions (report eq. 11) of every coefficient of `bank` at the points
# `Z` (N x p matrix, one row per point, the inputs in their own units and in
# the emulators' order). Returns a list of `mean` and `var`, N x n matrices
# (rows: points, columns: the bank's coefficients).
bank_predict <- function(bank, Z) gasp_bank_predict_cpp(bank, Z)

# Predictions with the design augmented draw by draw (report eq. 26): row h
# of the result is the prediction at Znew[h, ] of the bank augmented with the
# point Zstar[h, ] whose coefficients are Wstar[h, ], hyperparameters kept.
# Zstar and Znew are H x p (inputs in their own units), Wstar is H x n.
# Returns a list of `mean` and `var`, H x n matrices.
bank_predict_augmented <- function(bank, Zstar, Wstar, Znew) {
  gasp_bank_predict_augmented_cpp(bank, Zstar, Wstar, Znew)
}

# The design of `bank` scaled to the unit cube (K x p): two banks with the
# same design share their emulators' errors.
bank_design <- function(bank) bank$X

# Coefficient i's Cholesky factor in bank b (K x K): its own slice of `chol`,
# or the shared one `chol_of` points to.
bank_factor <- function(b, i) b$chol[, , if (is.null(b$chol_of)) i else b$chol_of[i]]

emulator_params <- function(site, basis, bank, converged, inputs) {
  n <- length(bank$mu)
  idx <- basis$index %||% seq_len(n)
  lev <- basis$level %||% rep(NA_integer_, n)
  out <- data.frame(site = rep(site, n), index = as.integer(idx), level = as.integer(lev),
                    mu = bank$mu, lambda = bank$lambda, nugget = bank$nugget, loglik = bank$loglik,
                    converged = converged, stringsAsFactors = FALSE)
  b <- bank$beta
  a <- bank$alpha
  colnames(b) <- paste0("beta_", inputs)
  colnames(a) <- paste0("alpha_", inputs)
  cbind(out, as.data.frame(b), as.data.frame(a))
}
