#' The statistical model of a calibration: noise, bias and likelihood
#'
#' `bias_control()` gathers the choices that change what [calibrate()] and
#' [validate()] estimate: how the field noise is set, how the bias variances
#' are grouped over wavelet levels, which levels inform the inputs, and how
#' the inputs' likelihood counts the coefficients, and what the registration
#' adds to the field's variance. Its defaults are the package's defaults; the
#' method's report is `bias_control(pool_levels = NULL, input_likelihood =
#' "independent")`. The arguments are checked
#' here, once; what depends on the data (the sites of `sigma2`, the levels
#' the basis holds, the groups of `fix_tau2`) is checked by [calibrate()].
#'
#' Wavelet levels are numbered as in [wavelet_basis()]: 0 for the scaling
#' coefficient, `l + 1` for wavethresh's detail level `l`.
#'
#' @param sigma2 How the field noise variances are set (see the section
#'   Field noise of [calibrate()]):
#'   * `NULL` (default): from the replicates at sites with two or more (the
#'     method's modular estimate), learned in the posterior with the default
#'     [noise_prior()] at sites with one (with a message);
#'   * a [noise_prior()]: learned in the posterior at every site, one variance
#'     per site shared by all coefficients;
#'   * fixed variances: a numeric vector (one value or one per coefficient)
#'     for a single site, or a list of such vectors named by site (the sites
#'     left out keep the default);
#'   * `"finest"`: estimated once from the finest wavelet level of the field
#'     curves with [field_noise()], with a warning. On a smoothed or
#'     interpolated curve the finest level holds less than the noise, and
#'     this underestimates it (the bands are then too narrow).
#' @param pool_levels `"coarse"` (default): the coarsest levels' bias
#'   coefficients share one variance at each site: the record-wide levels
#'   (whose functions span the whole record, see [where_fails()]) and the
#'   finer levels after them until the group holds more than four
#'   coefficients (levels 0 to 3 for the default basis), so that the data
#'   inform that variance; `NULL`, one bias variance per site and level, as
#'   in the method; or two or more wavelet levels whose bias coefficients
#'   share one variance at each site (group `"site:a-b"`). Under the method's
#'   prior a level of one coefficient (levels 0 and 1) has a nearly free bias,
#'   which takes whatever offset of the whole record the calibrated inputs
#'   create. See the section Bias variances of [calibrate()].
#' @param inform_levels `NULL` (every level informs the inputs, as in the
#'   method) or the wavelet levels whose coefficients inform the inputs; the
#'   other levels get their `tau2` and bias given the inputs drawn. Levels
#'   pooled by `pool_levels` must be all in or all out.
#' @param input_likelihood `"adjusted"` (default): in the inputs' steps only,
#'   the likelihood is raised to the magnitude adjustment of a composite
#'   likelihood estimated from the data, for errors the coefficients share;
#'   `"independent"`: the coefficients counted as independent, the method's
#'   likelihood and posterior. See the section Errors the coefficients share
#'   of [calibrate()].
#' @param temper Power of the likelihood in (0, 1]: 1 (default) is the
#'   method's posterior.
#' @param registration_variance What the registration of the field adds to
#'   the variance of the registered field mean (see the section
#'   Registration of [calibrate()]): `"auto"` (default), the registration's
#'   own error when the field carries it (as [validate()] registers it),
#'   as shifts of the events sampled with the inputs and a variance for the
#'   rest, and nothing otherwise; `"check"`, that error, required (an error when the
#'   field does not carry it); `FALSE`, nothing (the method's); `TRUE`, a
#'   first-order variance from the spread of the reference's landmarks over
#'   the runs.
#' @param fix_tau2 Optional fixed bias variances (one value, or a vector
#'   named by group `"site:level"`); they are then not sampled. Mostly for
#'   checks.
#' @param level_variances With several experiments: `"shared"` (default), one
#'   bias variance per resolution level across the experiments;
#'   `"per_experiment"`, one per experiment.
#' @param experiment_bias With several experiments: `"own"` (default), one
#'   bias function per experiment and site; `"shared"`, one per site common to
#'   every experiment (needs `level_variances = "shared"`).
#' @return A `wv_bias_control` object: a list of the checked values.
#' @seealso [sampler_control()] for the sampler's tuning, [calibrate()].
#' @export
#' @examples
#' bias_control()
#' # the method's report
#' bias_control(pool_levels = NULL, input_likelihood = "independent")
#' # the method's field mean: nothing for the registration's own error
#' bias_control(registration_variance = FALSE)
bias_control <- function(sigma2 = NULL, pool_levels = "coarse", inform_levels = NULL,
                         input_likelihood = c("adjusted", "independent"), temper = 1,
                         registration_variance = "auto", fix_tau2 = NULL,
                         level_variances = c("shared", "per_experiment"),
                         experiment_bias = c("own", "shared")) {
  input_likelihood <- check_choice(input_likelihood)
  level_variances <- check_choice(level_variances)
  experiment_bias <- check_choice(experiment_bias)
  check_number(temper, min = 0, max = 1)
  if (temper == 0) wv_abort("{.arg temper} must be above 0; 1 is the method's posterior.")
  if (!(isTRUE(registration_variance) || isFALSE(registration_variance) ||
        (is.character(registration_variance) && length(registration_variance) == 1L &&
         registration_variance %in% c("auto", "check")))) {
    wv_abort("{.arg registration_variance} must be {.val auto}, {.val check}, {.code TRUE} or {.code FALSE}.")
  }
  if (!identical(pool_levels, "coarse")) check_levels_arg(pool_levels, "pool_levels",
                                                          min_length = 2L)
  check_levels_arg(inform_levels, "inform_levels", min_length = 1L)
  check_sigma2(sigma2)
  if (!is.null(fix_tau2) &&
      (!is.numeric(fix_tau2) || any(!is.finite(fix_tau2)) || any(fix_tau2 <= 0))) {
    wv_abort("{.arg fix_tau2} must hold positive numbers.")
  }
  if (experiment_bias == "shared" && level_variances == "per_experiment") {
    wv_abort(c("A bias shared by the experiments has one variance per level.",
               "i" = "Use {.code level_variances = \"shared\"} with {.code experiment_bias = \"shared\"}."),
             class = "experiment")
  }
  structure(list(sigma2 = sigma2, pool_levels = pool_levels, inform_levels = inform_levels,
                 input_likelihood = input_likelihood, temper = temper,
                 registration_variance = registration_variance, fix_tau2 = fix_tau2,
                 level_variances = level_variances, experiment_bias = experiment_bias),
            class = "wv_bias_control")
}

