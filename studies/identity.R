# Fits, draws, bands and diagnoses on both test beds and the flyer, saved for
# a bit-for-bit comparison between two builds of the package.
#   R_LIBS=<lib> Rscript studies/identity.R save <file.rds>
#   Rscript studies/identity.R compare <a.rds> <b.rds>
# The calls name every setting the way both builds accept; a build with
# control objects is also called through them, and both ways must agree.
args <- commandArgs(TRUE)
if (args[1] == "compare") {
  a <- readRDS(args[2]); b <- readRDS(args[3])
  # where_fails() kept its bias by wavelet level in attribute `levels` before
  # it was named `wavelet_levels`
  attrs_sorted <- function(at) {
    names(at)[names(at) == "levels"] <- "wavelet_levels"
    at <- at[setdiff(names(at), c("class", "row.names", "names"))]
    at[order(names(at))]
  }
  rename <- function(x) {
    if (!is.list(x) || is.null(x$fails_attrs)) return(x)
    x$fails_attrs <- attrs_sorted(x$fails_attrs)
    h <- x$fails_attrs$held$fails
    if (!is.null(h)) x$fails_attrs$held$fails <- list(table = as.data.frame(unclass(h)), attrs = attrs_sorted(attributes(h)))
    x
  }
  a <- lapply(a, rename); b <- lapply(b, rename)
  for (nm in union(names(a), names(b))) {
    same <- identical(a[[nm]], b[[nm]])
    cat(sprintf("%-28s %s\n", nm, if (same) "identical" else "DIFFERENT"))
  }
  quit(status = if (identical(a[names(b)], b) && setequal(names(a), names(b))) 0 else 1)
}
suppressPackageStartupMessages(library(wavevalid))
options(wavevalid.quiet = TRUE)
new_api <- exists("bias_control", asNamespace("wavevalid"))
fit_call <- function(fun, ..., bias = list(), sampler = list()) {
  if (new_api) {
    fun(..., bias = do.call(bias_control, bias), sampler = do.call(sampler_control, sampler))
  } else {
    do.call(fun, c(list(...), bias, sampler))
  }
}
keep <- function(fit) {
  wf <- where_fails(fit)
  wf_attrs <- attributes(wf)
  wf_attrs$held$fit <- NULL
  list(draws = as.matrix(fit$draws), wb = fit$wb, wM = fit$wM, sigma2 = fit$sigma2,
       bias = bias(fit), reality = reality(fit), model = model_prediction(fit),
       fails = as.data.frame(unclass(wf)),
       fails_attrs = wf_attrs[setdiff(names(wf_attrs), c("class", "row.names", "names"))])
}
out <- list()
ex <- example_fit(1)
out$example <- keep(ex)
tb <- load_testbed()
fit <- suppressWarnings(fit_call(validate, tb$A$runs, tb$A$field, tb$iu, windows = tb$windows, chains = 1,
                                 seed = 1, sampler = list(n_draws = 100, n_inner = 10)))
out$suspension <- keep(fit)
out$suspension_explain <- as.data.frame(explain_bias(fit, testbed_signatures(colMeans(as.matrix(fit$draws))[fit$inputs]),
                                                    seed = 1))
out$suspension_indep <- keep(suppressWarnings(fit_call(
  calibrate, fit$emulators, fit$field, tb$iu, chains = 1, seed = 2,
  bias = list(input_likelihood = "independent", pool_levels = 0:3), sampler = list(n_draws = 100, n_inner = 10))))
dos <- testbed_dosing(seed = 1, hidden = "enterohepatic_recycling")
fd <- suppressWarnings(fit_call(validate, dos$A$runs, dos$A$field, dos$iu, windows = dos$windows, chains = 1,
                                seed = 1, sampler = list(n_draws = 100, n_inner = 10)))
out$dosing <- keep(fd)
fl <- load_flyer()
ff <- suppressWarnings(fit_call(validate, fl$runs, fl$field, fl$iu, chains = 1, seed = 1,
                                sampler = list(n_draws = 100, n_inner = 10)))
out$flyer <- keep(ff)
saveRDS(out, args[2])
cat("saved", length(out), "cases to", args[2], "\n")
