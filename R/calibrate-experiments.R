# --- the experiments in the sampler and in the fit ----------------------------

# Adds the experiments' sites to the base experiment's sampler spec. Site `s`
# of experiment `e` becomes site "e/s"; its coefficients' bias variances are
# the base site's groups (level_variances "shared", needs the base experiment
# to hold the site) or its own ("per_experiment").
add_experiments <- function(spec, experiments, emulators, iu, pool_levels, registration_variance,
                            level_variances, experiment_bias = "own", call = rlang::caller_env()) {
  base_sites <- names(spec$sites)
  p <- length(spec$inputs)
  site_experiment <- stats::setNames(rep("base", length(base_sites)), base_sites)
  base_site <- stats::setNames(base_sites, base_sites)
  shift <- list()
  banks <- list()
  # the registration's own error: measured on each experiment's field when
  # it carries a check, else the base experiment's at the same site (the
  # same registration of the same kind of curve)
  measured <- isTRUE(registration_variance %in% c("auto", "check"))
  if (measured && !is.null(spec$reg_shift_var) && experiment_bias == "shared") {
    # the sampler's shifts need each site's own bias: one variance per site
    spec$extra <- plus_fill(spec$extra_diag, spec$fill)
    for (s in base_sites) {
      spec$sites[[s]]$reg_U <- NULL
      spec$sites[[s]]$extra <- spec$extra[[s]]
    }
    spec$reg_shift_var <- NULL
  }
  for (e in names(experiments)) {
    x <- experiments[[e]]
    em <- x$emulators %||% emulators
    sub <- calibration_spec(em, x$field, iu, NULL, pool_levels = pool_levels,
                            registration_variance = if (measured) "diagonal" else
                              registration_variance, call = call)
    if (measured && is.null(sub$reg_extra) && !is.null(spec$reg_extra)) {
      sub$extra <- plus_fill((spec$extra_diag %||% spec$reg_extra)[names(sub$sites)], sub$fill)
    }
    sh <- stats::setNames(numeric(p), spec$inputs)
    if (!is.null(x$change)) sh[names(x$change)] <- x$change
    for (s in names(sub$sites)) {
      name <- paste0(e, "/", s)
      d <- sub$sites[[s]]
      d$extra <- sub$extra[[s]]
      lab <- sub$bias_group[[s]]
      if (level_variances == "shared") {
        if (!s %in% base_sites) {
          wv_abort(c("With {.code level_variances = \"shared\"} every experiment's site must be a site of the base experiment.",
                     "x" = "Experiment {.val {e}} has site {.val {s}}; the base has {.val {base_sites}}.",
                     "i" = "Use {.code level_variances = \"per_experiment\"}."),
                   class = "experiment", call = call)
        }
        d$group <- match(lab, spec$groups$name) - 1L
        if (anyNA(d$group)) {
          # a level the base site pooled (its curves reach no data there):
          # the base group of the nearest level
          base_g <- which(spec$groups$site == s)
          lv <- sub$groups$level[match(lab, sub$groups$name)]
          for (i in which(is.na(d$group))) {
            dd <- abs(spec$groups$level[base_g] - lv[i])
            d$group[i] <- base_g[which(dd == min(dd))[1]] - 1L
          }
          lab <- spec$groups$name[d$group + 1L]
        }
      } else {
        own <- sub$groups[sub$groups$site == s, , drop = FALSE]
        own$name <- paste0(e, "/", own$name)
        own$site <- name
        spec$groups <- rbind(spec$groups, own)
        lab <- paste0(e, "/", lab)
        d$group <- match(lab, spec$groups$name) - 1L
      }
      if (any(sh != 0)) d$shift <- unname(sh)
      if (experiment_bias == "shared") d$bias_of <- match(s, base_sites) - 1L
      spec$sites[[name]] <- d
      spec$bias_group[[name]] <- lab
      spec$wbar[[name]] <- sub$wbar[[s]]
      spec$s2[[name]] <- sub$s2[[s]]
      spec$n_rep[[name]] <- sub$n_rep[[s]]
      if (!is.null(sub$extra)) spec$extra[[name]] <- sub$extra[[s]]
      if (!is.null(sub$fill[[s]])) spec$fill[[name]] <- sub$fill[[s]]
      spec$noise_setting[[name]] <- sub$noise_setting[[s]]
      if (!is.null(sub$noise_evidence[[s]])) spec$noise_evidence[[name]] <- sub$noise_evidence[[s]]
      if (!is.null(sub$noise_prior) && !is.null(sub$noise_prior$scale[s]) &&
          !is.na(sub$noise_prior$scale[s])) {
        if (is.null(spec$noise_prior)) {
          spec$noise_prior <- sub$noise_prior
          spec$noise_prior$scale <- numeric(0)
        }
        spec$noise_prior$scale <- c(spec$noise_prior$scale,
                                    stats::setNames(unname(sub$noise_prior$scale[s]), name))
      }
      site_experiment[[name]] <- e
      base_site[[name]] <- s
      shift[[name]] <- sh
      banks[[name]] <- site_bank(em, s)
    }
  }
  spec$experiments <- data.frame(site = names(site_experiment),
                                 experiment = unname(site_experiment),
                                 field_site = unname(base_site), stringsAsFactors = FALSE)
  spec$shift <- shift
  spec$experiment_banks <- banks
  spec
}

