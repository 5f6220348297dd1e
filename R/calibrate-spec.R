# calibrate(), stage 1: the field data, emulators and I/U map as the sampler's
# sites, priors and tau2 groups.

# The inputs of the runs' design or of the emulators (`what`: "runs" or
# "emulators") against those of the I/U map: NULL when they are the same,
# else `figure` (which inputs lack where) and `fix` (how to make them agree).
# An input of the map that the runs do not vary would be calibrated from its
# prior alone, and an input of the runs without a range has no prior: both
# stop validate() and calibrate().
iu_inputs_mismatch <- function(inputs, iu, what = c("runs", "emulators")) {
  what <- match.arg(what)
  unrun <- setdiff(iu$name, inputs)
  unmapped <- setdiff(inputs, iu$name)
  if (!length(unrun) && !length(unmapped)) return(NULL)
  names_text <- function(x) paste(x, collapse = ", ")
  s <- function(x, one, more) if (length(x) == 1L) one else more
  where <- if (what == "runs") "the design of the runs" else "the inputs of the emulators"
  figure <- c(
    if (length(unrun)) sprintf("the I/U map's input%s %s %s not in %s", s(unrun, "", "s"),
                               names_text(unrun),
                               s(unrun, "is", "are"), where),
    if (length(unmapped)) sprintf("%s's input%s %s %s not in the I/U map",
                                  if (what == "runs") "the design" else "the emulators",
                                  s(unmapped, "", "s"),
                                  names_text(unmapped), s(unmapped, "is", "are"))
  )
  drop <- if (length(unrun) == 1L) sprintf("iu[iu$name != \"%s\", ]", unrun) else
    sprintf("iu[!iu$name %%in%% c(%s), ]", paste0("\"", unrun, "\"", collapse = ", "))
  fix <- c(
    if (length(unrun)) sprintf("%s %s, or drop %s from the I/U map with %s (the runs do not vary %s, so the calibration could only return %s prior).",
                               if (what == "runs") "Add" else "Fit the emulators on runs whose design holds",
                               if (what == "runs") paste(names_text(unrun), "to the design of the runs (run the model over it)") else names_text(unrun),
                               s(unrun, "it", "them"), drop, s(unrun, "it", "them"),
                               s(unrun, "its", "their")),
    if (length(unmapped)) sprintf("Add %s to the I/U map with iu_add() (an input held fixed with a narrow range around its value)%s.",
                                  names_text(unmapped),
                                  if (what == "runs") paste(", or drop", s(unmapped, "it", "them"),
                                                            "from the design of the runs") else "")
  )
  list(figure = paste(figure, collapse = "; "), fix = paste(fix, collapse = " "))
}

upper_first <- function(x) paste0(toupper(substr(x, 1L, 1L)), substring(x, 2L))

# --- data and priors ----------------------------------------------------------

