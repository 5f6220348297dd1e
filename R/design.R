#' A space-filling design for the model runs
#'
#' An approximately maximin Latin hypercube on the ranges of an I/U map: the
#' best of 50 random Latin hypercubes by their smallest inter-point distance
#' (inputs scaled to the unit cube), improved by 2000 swaps of two values
#' within a column that increase that distance. The report's designs are of
#' this kind. With `nominal = TRUE` the nominal point is added as the last
#' run, as in the test bed.
#'
#' Emulators are only as accurate as their design: with few runs per input,
#' their errors away from the runs exceed their predictive variances and the
#' calibrated inputs compensate. Adding runs is the remedy.
#'
#' @param iu A `wv_iu` object ([iu_map()]).
#' @param n Number of runs, including the nominal point when `nominal = TRUE`.
#' @param nominal Add the nominal point as the last run.
#' @param seed `NULL` (R's RNG) or a whole number; the design depends only on
#'   it, not on the state of R's generator.
#' @return A data frame with one column per input of `iu` and `n` rows, in the
#'   inputs' own units.
#' @export
#' @examples
#' iu <- iu_map(c("u1", "x1"), c("calibration", "variation"),
#'              lower = c(0, 10), upper = c(1, 20), nominal = c(0.5, 15))
#' d <- design_maximin(iu, 12, seed = 1)
#' d
#' plot(d)
design_maximin <- function(iu, n, nominal = TRUE, seed = NULL) {
  check_class(iu, "wv_iu")
  check_number(n, min = if (isTRUE(nominal)) 3 else 2, max = 1e5, integer = TRUE)
  if (!is.logical(nominal) || length(nominal) != 1L || is.na(nominal)) {
    wv_abort("{.arg nominal} must be TRUE or FALSE.")
  }
  seed <- resolve_seed(seed)
  n_lhd <- as.integer(n) - as.integer(nominal)
  cube <- with_rng_seed(seed, maximin_lhd(n_lhd, nrow(iu)))
  d <- sweep(sweep(cube, 2L, iu$upper - iu$lower, `*`), 2L, iu$lower, `+`)
  if (nominal) d <- rbind(d, iu$nominal)
  colnames(d) <- iu$name
  as.data.frame(d)
}