# The fit's emulators with a bank for every experiment's site, and its field
# with every site's curves.
experiment_fit_parts <- function(spec, emulators, field, experiments) {
  if (is.null(spec$experiments)) return(list(emulators = emulators, field = field))
  for (s in names(spec$experiment_banks)) {
    e <- spec$experiments$experiment[spec$experiments$site == s]
    fs <- spec$experiments$field_site[spec$experiments$site == s]
    em <- experiments[[e]]$emulators %||% emulators
    emulators <- emulators_add_site(emulators, s, spec$experiment_banks[[s]],
                                    em$params[em$params$site == fs, , drop = FALSE])
    field$curves[[s]] <- experiments[[e]]$field$curves[[fs]]
    if (!is.null(experiments[[e]]$field$observed[[fs]])) {
      field$observed[[s]] <- experiments[[e]]$field$observed[[fs]]
    }
    if (!is.null(experiments[[e]]$field$units)) {
      field$units[[s]] <- experiments[[e]]$field$units[[fs]]
    }
  }
  list(emulators = emulators, field = field)
}

# The change of the inputs at which site s's emulators are evaluated (zeros
# for the base experiment's sites), named by input.
site_shift <- function(fit, s) {
  sh <- fit_get(fit, "shift")[[s]]
  if (is.null(sh)) sh <- stats::setNames(numeric(length(fit_get(fit, "inputs"))),
                                         fit_get(fit, "inputs"))
  sh
}

# Share of draws whose inputs, moved by an experiment's change, leave the
# range of the emulators' runs: a classed warning when above 1%.
warn_experiment_extrapolation <- function(fit) {
  if (is.null(fit_get(fit, "shift"))) return(invisible())
  X <- fit_draws_matrix(fit)[, fit_get(fit, "inputs"), drop = FALSE]
  for (s in names(fit_get(fit, "shift"))) {
    sh <- fit_get(fit, "shift")[[s]]
    if (all(sh == 0)) next
    moved <- names(sh)[sh != 0]
    rng <- apply(fit_get(fit, "emulators")$design[, moved, drop = FALSE], 2L, range)
    Z <- sweep(X[, moved, drop = FALSE], 2L, sh[moved], `+`)
    out <- rowSums(sweep(Z, 2L, rng[1L, ] - 1e-12, `<`) | sweep(Z, 2L, rng[2L, ] + 1e-12, `>`)) > 0
    if (mean(out) > 0.01) {
      wv_warn(c("At site {.val {s}}, {round(100 * mean(out))}% of the draws' changed inputs leave the range of the model runs.",
                "i" = "The emulators extrapolate there; give the experiment its own runs ({.code experiment(field, emulators = )})."),
              class = "extrapolation")
    }
  }
  invisible()
}


# Registration variances by site plus the variance of curves missing beyond
# their own extent (calibration_spec()'s `fill`), NULL when both are.
plus_fill <- function(reg, fill) {
  sites <- union(names(reg), names(fill))
  if (!length(sites)) return(NULL)
  out <- lapply(stats::setNames(sites, sites), function(s) {
    if (is.null(reg[[s]]) && is.null(fill[[s]])) NULL else (reg[[s]] %||% 0) + (fill[[s]] %||% 0)
  })
  out[!vapply(out, is.null, logical(1))]
}