calibration_spec <- function(emulators, field, iu, sigma2 = NULL, pool_levels = NULL,
                             registration_variance = FALSE, call = rlang::caller_env()) {
  basis <- emulators$basis
  check_class(basis, "wv_basis", arg = "emulators$basis", call = call)
  if (length(field$t) != length(basis$t) ||
      max(abs(field$t - basis$t)) > 1e-8 * max(1, abs(basis$t))) {
    wv_abort(c(
      "{.arg field} must be on the grid of the emulators' basis.",
      "x" = "The field grid has {length(field$t)} point{?s} on [{signif(min(field$t), 4)}, {signif(max(field$t), 4)}]; the basis grid has {length(basis$t)} on [{signif(min(basis$t), 4)}, {signif(max(basis$t), 4)}].",
      "i" = "Build the field with {.fn field_runs} on the grid of the model runs (and register it with {.fn register_curves})."
    ), call = call)
  }
  inputs <- emulators$inputs
  mismatch <- iu_inputs_mismatch(inputs, iu, "emulators")
  if (!is.null(mismatch)) {
    wv_abort(c(
      "The emulators and {.arg iu} must have the same inputs.",
      "x" = "{upper_first(mismatch$figure)}.",
      "i" = "{mismatch$fix}"
    ), class = c("inputs", "input"), call = call)
  }
  sites <- names(field$curves)
  nobank <- setdiff(sites, emulator_sites(emulators))
  if (length(nobank)) {
    wv_abort("Field {cli::qty(length(nobank))}site{?s} {.val {nobank}} {?has/have} no emulators; emulated sites are {.val {emulator_sites(emulators)}}.",
             call = call)
  }
  iu <- iu_upgrade(iu)
  k <- match(inputs, iu$name)
  x_nom <- stats::setNames(iu$nominal[k], inputs)
  if (!is.null(field$x_nom)) {
    use <- intersect(names(field$x_nom), inputs)
    x_nom[use] <- field$x_nom[use]
  }
  var <- iu$type[k] == "variation"
  shift <- ifelse(var, x_nom - iu$nominal[k], 0)
  prior_iu <- iu[k, , drop = FALSE]
  prior_iu$lower <- iu$lower[k] + shift
  prior_iu$upper <- iu$upper[k] + shift
  prior_iu$nominal <- ifelse(var, x_nom, iu$nominal[k])
  prior_iu$prior_mean[var] <- x_nom[var]
  rownames(prior_iu) <- NULL
  priors <- sampler_priors(prior_iu)

  check_sigma2(sigma2, sites, call = call)
  n_reps <- vapply(field$curves, nrow, integer(1))[sites]
  noise_setting <- stats::setNames(ifelse(n_reps >= 2L, "replicates", "learned"), sites)
  noise <- NULL
  if (inherits(sigma2, "wv_noise_prior")) {
    noise <- sigma2
    noise_setting[] <- "learned"
    sigma2 <- NULL
  } else if (identical(sigma2, "finest")) {
    noise_setting[] <- "finest"
  } else if (!is.null(sigma2)) {
    given <- if (is.list(sigma2)) names(sigma2) else sites
    noise_setting[given] <- "given"
  }
  if (any(noise_setting == "learned") && is.null(noise)) {
    noise <- noise_prior()
    wv_inform(c("i" = "{cli::qty(sum(noise_setting == 'learned'))}Site{?s} {.val {sites[noise_setting == 'learned']}} {?has/have} one field replicate: the field noise is learned in the posterior, one variance for all coefficients (see {.fn noise_prior}).",
                if (length(field$noise)) c(" " = "It is the variance of one measurement, with the evidence {.fn field_runs} kept from the measured curve on its own time stamps.")))
  }
  noise_scale <- NULL
  if (!is.null(noise)) {
    learned <- sites[noise_setting == "learned"]
    noise_scale <- if (is.null(noise$scale)) {
      measured_noise_scale(field, basis, learned)
    } else if (length(noise$scale) == 1L && is.null(names(noise$scale))) {
      stats::setNames(rep(noise$scale, length(learned)), learned)
    } else {
      noise$scale[learned]
    }
    noise$scale <- noise_scale
  }
  if (identical(sigma2, "finest")) {
    sigma2 <- unclass(field_noise(field, basis))
    wv_warn(c(
      "Field variances estimated from the finest wavelet level of the field curves, not from replicates.",
      "i" = "The bands rest on that estimate and on the measurement noise being close to white."
    ), class = "noise_estimate")
  }
  sigma2 <- resolve_sigma2(sigma2, sites, length(basis$index), call = call)
  if (identical(pool_levels, "coarse")) pool_levels <- coarse_levels(basis)
  tau_group <- bias_groups(basis$level, pool_levels, call = call)
  extra <- shifts <- extra_diag <- NULL
  if (isTRUE(registration_variance %in% c("auto", "check", "diagonal"))) {
    # the check's error as shifts of the landmarks along the curve's
    # time-shift directions, sampled with the inputs, and the rest on every
    # coefficient; one variance per site for all of it ("diagonal", internal:
    # the experiments' sites and a bias shared by experiments)
    extra <- extra_diag <- registration_check_variance(field, basis)
    if (!identical(registration_variance, "diagonal"))
      shifts <- registration_shift_structure(field, basis)
    if (!is.null(shifts)) extra <- shifts$extra
    if (is.null(extra) && identical(registration_variance, "check")) {
      wv_abort(c(
        "{.code registration_variance = \"check\"} needs the registration's own error, measured on model runs.",
        "x" = "{.arg field} carries no {.field registration_check}.",
        "i" = "Register it with {.code register_curves(field, runs, windows, check_runs = 5)}, or call {.fn validate} with {.arg windows}."
      ), class = "registration", call = call)
    }
  } else if (isTRUE(registration_variance)) {
    extra <- registration_extra_variance(field, basis)
    if (is.null(extra)) {
      wv_abort(c(
        "{.code registration_variance = TRUE} needs field data registered to model runs.",
        "x" = "{.arg field} has no landmark spread of a reference made of model runs.",
        "i" = "Register it with {.code register_curves(field, runs, windows)}, {.code runs} a {.cls wv_runs}."
      ), call = call)
    }
  }
  groups <- NULL
  site_data <- list()
  wbar <- s2 <- n_rep <- bias_group <- list()
  reg_extra <- extra
  fills <- list()
  for (s in sites) {
    fill <- NULL
    if (!is.null(field$observed[[s]])) {
      fill <- missing_fill_variance(field$curves[[s]], field$observed[[s]], basis$Psi)
      fills[[s]] <- fill$var
      if (sum(!fill$no_data) < 3L) {
        wv_abort(c("Site {.val {s}}: no field curve reaches {sum(!fill$covered)} of the {length(fill$covered)} points (from t = {signif(field$t[which(!fill$covered)[1]], 4)}), and {sum(fill$no_data)} of the {length(fill$no_data)} coefficients reach there: the data inform {sum(!fill$no_data)}.",
                   "i" = "Give the runs and the field on the range the curves cover (the runs cut there, and {.code field_runs(grid = )} on that range)."),
                 class = c("own_extent", "input"), call = call)
      }
      if (any(!fill$covered)) {
        wv_inform(c("i" = "Site {.val {s}}: no field curve reaches {sum(!fill$covered)} of the {length(fill$covered)} points (from t = {signif(field$t[which(!fill$covered)[1]], 4)}); the {sum(fill$no_data)} of {length(fill$var)} coefficients whose functions reach there get no weight, the record-wide ones among them.",
                    " " = "To keep them, give the runs and the field on the range the curves cover."),
                  class = "own_extent")
      }
    }
    W <- field$curves[[s]] %*% basis$Psi
    R <- nrow(W)
    wbar[[s]] <- colMeans(W)
    s2[[s]] <- colSums(sweep(W, 2L, wbar[[s]])^2)
    if (!is.null(fill)) {
      extra[[s]] <- (extra[[s]] %||% 0) + fill$var
      if (any(!fill$cut)) s2[[s]][fill$cut] <- stats::median(s2[[s]][!fill$cut])
    }
    n_rep[[s]] <- R
    grp <- tau_group$group
    if (!is.null(fill)) grp <- pool_data_free(grp, tau_group$level, fill$no_data)
    used <- sort(unique(grp))
    g0 <- if (is.null(groups)) 0L else nrow(groups)
    groups <- rbind(groups, data.frame(name = paste0(s, ":", tau_group$label[used]), site = s,
                                       level = tau_group$level[used],
                                       stringsAsFactors = FALSE))
    site_data[[s]] <- list(bank = site_bank(emulators, s), wbar = wbar[[s]], s2 = s2[[s]], R = R,
                           sigma2 = sigma2[[s]], group = g0 + match(grp, used) - 1L,
                           extra = extra[[s]],
                           reg_U = shifts$U[[s]])
    if (noise_setting[[s]] == "learned") {
      site_data[[s]]$noise <- c(list(scale = unname(noise_scale[[s]]),
                                     family = match(noise$family,
                                                    c("half-cauchy", "half-normal")) - 1L),
                                measured_noise_evidence(field$noise[[s]], basis))
    }
    bias_group[[s]] <- paste0(s, ":", tau_group$label[grp])
  }
  list(sites = site_data, priors = priors, inputs = inputs, x_nom = x_nom, prior_iu = prior_iu,
       groups = groups, bias_group = bias_group, pool_levels = tau_group$pooled, z_init = x_nom,
       wbar = wbar,
       s2 = s2, n_rep = n_rep, basis = basis, extra = extra, reg_extra = reg_extra,
       fill = if (length(fills)) fills, reg_shift_var = shifts$var,
       extra_diag = extra_diag,
       noise_setting = noise_setting, noise_prior = noise,
       noise_evidence = noise_evidence_summary(field, sites[noise_setting == "learned"], site_data))
}