#' Tuning of the calibration's sampler
#'
#' `sampler_control()` gathers the settings of the Metropolis-Hastings
#' sampler of [calibrate()] and [validate()]: how many chains and draws, how
#' they are thinned, the proposal, the burn-in, the start's search and the
#' threads. They change how well the posterior is explored, not which
#' posterior it is. The seed stays an argument of [calibrate()] and
#' [validate()].
#'
#' @section Proposals:
#' `proposal = "report"` is the sampler of the report (Appendix C): each cycle
#' is a joint log-uniform step on every `tau2` (factor `e^0.7`) and a joint
#' step on every input, each coordinate from a 50/50 mixture of a uniform on
#' its support and a uniform on `current +/- step * range`, with the mixture
#' densities in the Hastings ratio. These joint moves are almost never
#' accepted when the posterior is narrow (many coefficients, several
#' replicates), and the chains then stay where they start.
#'
#' `proposal = "adaptive"` (the default) departs from the report: each `tau2`
#' group is updated on its own (no emulator prediction needed); the inputs
#' move by a Gaussian random walk whose covariance is learned during the
#' burn-in (adaptive Metropolis, Haario, Saksman and Tamminen 2001),
#' `(2.38^2 / d) (Sigma_hat + eps)` times a scale tuned towards acceptance
#' 0.234, from a diagonal of 2\% of each range; proposals outside the support
#' are rejected. The burn-in starts from the best, by profile likelihood, of
#' the nominal point and `n_search` draws from the inputs' prior, is not
#' saved, and ends with the proposal frozen, so the saved chain is a
#' time-homogeneous Metropolis-Hastings chain. A tenth of the cycles use the
#' report's mixture step, for global moves.
#'
#' With `global_moves > 0`, that share of the cycles instead makes an
#' independence move: a multivariate t (4 degrees of freedom) with the mean
#' and covariance of the second half of the burn-in (weight 0.8), or the
#' uniform on the inputs' box (weight 0.2). Where the posterior is close to
#' that t the chains need fewer cycles per effective sample; where it is a
#' curved ridge or has several modes the move is rarely accepted and costs
#' random-walk steps. It helped on the test beds and not on the flyer plate
#' of [load_flyer()] (`studies/README.md` in the package's source repository,
#' "The sampler's independence moves"), hence it is not the default.
#' `fit$acceptance$global` and the print give its acceptance; a burn-in of
#' fewer than `40 d` cycles leaves too few points, and the report's step is
#' used.
#'
#' @section Stopping:
#' With `n_draws = NULL` (default) the chains stop when every input's
#' effective sample size, all chains together, is at least `ess` and, with two
#' chains or more, its R-hat at most `rhat`, or at `max_draws` draws per chain
#' with a warning. The chains first run `ess / chains` draws each after a
#' burn-in sized to them; while a target is unmet, every chain continues from
#' where it stopped by the draws the slowest input's ESS says are missing, a
#' fifth more, but at most the draws it holds (their ESS, partly drawn with
#' the burn-in's walk, understates what the next round gives), or by the
#' draws it holds while R-hat is above target. A continued
#' chain's random walk is learned anew from that chain's draws so far
#' (`2.38^2 / d` times their covariance; with `global_moves`, the
#' independence proposal their mean and covariance): the burn-in's estimate
#' rests on a few thousand cycles, noisy where an input moves slowly, and a
#' round's draws on many more. Each round is then a time-homogeneous chain.
#' At 4 sites x 4096 points x 200 runs x 2 experiments this took the slowest
#' input from 0.2 to 0.4 effective draws per draw after the first round. A
#' round at most doubles the draws because the first round's ESS, drawn with
#' the burn-in's walk, understates the next round's: projected from it, the
#' chains stopped at 838 draws each with an ESS of 715; doubling first, at
#' 608 with 470 (`bench/README.md`, "The stopping rule's rounds"). The print
#' of the fit says where and why the chains stopped, and the slowest input's
#' effective draws per second. On both test beds the chains stop after two or
#' three rounds, several times sooner than the former fixed 1000 draws of 200
#' cycles, with the same findings (`studies/README.md`, "stopping.R").
#'
#' @param n_draws Draws saved per chain: a number for chains of that
#'   length, or `NULL` (default) for chains that stop when they have enough
#'   (`ess`, `rhat`, `max_draws`; see the section Stopping).
#' @param n_inner Metropolis-Hastings cycles between saved draws (the
#'   thinning, default 50); `sigma2` is drawn anew every `n_inner` cycles.
#'   On both test beds, with the chains stopping at 400 effective draws, a
#'   saved draw every 50 cycles was worth 0.8-0.9 of an effective draw and
#'   one every 200 cycles about one: 50 gave 2.3 to 3 times the effective
#'   draws per second of 200 (`studies/stopping.R`).
#' @param ess,rhat With `n_draws = NULL`, the targets: every input's
#'   effective sample size, all chains together (`coda::effectiveSize()`), at
#'   least `ess` (default 400), and with two chains or more its potential
#'   scale reduction factor (`coda::gelman.diag()`) at most `rhat` (default
#'   1.05). Inputs held to a point are not judged.
#' @param max_draws With `n_draws = NULL`, the ceiling: draws per chain at
#'   most (default 1000); a chain that reaches it without the targets warns.
#' @param step Half-width of the local proposal as a fraction of each input's
#'   range (the method's 0.05 on a coded range of about 0.5-0.75).
#' @param proposal `"adaptive"` (default) or `"report"`; see the section
#'   Proposals.
#' @param global_moves Probability, in `[0, 1)`, that a cycle of the
#'   `"adaptive"` sampler makes an independence move; 0 (default) keeps the
#'   report's mixture step as the global move, in a tenth of the cycles.
#' @param burnin Cycles run before the first saved draw and discarded. `NULL`
#'   gives `max(5000, n * n_inner / 4)` for `"adaptive"`, whose proposal
#'   adapts during these cycles (`n` the draws per chain, or with
#'   `n_draws = NULL` the first round's `ess / chains`), and 0 for
#'   `"report"`.
#' @param n_search Number of draws from the prior of the inputs searched,
#'   with the nominal point, for the start of each chain's burn-in under
#'   `"adaptive"` (the best by profile likelihood; 0 starts at the nominals).
#'   Where the posterior has several modes, a wider search finds the better
#'   one more often.
#' @param threads Threads (OpenMP) sharing the emulator predictions of each
#'   chain, default `getOption("wavevalid.threads", 1)`. The draws do not
#'   depend on `threads`. No more threads are used than there are free cores
#'   (or `getOption("wavevalid.free_cores")` when set); a message says when
#'   `threads` is cut.
#' @param quiet Suppress the progress bars and messages (default
#'   `getOption("wavevalid.quiet", FALSE)`).
#' @param chains Number of chains (default 2), each with its own stream of
#'   random numbers derived from the seed.
#' @param together Run the chains together in one R process, a thread each,
#'   their emulator predictions made in step: each coefficient's weights and
#'   each emulator's factor are read from memory once per cycle for all the
#'   chains, which is what limits a large problem. The draws are the same as
#'   with the chains apart. `NULL` (default) runs them together when there
#'   are two chains or more and a core for each: the workers of a
#'   multisession, multicore or callr plan, or the free cores under the
#'   sequential plan (not with `options(wavevalid.workers = 1)`); never under
#'   a plan that sends work to other machines (a cluster or batchtools plan),
#'   where each chain is a job of its own.
#' @return A `wv_sampler_control` object: a list of the checked values.
#' @seealso [bias_control()] for the statistical model's choices,
#'   [calibrate()].
#' @export
#' @examples
#' # chains that stop when every input has 400 effective draws and R-hat 1.05
#' sampler_control()
#' # a fixed length
#' sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE)
#' # one chain
#' sampler_control(chains = 1)
sampler_control <- function(n_draws = NULL, n_inner = 50, step = 0.1,
                            proposal = c("adaptive", "report"),
                            global_moves = 0, burnin = NULL, n_search = 200,
                            threads = getOption("wavevalid.threads", 1L),
                            quiet = getOption("wavevalid.quiet", FALSE), ess = 400, rhat = 1.05,
                            max_draws = 1000,
                            chains = 2, together = NULL) {
  if (!is.null(n_draws)) check_number(n_draws, min = 1, integer = TRUE)
  check_number(n_inner, min = 1, integer = TRUE)
  check_number(ess, min = 10, max = 1e7)
  check_number(rhat, min = 1.0001, max = 2)
  check_number(max_draws, min = 20, max = 1e7, integer = TRUE)
  check_number(step, min = 1e-6, max = 1)
  proposal <- check_choice(proposal)
  check_number(global_moves, min = 0, max = 0.99)
  if (!is.null(burnin)) check_number(burnin, min = 0, max = .Machine$integer.max, integer = TRUE)
  check_number(n_search, min = 0, max = 1e7, integer = TRUE)
  check_number(threads, min = 1, max = 1024, integer = TRUE)
  check_flag(quiet)
  check_number(chains, min = 1, integer = TRUE)
  if (!is.null(together)) check_flag(together)
  structure(list(n_draws = n_draws, n_inner = n_inner, step = step, proposal = proposal,
                 global_moves = global_moves, burnin = burnin, n_search = n_search,
                 threads = threads,
                 quiet = quiet, ess = ess, rhat = rhat, max_draws = max_draws, chains = chains,
                 together = together),
            class = "wv_sampler_control")
}

