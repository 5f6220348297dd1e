# The declared shape of a fit (R/fit-class.R) and the emulator bank's door
# (R/emulator.R).

expect_declared_fit <- function(fit) {
  expect_s3_class(fit, "wv_fit")
  expect_identical(names(unclass(fit)), names(wv_fit_fields))
  expect_identical(validate_wv_fit(fit), fit)
}

test_that("every field of a fit is declared with a known type", {
  types <- c("mcmc.list", "site matrices", "site list", "integer", "character", "named numeric",
             "named character", "number", "data frame", "matrix", "list", "wv_emulators", "wv_basis",
             "wv_field", "wv_iu")
  expect_true(all(sub("[?]$", "", wv_fit_fields) %in% types))
  expect_false(anyDuplicated(names(wv_fit_fields)) > 0)
  fit <- new_wv_fit(list(seed = 1L))
  expect_identical(names(unclass(fit)), names(wv_fit_fields))
  expect_null(fit$draws)
  expect_error(new_wv_fit(list(colour = "red")), class = "wavevalid_error_internal")
})

test_that("the example fit, calibrate() and the fits made from a fit have exactly the declared fields", {
  withr::local_seed(1)
  expect_declared_fit(example_fit())
  ex <- example_problem()
  fit <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 2,
                                    sampler = sampler_control(n_draws = 40, n_inner = 5, quiet = TRUE)))
  expect_declared_fit(fit)
  expect_declared_fit(reread_held(fit, "u1"))
  held <- suppressWarnings(hold_inputs(fit, inputs = "u1", strata = 2, quiet = TRUE))
  expect_declared_fit(held)
  expect_identical(held$held$inputs, "u1")
})

test_that("validate() with an experiment on the suspension test bed makes a fit of the declared shape", {
  skip_on_cran()
  withr::local_seed(1)
  withr::local_options(wavevalid.quiet = TRUE)
  tb <- testbed_suspension(seed = 1, hidden = "progressive_bumpstop", n_added_mass = 2)
  exps <- list(added_mass = experiment(tb$added_mass$field, change = tb$added_mass$delta))
  fit <- suppressWarnings(validate(tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, chains = 1, seed = 1,
                                   experiments = exps,
                                   sampler = sampler_control(n_draws = 20, n_inner = 5, burnin = 100, n_search = 10,
                                                             quiet = TRUE)))
  expect_declared_fit(fit)
  expect_false(is.null(fit$experiments))
  expect_true(all(fit$experiments$site %in% names(fit$wb)))
  expect_false(is.null(fit$pipeline))
  expect_null(fit$call_args)
  expect_identical(names(fit$control), c("registration", "emulation", "bias", "sampler"))
  expect_s3_class(fit$timing, "data.frame")
})

test_that("the check refuses a field of the wrong type, draws with the wrong columns and a missing field", {
  fit <- example_fit()
  wrong <- unclass(fit)
  wrong$chain <- as.character(wrong$chain)
  expect_error(validate_wv_fit(structure(wrong, class = "wv_fit")), class = "wavevalid_error_state")
  expect_error(fit_set(fit, chain = as.character(fit$chain)), class = "wavevalid_error_state")
  expect_error(fit_set(fit, emulators = list()), class = "wavevalid_error_state")

  d <- fit$draws
  d[[1]] <- coda::mcmc(as.matrix(d[[1]])[, -1L, drop = FALSE])
  expect_error(fit_set(fit, draws = d), class = "wavevalid_error_state")
  wb <- fit$wb
  wb[[1]] <- wb[[1]][, -1L, drop = FALSE]
  expect_error(fit_set(fit, wb = wb), class = "wavevalid_error_state")
  wM <- fit$wM
  names(wM) <- "elsewhere"
  expect_error(fit_set(fit, wM = wM), class = "wavevalid_error_state")

  missing <- unclass(fit)
  missing$settings <- NULL
  expect_error(validate_wv_fit(structure(missing, class = "wv_fit")), class = "wavevalid_error_state")
  expect_error(fit_set(fit, settings = NULL), class = "wavevalid_error_state")
  extra <- c(unclass(fit), list(colour = "red"))
  expect_error(validate_wv_fit(structure(extra, class = "wv_fit")), class = "wavevalid_error_state")
})

test_that("the setter re-checks, keeps emptied fields and refuses an undeclared name", {
  fit <- example_fit()
  expect_error(fit_set(fit, colour = "red"), class = "wavevalid_error_internal")
  out <- fit_set(fit, sampling_seconds = 2, held = NULL)
  expect_identical(out$sampling_seconds, 2)
  expect_identical(names(unclass(out)), names(wv_fit_fields))
  expect_identical(out$draws, fit$draws)
  expect_identical(names(unclass(fit_set(out, sampling_seconds = NULL))), names(wv_fit_fields))
})