# The levels whose bias coefficients share one variance under
# `pool_levels = "coarse"`: the record-wide levels (their functions span the
# whole record) and the finer levels after them until the group holds more
# than four coefficients, so that the posterior of its variance (about an
# inverse gamma of shape n / 2 from n coefficients) has a finite variance.
# NULL when that leaves fewer than two levels.
coarse_levels <- function(basis) {
  lv <- sort(unique(basis$level))
  n <- as.vector(table(factor(basis$level, levels = lv)))
  j <- max(c(intersect(record_wide_levels(basis), lv), min(lv)))
  while (sum(n[lv <= j]) <= 4L && j < max(lv)) j <- lv[lv > j][1L]
  out <- lv[lv <= j]
  if (length(out) < 2L) NULL else out
}

# The bias-variance groups of the coefficients of a basis: one per level, or
# one for the levels in pool_levels (those present) and one per other level.
# `coef_level` is the wavelet level of each coefficient. Returns label and
# (lowest) level of each group, the 1-based group of each coefficient and the
# pooled levels.
bias_groups <- function(coef_level, pool_levels = NULL, call = rlang::caller_env()) {
  lv <- sort(unique(coef_level))
  if (!is.null(pool_levels)) {
    check_levels_arg(pool_levels, "pool_levels", min_length = 2L, call = call)
    pool_levels <- sort(unique(as.integer(pool_levels)))
    absent <- setdiff(pool_levels, lv)
    if (length(absent)) {
      wv_abort(c(
        "{.arg pool_levels} names level{?s} {absent} that the basis does not hold.",
        "i" = "The basis holds levels {lv}."
      ), call = call)
    }
  }
  if (is.null(pool_levels)) return(list(label = as.character(lv), level = lv,
                                        group = match(coef_level, lv), pooled = NULL))
  low <- min(pool_levels)
  key <- ifelse(coef_level %in% pool_levels, low, coef_level)
  lev <- sort(unique(key))
  label <- as.character(lev)
  contiguous <- identical(pool_levels, seq(low, max(pool_levels)))
  label[lev == low] <-
    if (contiguous) paste0(low, "-", max(pool_levels)) else paste(pool_levels, collapse = ",")
  list(label = label, level = lev, group = match(key, lev), pooled = pool_levels)
}

