# Generates the small "bring your own model" example shipped in inst/extdata:
# a one-degree-of-freedom oscillator hit by a pulse, with three inputs, 40
# runs on a non-dyadic grid of 136 points and 3 measured curves.
set.seed(20261122)
t <- seq(0, 10, length.out = 136)
oscillator <- function(k, c, m, t, cubic = 0) {
  dt <- 0.002
  tt <- seq(0, max(t), by = dt)
  force <- 50 * exp(-((tt - 1.5) / 0.15)^2) - 30 * exp(-((tt - 6) / 0.25)^2)
  x <- v <- 0
  out <- numeric(length(tt))
  for (i in seq_along(tt)) {
    a <- (force[i] - c * v - k * x - cubic * x^3) / m
    v <- v + a * dt
    x <- x + v * dt
    out[i] <- k * x + c * v
  }
  stats::approx(tt, out, xout = t)$y
}
lhs <- function(n, p) sapply(seq_len(p), function(j) (sample(n) - runif(n)) / n)
design01 <- lhs(40, 3)
ranges <- rbind(stiffness = c(80, 120), damping = c(2, 8), mass = c(0.8, 1.2))
design <- data.frame(
  stiffness = ranges[1, 1] + design01[, 1] * diff(ranges[1, ]),
  damping = ranges[2, 1] + design01[, 2] * diff(ranges[2, ]),
  mass = ranges[3, 1] + design01[, 3] * diff(ranges[3, ])
)
runs <- t(apply(design, 1, function(z) oscillator(z[1], z[2], z[3], t)))
truth <- c(stiffness = 104, damping = 4.5, mass = 0.97)
reality <- oscillator(truth[1], truth[2], truth[3], t, cubic = 200)
field <- t(replicate(3, reality + stats::filter(rnorm(136, sd = 0.15), 0.6, method = "recursive")))

long <- function(m) data.frame(curve = rep(seq_len(nrow(m)), times = ncol(m)), t = rep(t, each = nrow(m)),
                               y = signif(as.vector(m), 6))
dir <- file.path("inst", "extdata")
write.csv(cbind(run = seq_len(nrow(design)), signif(design, 6)), file.path(dir, "byom-design.csv"), row.names = FALSE)
con <- xzfile(file.path(dir, "byom-runs.csv.xz"), "w", compression = 9)
write.csv(long(runs), con, row.names = FALSE)
close(con)
con <- xzfile(file.path(dir, "byom-field.csv.xz"), "w", compression = 9)
write.csv(long(field), con, row.names = FALSE)
close(con)
write.csv(data.frame(name = rownames(ranges), type = c("variation", "calibration", "variation"),
                     lower = ranges[, 1], upper = ranges[, 2], nominal = c(100, 5, 1)),
          file.path(dir, "byom-iu.csv"), row.names = FALSE)
