# The tests run in several processes at once: each keeps its work in its own
# R process unless a test sets another plan (test-plans.R checks the plan
# validate() and calibrate() set by themselves).
options(wavevalid.workers = 1)