resolve_sigma2 <- function(sigma2, sites, n, call = rlang::caller_env()) {
  out <- stats::setNames(vector("list", length(sites)), sites)
  if (is.null(sigma2)) return(out)
  if (is.numeric(sigma2) && length(sites) == 1L) sigma2 <- stats::setNames(list(sigma2), sites)
  if (!is.list(sigma2) || is.null(names(sigma2)) || !all(names(sigma2) %in% sites)) {
    wv_abort("{.arg sigma2} must be a numeric vector (one site) or a list named by site ({.val {sites}}).",
             call = call)
  }
  for (s in names(sigma2)) {
    v <- sigma2[[s]]
    if (!is.numeric(v) || !length(v) %in% c(1L, n) || any(!is.finite(v)) || any(v <= 0)) {
      wv_abort("{.arg sigma2} for site {.val {s}} must be positive, one value or {n} (one per coefficient).",
               call = call)
    }
    out[[s]] <- rep_len(as.numeric(v), n)
  }
  out
}

resolve_fix_tau2 <- function(fix_tau2, groups, call = rlang::caller_env()) {
  G <- nrow(groups)
  if (is.null(fix_tau2)) return(list(fixed = rep(FALSE, G), values = numeric(0)))
  if (!is.numeric(fix_tau2) || any(!is.finite(fix_tau2)) || any(fix_tau2 <= 0)) {
    wv_abort("{.arg fix_tau2} must hold positive numbers.", call = call)
  }
  if (is.null(names(fix_tau2))) {
    if (length(fix_tau2) != 1L && length(fix_tau2) != G) {
      wv_abort("{.arg fix_tau2} must have one value or one per group ({G}: {.val {groups$name}}).",
               call = call)
    }
    vals <- rep_len(fix_tau2, G)
  } else {
    if (!setequal(names(fix_tau2), groups$name)) {
      wv_abort("{.arg fix_tau2} must be named by every group: {.val {groups$name}}.", call = call)
    }
    vals <- unname(fix_tau2[groups$name])
  }
  list(fixed = rep(TRUE, G), values = stats::setNames(vals, groups$name))
}