#' How validate() registers the field curves
#'
#' `registration_control()` gathers the settings of the registration of the
#' field curves on the model's event landmarks that [validate()] runs before
#' the basis is built ([register_curves()]). Without `windows` nothing is
#' registered.
#'
#' Choose as landmarks (`features`) the features that mark when an event
#' happens, not those whose timing the model's own physics sets: the
#' registration moves each landmark of a replicate onto the reference's, so
#' a landmark the inputs move carries part of the model's error away with
#' it, or adds one. The price of landmarks that mark only when an event
#' happens: a mechanism that only delays an event (an absorption lag) is
#' aligned away with the timing jitter, and only the landmarks' own timing,
#' which [where_fails()] reads, keeps it.
#'
#' @param windows Optional list of `c(from, to)` event windows; when given,
#'   the field curves are registered first.
#' @param reference Reference curves for the registration (passed to
#'   [register_curves()]; default: the mean of the model runs). When the I/U
#'   map has test conditions (inputs of type `"condition"`), the runs span
#'   them all, so by default the field is registered twice: first to the
#'   mean of the runs, to build the basis and fit the emulators, then again
#'   to the model at the base experiment's condition (the runs' inputs with
#'   the conditions set to their nominal values, through the emulators), as
#'   the experiments are registered to the model at theirs.
#' @param knots_every Spacing of the further warp knots fitted between the
#'   windows (passed to [register_curves()]): `"auto"` (default) a knot
#'   every 1/32 of the record (at least four steps of the field's grid, the
#'   closest spacing [register_curves()] takes), a number (in time units),
#'   or `NULL` for the method's report's landmark warp (landmarks only).
#' @param features The landmarks located in each window (passed to
#'   [register_curves()]): `c("min", "max")` (default), or any of `"min"`,
#'   `"max"`, `"rise"`, `"fall"`, `"cross"` that the physics of the events
#'   makes sharp.
#' @return A `wv_registration_control` object: a list of the checked values.
#' @seealso [validate()], [register_curves()].
#' @export
#' @examples
#' registration_control(windows = list(c(6, 11), c(37, 41)))
#' # the method's report's landmark warp, on the steepest rise of each event
#' registration_control(windows = list(c(6, 11)), knots_every = NULL, features = "rise")
registration_control <- function(windows = NULL, reference = NULL, knots_every = "auto",
                                 features = c("min", "max")) {
  if (!is.null(windows)) {
    pairs <- if (is.numeric(windows)) list(windows) else windows
    ok <- is.list(pairs) && length(pairs) > 0L &&
      all(vapply(pairs, function(x) is.numeric(x) && length(x) == 2L && all(is.finite(x)) &&
                 x[1] < x[2], logical(1)))
    if (!ok) {
      wv_abort("{.arg windows} must be a list of increasing pairs of times, e.g. {.code list(c(6, 11), c(37, 41))}.")
    }
  }
  if (!is.null(knots_every) && !identical(knots_every, "auto")) {
    if (!is.numeric(knots_every) || length(knots_every) != 1L || !is.finite(knots_every) ||
        knots_every <= 0) {
      wv_abort("{.arg knots_every} must be {.val auto}, a positive number (in time units) or {.code NULL}.")
    }
  }
  check_features(features)
  structure(list(windows = windows, reference = reference, knots_every = knots_every,
                 features = features),
            class = "wv_registration_control")
}

