#' The flyer-plate impact: a real validation data set
#'
#' Loads the flyer-plate example of GPMSA (Los Alamos National Laboratory,
#' LA-UR-08-07464; GNU GPL version 2, see the folder `extdata/flyer` of the
#' installed package). A tantalum flyer plate hits a target; a laser
#' velocimeter measures the free-surface velocity of the target over time
#' (cm per microsecond against microseconds), and a hydrocode simulates it.
#' There are 128 runs of the hydrocode at a design of 10 inputs and one
#' measured curve.
#'
#' The inputs, in the design's units (the scaled design of the files mapped
#' to the physical ranges of `fl_ranges`: 0 to the lower end, 1 to the upper):
#' `eos` (a perturbation of the equation of state), the seven
#' Preston-Tonks-Wallace strength parameters `theta0`, `kappa`, `gamma`,
#' `y0`, `yinf`, `s0`, `sinf`, `pmin` (the spall strength) and `vs` (the
#' impact velocity).
#'
#' How the files become package objects:
#' * **Grid.** The simulator's 136 time points are not equally spaced (steps
#'   of 0.0097 to 0.0103 microseconds), so [model_runs()] interpolates the
#'   runs linearly to 256 equally spaced points on the same interval
#'   (`t`, from 0.9314 to 2.2816).
#' * **Measured curve.** It has 170 rows but 34 time stamps appear twice.
#'   [field_runs()] takes it as recorded: the velocities at one time stamp
#'   are averaged (136 distinct times, one every 0.01 microseconds), then
#'   interpolated linearly to `t`. The record starts 0.0022 microseconds
#'   after the first point of `t`, before the impact: that point takes the
#'   first measured value (5e-6, the target at rest). GPMSA's own script
#'   also interpolates the measured curve to the simulation times, without a
#'   time shift. The field keeps the evidence of the measurement noise that
#'   the interpolated curve loses (`field$noise`): the scatter of the 34
#'   repeated measurements (an sd of about 4.3e-4), the noise of the curve on
#'   its own time stamps, and each wavelet coefficient's noise variance after
#'   the averaging and interpolation; the noise learned by [calibrate()]
#'   uses them (see [field_runs()]).
#' * **I/U map.** `vs` is a condition of the experiment, measured with some
#'   uncertainty, not an unknown of the model: it is a `"variation"` input,
#'   normal about the centre of its range (334, the files do not give the
#'   measured value) with a sixth of its range as standard deviation,
#'   truncated to the range. The other nine inputs are unknowns of the model,
#'   `"calibration"` inputs, uniform on their ranges in the I/U map.
#' * **Prior.** `prior` is the Gaussian prior of the seven strength
#'   parameters that GPMSA's example takes from earlier calibrations
#'   (`c.theta`, `c.cov`), with its third coordinate turned from
#'   `-log(gamma)` into `log(gamma)` (the sign of its mean and of its
#'   covariances with the other six flipped; its variance is unchanged).
#'   Coordinates with `scale = "log"` are on the log of the input.
#'
#' @return A list with
#' * `runs`: a `wv_runs` object ([model_runs()]) of the 128 runs, design in
#'   physical units, one site `"velocity"`;
#' * `field`: a `wv_field` object ([field_runs()]) holding the measured curve
#'   on `t`, one replicate;
#' * `iu`: the `wv_iu` I/U map ([iu_map()]) of the 10 inputs;
#' * `prior`: a list with `names` (the seven strength parameters), `mean`,
#'   `cov` (7 x 7) and `scale` (`"identity"` or `"log"` for each);
#' * `t`: the time grid (256 points);
#' * `ranges`: a data frame of each input's `lower` and `upper` end;
#' * `raw`: the measured curve as recorded (`t`, `velocity`, 170 rows).
#' @seealso [preflight()] to check a data set before [validate()].
#' @export
#' @examples
#' fl <- load_flyer()
#' fl$runs
#' fl$field
#' fl$iu
#' exp(fl$prior$mean[["gamma"]])
#' autoplot(fl$runs, field = fl$field)
load_flyer <- function() {
  dir <- system.file("extdata", "flyer", package = "wavevalid", mustWork = TRUE)
  read <- function(f) as.matrix(utils::read.table(file.path(dir, f)))
  inputs <- c("eos", "theta0", "kappa", "gamma", "y0", "yinf", "s0", "sinf", "pmin", "vs")
  scaled <- read("design.txt.xz")
  ranges <- read("fl_ranges")
  design <- as.data.frame(sweep(sweep(scaled, 2L, ranges[, 2] - ranges[, 1], `*`), 2L, ranges[, 1],
                                `+`))
  names(design) <- inputs
  sim <- read("sim_outputs.xz")
  runs <- withCallingHandlers(
    model_runs(design, t(sim[, -1L]), sim[, 1L], site = "velocity"),
    wavevalid_message = function(m) invokeRestart("muffleMessage")
  )
  obs <- read("obs_outputs1")
  raw <- data.frame(t = obs[, 1L], velocity = obs[, 2L])
  field <- withCallingHandlers(
    field_runs(matrix(raw$velocity, nrow = 1L), raw$t, site = "velocity", grid = runs$t),
    wavevalid_message = function(m) invokeRestart("muffleMessage")
  )

  iu <- iu_map(name = inputs, type = ifelse(inputs == "vs", "variation", "calibration"),
               lower = ranges[, 1], upper = ranges[, 2])
  strength <- inputs[2:8]
  m <- as.vector(read("c.theta"))
  v <- read("c.cov")
  m[3] <- -m[3]
  v[3, -3] <- -v[3, -3]
  v[-3, 3] <- -v[-3, 3]
  dimnames(v) <- list(strength, strength)
  prior <- list(names = strength, mean = stats::setNames(m, strength), cov = v,
                scale = stats::setNames(ifelse(strength == "gamma", "log", "identity"), strength))
  list(runs = runs, field = field, iu = iu, prior = prior, t = runs$t,
       ranges = data.frame(input = inputs, lower = ranges[, 1], upper = ranges[, 2]), raw = raw)
}