# The default scale of the learned noise's prior by site: the noise sd of the
# measured curve on its own time stamps where field_runs() kept it, else the
# finest-level estimate of field_noise().
measured_noise_scale <- function(field, basis, sites) {
  kept <- vapply(sites, function(s) !is.null(field$noise[[s]]$detail_sd), logical(1))
  out <- stats::setNames(numeric(length(sites)), sites)
  if (any(!kept)) out[!kept] <- attr(field_noise(subset_field_sites(field, sites[!kept]), basis),
                                     "sd")
  for (s in sites[kept]) out[[s]] <- field$noise[[s]]$detail_sd
  if (any(!(out > 0))) {
    wv_abort(c("The measured curve of site{?s} {.val {sites[!(out > 0)]}} shows no noise at all.",
               "i" = "Give the scale of the noise with {.code noise_prior(scale = )}, or the variances with {.arg sigma2}."),
             class = "numeric")
  }
  out
}

# What the sampler takes of the noise evidence field_runs() kept for a site
# (NULL: none): each coefficient's noise variance in units of one
# measurement's (mult), and as data on that variance, ss / sigma2 ~
# chi^2_df, the repeated measurements' scatter and the difference residuals
# of the measured curve on its own stamps (their ss and df summed; the two
# are independent under Gaussian noise, the residuals being those of the
# values averaged by stamp).
measured_noise_evidence <- function(nz, basis) {
  if (is.null(nz)) return(NULL)
  out <- list(mult = resampled_noise_multipliers(nz$map, basis$Psi))
  df <- nz$df + (nz$detail_df %||% 0)
  if (df > 0) out <- c(out, list(ss = nz$ss + (nz$detail_ss %||% 0), df = df))
  out
}

# For the print and the report, by learned site: where the noise evidence
# came from (NULL where nothing was kept from the measurements).
noise_evidence_summary <- function(field, learned, site_data) {
  out <- lapply(learned, function(s) {
    nz <- field$noise[[s]]
    if (is.null(nz)) return(NULL)
    list(n_stamps = nz$n_stamps, n_repeated = nz$n_repeated, df = nz$df, ss = nz$ss,
         detail_sd = nz$detail_sd,
         detail_ss = nz$detail_ss %||% 0, detail_df = nz$detail_df %||% 0,
         mult = site_data[[s]]$noise$mult)
  })
  out <- stats::setNames(out, learned)
  out[!vapply(out, is.null, logical(1))]
}

# The field data of some sites only.
subset_field_sites <- function(field, sites) {
  field$curves <- field$curves[sites]
  if (!is.null(field$units)) field$units <- field$units[sites]
  if (!is.null(field$observed)) field$observed <- field$observed[intersect(sites, names(field$observed))]
  field
}

