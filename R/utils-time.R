# A clock of a pipeline's phases: clock("phase", expr) evaluates expr and
# adds its elapsed and CPU seconds (user + system, this process and its
# children) to the phase's; clock() returns a data frame with one row per
# phase in the order first seen.
phase_clock <- function() {
  elapsed <- cpu <- stats::setNames(numeric(0), character(0))
  function(phase, expr) {
    if (missing(phase)) {
      return(data.frame(phase = names(elapsed), elapsed = unname(elapsed), cpu = unname(cpu)))
    }
    t0 <- proc.time()
    value <- force(expr)
    d <- proc.time() - t0
    if (!phase %in% names(elapsed)) elapsed[[phase]] <<- cpu[[phase]] <<- 0
    elapsed[[phase]] <<- elapsed[[phase]] + d[["elapsed"]]
    cpu[[phase]] <<- cpu[[phase]] +
      sum(d[c("user.self", "sys.self", "user.child", "sys.child")], na.rm = TRUE)
    value
  }
}
