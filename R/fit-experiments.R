# The experiments of a fit's sites: which site belongs to which experiment,
# the base experiment's sites, and the inputs moved by an experiment's change.

# The inputs Z (rows, own units) moved to site s's experiment.
shift_inputs <- function(fit, s, Z) {
  sh <- fit$shift[[s]]
  if (is.null(sh) || all(sh == 0)) return(Z)
  sweep(Z, 2L, sh[colnames(Z) %||% fit$inputs], `+`)
}

# The experiment of each site of a fit ("base" for all with one experiment).
fit_experiments <- function(fit) {
  sites <- names(fit$wb)
  fit$experiments %||%
    data.frame(site = sites, experiment = "base", field_site = sites, stringsAsFactors = FALSE)
}

# The sites of the base experiment (every site with one experiment).
base_sites <- function(fit) {
  ex <- fit_experiments(fit)
  ex$site[ex$experiment == "base"]
}