# One value per tau2 group (`coef_level`: the wavelet level of each
# coefficient): 1 when its coefficients inform the inputs (their
# levels are all in inform_levels), 0 when they are cut off; NULL when every
# level informs them.
informing_groups <- function(inform_levels, coef_level, bias_group, groups,
                             call = rlang::caller_env()) {
  if (is.null(inform_levels)) return(NULL)
  lv <- sort(unique(coef_level))
  check_levels_arg(inform_levels, "inform_levels", min_length = 1L, call = call)
  absent <- setdiff(inform_levels, lv)
  if (length(absent)) {
    wv_abort(c("{.arg inform_levels} names level{?s} {absent} that the basis does not hold.",
               "i" = "The basis holds levels {lv}."), call = call)
  }
  inside <- coef_level %in% inform_levels
  out <- vapply(groups$name, function(g) {
    k <- unlist(lapply(bias_group, function(b) b == g))
    here <- unique(rep(inside, length(bias_group))[k])
    if (length(here) > 1L) {
      wv_abort(c("{.arg inform_levels} splits levels that share one bias variance.",
                 "x" = "Group {.val {g}} holds levels both in and out of {.arg inform_levels}.",
                 "i" = "Take all of {.arg pool_levels} in or out."), call = call)
    }
    as.integer(here)
  }, integer(1))
  if (!any(out == 1L)) {
    wv_abort("{.arg inform_levels} leaves no coefficient to inform the inputs.", call = call)
  }
  unname(out)
}

# What curves missing beyond their own extent (`observed`: the R x T mask of
# the points each covers; NULL: all covered) add to the variance of the
# replicates' mean coefficients (Psi: T x coefficients), the curves filled
# there by fill_missing(). A point covered by n of R curves holds a mean of
# n: sigma2 (1 / n - 1 / R) more, sigma2 the replicates' pooled variance
# where all cover. A coefficient whose function reaches a point no curve
# covers is left to the bias's prior (a variance 1e6 times the curves' mean
# square): the fill there is no evidence, and a guess at it (the model's
# prior predictive, the bias at the last covered point carried on) was read
# as a misfit where the curves are different units. A coefficient a tenth
# of whose weight is missing (`cut`) takes the median scatter of the others
# as its own (the fill has none).
missing_fill_variance <- function(curves, observed, Psi) {
  if (is.null(observed)) return(NULL)
  R <- nrow(curves)
  n_at <- colSums(observed)
  full <- n_at == R
  s2 <- if (R >= 2L && any(full)) {
    mean(apply(curves[, full, drop = FALSE], 2L, stats::var))
  } else 0
  none <- n_at == 0L
  v <- s2 * (1 / pmax(n_at, 1) - 1 / R)
  big <- 1e6 * mean(curves[observed]^2)
  reach_none <- colSums(Psi^2 * none) > 1e-10 * colSums(Psi^2)
  var <- colSums(Psi^2 * ifelse(none, 0, v)) + ifelse(reach_none, big, 0)
  w_miss <- colSums(Psi^2 * (n_at < R)) / colSums(Psi^2)
  list(var = var, cut = w_miss > 0.1, point = ifelse(none, big, v), covered = !none,
       no_data = reach_none)
}

# The bias-variance group of each coefficient (`group`, indices into the
# levels `level`) with every group that has fewer than three coefficients
# with data (the others reach where no curve does, `no_data`) pooled with
# the nearest level's group that has three (the finer on a tie). The prior
# of a group's variance is flat up to the variance of its coefficients'
# data, which no data makes unbounded; the posterior is then proper only
# with three coefficients of data (its tail tau2^(-n/2)), and without them
# the variance, and the bias with it, wander without bound.
pool_data_free <- function(group, level, no_data) {
  n_data <- tabulate(group[!no_data], max(group))
  informed <- which(n_data >= 3L)
  if (!length(informed)) return(group)
  for (g in setdiff(unique(group), informed)) {
    d <- abs(level[informed] - level[g])
    near <- informed[d == min(d)]
    group[group == g] <- near[which.max(level[near])]
  }
  group
}
