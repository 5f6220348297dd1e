# Two tiers of tests. The default tier proves every property on small
# problems and one test-bed fit per test process; the slow tier (full-size
# simulation-based calibration, coverage over many vehicles, the diagnosis
# over several test beds and mechanisms) runs only when the environment
# variable WAVEVALID_SLOW_TESTS is "true" (`make test-slow`).
slow_tier <- function() identical(tolower(Sys.getenv("WAVEVALID_SLOW_TESTS")), "true")

skip_unless_slow <- function() {
  testthat::skip_if_not(slow_tier(), "slow tier: set WAVEVALID_SLOW_TESTS=true (make test-slow)")
}
