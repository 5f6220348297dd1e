# The terms with memory of the term library: a first-order filter, a delay
# and a running integral of a channel, and the products of a filter or an
# integral with a channel. Each is computed on the curves' own time grid.

# The filter x' = u - b x, x(t1) = 0, of the curve `u` on the grid `t`: the
# recursion exact for `u` linear between the grid's points.
memory_filter <- function(u, t, b) {
  n <- length(u)
  if (n < 2L) return(numeric(n))
  h <- diff(t)
  a <- exp(-b * h)
  one_a <- -expm1(-b * h)
  s <- diff(u) / h
  inc <- u[-n] * one_a / b + s * (b * h - one_a) / b^2
  x <- numeric(n)
  for (k in seq_len(n - 1L)) x[k + 1L] <- a[k] * x[k] + inc[k]
  x
}

# The curve `u` on the grid `t` delayed by `d`: u(t - d), linear between the
# grid's points, held at its first value before the start.
memory_delay <- function(u, t, d) {
  stats::approx(t, u, xout = t - d, rule = 2, ties = "ordered")$y
}

# The running integral of `u` from the grid's start (the trapezoid rule,
# exact for `u` linear between the grid's points).
memory_integral <- function(u, t) {
  n <- length(u)
  if (n < 2L) return(numeric(n))
  c(0, cumsum(diff(t) * (u[-1L] + u[-n]) / 2))
}

# The memory terms of one channel `ch` (curves `x` by site on the grid `t`):
# rows as channel_terms() makes them, each with `op`, the term as a function
# of the channel's curve and its grid, `label`, its readable name, and no
# `fun` (a term with memory is no function of the channel's value at one
# time), and for a filter or a delay `rate`: its time constant or lag as an
# input (`name`, `lower`, `upper` spanning the library's versions, `value`,
# and `op`, the term as a function of the curve, its grid and the rate). With `with`, the curves of further channels (named): the products
# of the channel's filters and integral with each.
memory_terms <- function(ch, x, t, with = list()) {
  len <- diff(range(t))
  fmt <- function(v) format(signif(v, 3))
  row <- function(term, effect, family, channel, version, label, op, by = NULL, self = FALSE,
                  rate = NULL) {
    values <- lapply(names(x), function(s) {
      v <- op(x[[s]], t)
      if (!is.null(by)) v <- v * by[[s]]
      v
    })
    list(term = term, effect = effect, family = family, channel = channel, version = version,
         label = label, values = stats::setNames(values, names(x)), fun = NULL,
         op = if (is.null(by)) op else if (self) function(u, t) op(u, t) * u,
         rate = if (!is.null(rate) && (is.null(by) || self)) {
           if (self) rate$op <- local({
             f <- rate$op
             function(u, t, r) f(u, t, r) * u
           })
           rate
         })
  }
  filters <- lapply(c(1 / 16, 1 / 4, 1), function(f) {
    tau <- f * len
    list(version = paste0("tau = ", fmt(tau)), tau = tau, f = f,
         op = function(u, t) memory_filter(u, t, 1 / tau),
         rate = list(name = "tau_term", what = "time constant", lower = len / 16, upper = len,
                     value = tau, op = function(u, t, r) memory_filter(u, t, 1 / r)))
  })
  delays <- lapply(c(32, 8, 4), function(k) {
    d <- len / k
    list(version = paste0("lag = ", fmt(d)), d = d, k = k,
         op = function(u, t) memory_delay(u, t, d),
         rate = list(name = "lag_term", what = "lag", lower = len / 32, upper = len / 4, value = d,
                     op = function(u, t, r) memory_delay(u, t, r)))
  })
  integral <- function(u, t) memory_integral(u, t)
  out <- lapply(filters, function(v) {
    row(sprintf("filter(%s; %s)", ch, v$version), sprintf("filter(%s)", ch), "filter", ch,
        v$version, sprintf("first-order filter of %s, time constant %s (%s of the record)", ch,
                           fmt(v$tau), fmt(v$f)), v$op, rate = v$rate)
  })
  out <- c(out, lapply(delays, function(v) {
    row(sprintf("delay(%s; %s)", ch, v$version), sprintf("delay(%s)", ch), "delay", ch, v$version,
        sprintf("delay of %s by %s (1/%d of the record)", ch, fmt(v$d), v$k), v$op, rate = v$rate)
  }))
  out <- c(out, list(row(sprintf("integral(%s)", ch), sprintf("integral(%s)", ch), "integral", ch,
                         "", sprintf("running integral of %s", ch), integral)))
  for (other in names(with)) {
    by <- with[[other]]
    # a product with the channel itself is still a term of that one channel
    chan <- if (other == ch) ch else paste(ch, "x", other)
    out <- c(out, lapply(filters, function(v) {
      row(sprintf("product(filter(%s; %s), %s)", ch, v$version, other),
          sprintf("product(filter(%s), %s)", ch, other), "product", chan, v$version,
          sprintf("first-order filter of %s, time constant %s (%s of the record), times %s", ch,
                  fmt(v$tau), fmt(v$f), other),
          v$op, by, other == ch, rate = v$rate)
    }))
    out <- c(out, list(row(sprintf("product(integral(%s), %s)", ch, other),
                           sprintf("product(integral(%s), %s)", ch, other), "product", chan, "",
                           sprintf("running integral of %s, times %s", ch, other), integral, by, other == ch)))
  }
  out
}

# The channels whose memory terms the library holds, and the channels each
# one's filter and integral multiply: every channel but the output's time
# derivative (whose filter and integral are the output itself, nearly), each
# by itself and, for a state, by the output too.
memory_channels <- function(channels, kind) {
  nm <- setdiff(names(channels), "d/dt output")
  stats::setNames(lapply(nm, function(ch) {
    by <- ch
    if (kind[[ch]] == "state" && "output" %in% names(channels)) by <- c(by, "output")
    channels[by]
  }), nm)
}