# Only the emulator module (R/emulator.R, R/emulator-methods.R,
# R/emulator-variance.R) names the compiled emulator functions (gasp_*_cpp);
# every other file goes through bank_predict() and its siblings. The check
# reads the sources when the tests run from the package's source tree.
test_that("bank_predict() is the compiled bank prediction, and only the emulator module calls it", {
  ex <- example_problem()
  bank <- site_bank(ex$emulators, "site1")
  Z <- cbind(u1 = c(0.1, 0.5, 0.9), x1 = c(0.3, 0.5, 0.7))
  expect_identical(bank_predict(bank, Z), gasp_bank_predict_cpp(bank, Z))
  W <- bank_predict(bank, Z)$mean
  expect_identical(bank_predict_augmented(bank, Z, W, Z[3:1, ]),
                   gasp_bank_predict_augmented_cpp(bank, Z, W, Z[3:1, ]))
  expect_identical(emulator_sites(ex$emulators), "site1")

  src <- test_path("..", "..", "R")
  skip_if_not(dir.exists(src), "the package's R sources are not at hand")
  files <- setdiff(list.files(src, pattern = "[.]R$"),
                   c("emulator.R", "emulator-methods.R", "emulator-variance.R", "RcppExports.R"))
  hits <- unlist(lapply(files, function(f) {
    code <- grep("^\\s*#", readLines(file.path(src, f), warn = FALSE), value = TRUE, invert = TRUE)
    if (any(grepl("gasp_[a-z_]*_cpp|\\$banks\\b", code))) f
  }))
  expect_identical(hits, NULL)
})

test_that("fit_get() reads every declared field as [[ does and refuses an undeclared name", {
  fit <- example_fit()
  for (f in names(wv_fit_fields)) expect_identical(fit_get(fit, f), fit[[f]], info = f)
  expect_identical(fit_sites(fit), names(fit$wb))
  expect_identical(fit_draws_matrix(fit), as.matrix(fit$draws))
  expect_error(fit_get(fit, "colour"), class = "wavevalid_error_internal")
  expect_error(fit_get(fit, c("wb", "wM")), class = "wavevalid_error_internal")
  expect_error(fit_get(fit, 1L), class = "wavevalid_error_internal")
  expect_error(fit_get(unclass(fit), "wb"), class = "wavevalid_error_internal")
  # a fit saved before a field was declared lacks it: the field reads as NULL
  old <- structure(unclass(fit)[setdiff(names(wv_fit_fields), c("held", "timing", "pipeline"))], class = "wv_fit")
  expect_null(fit_get(old, "held"))
  expect_identical(fit_get(old, "wb"), fit$wb)
})

# Outside the fit module (R/fit-*.R) a fit's fields are read through
# fit_get() and its accessors: no `fit$<field>`, `before$`, `after$` (the
# names that hold only fits there), nor `object$`/`x$` in the methods for
# wv_fit. design_posterior() (R/inputs-design.R) reads a fit's fields
# directly: the inputs module sits below the fit's, which calls it. The
# check reads the sources when the tests run from the package's source tree.
test_that("no file outside the fit module reads a fit's fields directly", {
  src <- test_path("..", "..", "R")
  skip_if_not(dir.exists(src), "the package's R sources are not at hand")
  files <- setdiff(list.files(src, pattern = "[.]R$"), c("RcppExports.R", "inputs-design.R"))
  files <- files[!startsWith(files, "fit-")]
  walk <- function(e, vars) {
    if (!is.call(e)) return(character())
    hit <- if (identical(e[[1]], as.name("$")) && is.name(e[[2]]) && as.character(e[[2]]) %in% vars &&
               as.character(e[[3]]) %in% names(wv_fit_fields)) {
      paste0(as.character(e[[2]]), "$", as.character(e[[3]]))
    }
    c(hit, unlist(lapply(as.list(e)[-1], function(a) if (!missing(a)) walk(a, vars))))
  }
  hits <- unlist(lapply(files, function(f) {
    unlist(lapply(parse(file.path(src, f), keep.source = FALSE), function(e) {
      name <- if (is.call(e) && identical(e[[1]], as.name("<-")) && is.name(e[[2]])) as.character(e[[2]]) else ""
      vars <- c("fit", "before", "after", if (endsWith(name, ".wv_fit")) c("object", "x"))
      found <- walk(e, vars)
      if (length(found)) paste0(f, ": ", name, ": ", found)
    }))
  }))
  expect_identical(hits, NULL)
})
