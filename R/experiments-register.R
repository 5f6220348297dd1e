# --- registration of the experiments' field data -------------------------------

# The model runs whose mean the field data of experiment `x` are registered
# to: its own `reference` when given, else the model in its condition as the
# emulators predict it. With `change`: every run of `runs` (the base
# experiment's, to which `emulators` were fitted) with its retained wavelet
# coefficients replaced by the emulators' means at its inputs plus the change
# (with a condition: its condition inputs set to the experiment's values),
# so that the mean of these runs stands to the experiment as the mean of
# `runs` stands to the base experiment. With a condition, the part the basis
# leaves out is the mean of the runs nearest the condition
# (condition_neighbours()). Every run is kept, those the change
# moves outside the range of the design too (the emulators extrapolate
# there): on the suspension test bed, leaving them out or moving them to the
# edge of the range took the reference farther from the true runs with the
# change. The part of a run the basis does not retain (fine detail the
# change hardly alters, to which the warp knots between the events are
# fitted) is kept from the run itself. With `emulators` of its own: their
# means at their own design, plus the base runs' mean part outside the basis
# at the sites of `runs`.
experiment_reference <- function(x, emulators, runs) {
  if (!is.null(x$reference)) return(x$reference)
  sites <- names(x$field$curves)
  if (!is.null(x$change)) {
    design <- runs$design
    for (p in names(x$change)) design[[p]] <- design[[p]] + x$change[[p]]
    # a condition is known: every run at the experiment's value
    for (p in intersect(names(x$condition), names(design))) design[[p]] <- x$condition[[p]]
    near <- condition_neighbours(runs$design, x$condition)
    basis <- emulators$basis
    curves <- lapply(sites, function(s) {
      Y <- runs$curves[[s]]
      mean_s <- stats::predict(emulators, design, site = s)$mean
      if (is.null(near)) {
        # each run's own part outside the basis: the run moved by the change
        # of its retained coefficients (one pass back to the grid)
        return(Y + basis_curves(basis, mean_s - basis_coef(basis, Y)))
      }
      rest <- basis_remainder(basis, colMeans(Y[near, , drop = FALSE]))
      sweep(basis_curves(basis, mean_s), 2L, drop(rest), `+`)
    })
  } else {
    em <- x$emulators
    design <- as.data.frame(em$design)
    curves <- lapply(sites, function(s) {
      y <- basis_curves(em$basis, stats::predict(em, em$design, site = s)$mean)
      if (s %in% names(runs$curves)) {
        y <- sweep(y, 2L, drop(basis_remainder(em$basis, colMeans(runs$curves[[s]]))), `+`)
      }
      y
    })
  }
  validate_wv_runs(new_wv_runs(design, runs$t, stats::setNames(curves, sites)))
}

# The experiments (checked by check_experiments()) with their field data
# registered like the base experiment's (the arguments of register_curves()
# in `...`), each to experiment_reference(); says once which reference each
# one was registered to.
register_experiments <- function(experiments, emulators, runs, windows, ..., quiet = FALSE) {
  how <- character(0)
  refs <- list()
  for (e in names(experiments)) {
    x <- experiments[[e]]
    ref <- experiment_reference(x, emulators, runs)
    refs[[e]] <- ref
    x$field <- register_curves(x$field, ref, windows, ...)
    experiments[[e]] <- x
    how[[e]] <- if (!is.null(x$reference)) {
      sprintf("its reference (%d run%s)", nrow(ref$design), if (nrow(ref$design) == 1L) "" else "s")
    } else if (!is.null(x$condition)) {
      paste0("the emulators at the runs' inputs at the condition ",
             paste(sprintf("%s = %g", names(x$condition), x$condition), collapse = ", "))
    } else if (!is.null(x$change)) {
      n_out <- sum(outside_design(ref$design, runs$design, names(x$change)))
      paste0("the emulators at the runs' inputs changed by ",
             paste(sprintf("%s %+g", names(x$change), x$change), collapse = ", "),
             if (n_out) sprintf(" (%d of %d runs moved outside their range, extrapolated)", n_out,
                                nrow(ref$design)))
    } else {
      sprintf("its emulators at their %d runs' inputs", nrow(ref$design))
    }
  }
  if (!quiet) {
    names_e <- names(how)
    bullets <- sprintf("{.val {names_e[%d]}}: {how[%d]}", seq_along(how), seq_along(how))
    wv_inform(c("i" = "The field data of the experiments were registered to the model in their own condition:",
                stats::setNames(bullets, rep("*", length(bullets)))))
  }
  attr(experiments, "references") <- refs
  experiments
}

# The runs nearest an experiment's condition (NULL without one): the
# max(5, 10%) of them closest to `condition` in the condition inputs, each
# scaled by its range in the design. A condition can change the fine detail
# the basis leaves out (a dose scales the kink where it is given), so an
# experiment's reference takes that detail from these runs, not from all.
condition_neighbours <- function(design, condition) {
  cond <- intersect(names(condition), names(design))
  if (!length(cond)) return(NULL)
  d2 <- 0
  for (p in cond) {
    w <- diff(range(design[[p]]))
    d2 <- d2 + ((design[[p]] - condition[[p]]) / if (w > 0) w else 1)^2
  }
  k <- min(nrow(design), max(5L, ceiling(nrow(design) / 10)))
  order(d2)[seq_len(k)]
}

# Which rows of `design` lie outside the range of `runs_design` in the
# columns `inputs`.
outside_design <- function(design, runs_design, inputs) {
  out <- rep(FALSE, nrow(design))
  for (p in inputs) {
    r <- range(runs_design[[p]])
    out <- out | design[[p]] < r[1] | design[[p]] > r[2]
  }
  out
}