#' How validate() builds the basis and the emulators
#'
#' `emulation_control()` gathers the settings of the wavelet basis
#' ([wavelet_basis()]) and of the emulators ([fit_emulators()]) that
#' [validate()] fits to the model runs.
#'
#' @param basis_args A list of further arguments to [wavelet_basis()]
#'   (default: none, the basis that reconstructs the runs to 1% and each
#'   field curve to 2% or its noise).
#' @param engine The emulators' engine (see [fit_emulators()]):
#'   `"gasp_level"` (default), whose predictive variances hold at runs away
#'   from the design, or `"gasp"`, the method's report's per-coefficient fit,
#'   or `"dicekriging"`.
#' @return A `wv_emulation_control` object: a list of the checked values.
#' @seealso [validate()], [wavelet_basis()], [fit_emulators()].
#' @export
#' @examples
#' emulation_control()
#' # the method's report: its basis rule and its emulators
#' emulation_control(basis_args = list(retain = "report"), engine = "gasp")
emulation_control <- function(basis_args = list(),
                              engine = c("gasp_level", "gasp", "dicekriging")) {
  if (!is.list(basis_args))
    wv_abort("{.arg basis_args} must be a list of arguments to {.fn wavelet_basis}.")
  engine <- check_choice(engine)
  structure(list(basis_args = basis_args, engine = engine), class = "wv_emulation_control")
}

# The spacing of the further warp knots of a registration on the grid `t`:
# "auto" is a knot every 1/32 of the record, at least four grid steps.
registration_knots <- function(knots_every, t) {
  if (identical(knots_every, "auto")) max(diff(range(t)) / 32, 4 * diff(t[1:2])) else knots_every
}
