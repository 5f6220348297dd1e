test_that("report tables keep significant digits of inputs on very different scales", {
  fl <- load_flyer()
  tab <- signif_table(as.data.frame(fl$iu))
  expect_identical(names(tab), names(as.data.frame(fl$iu)))
  g <- tab[tab$name == "gamma", ]
  expect_identical(g$lower, "6.964e-08")
  expect_identical(g$upper, "0.0006765")
  expect_identical(tab$upper[tab$name == "vs"], "338.5")
  expect_identical(tab$prior_sd[tab$name == "gamma"], "")
  expect_identical(tab$prior_sd[tab$name == "vs"], "1.5")
  # every figure reads back to the value within four significant digits
  num <- as.numeric(tab$upper)
  expect_equal(num, fl$iu$upper, tolerance = 1e-3)
  expect_true(all(num != 0))
})

test_that("the report renders for a fit whose emulators were given their parameters", {
  skip_if_not(rmarkdown::pandoc_available())
  fit <- example_fit()
  expect_true(all(is.na(fit$emulators$params$loglik)))
  out <- withr::local_tempfile(fileext = ".html")
  suppressWarnings(validation_report(fit, file = out, quiet = TRUE))
  html <- readLines(out, warn = FALSE)
  expect_true(any(grepl("Field noise", html, fixed = TRUE)))
  expect_true(any(grepl("uniform", html, fixed = TRUE)))
  # the report leads with the verdict
  expect_lt(grep("<h2>Verdict</h2>", html, fixed = TRUE)[1], grep("Inputs</h2>", html, fixed = TRUE)[1])
})

# One report of the example fit with a comparison, read by the tests below:
# the page's text with its lines joined, runs of white space made one and
# characters outside ASCII as "?" (positions then count characters and
# bytes alike).
report_cmp <- NULL
report_text <- local({
  text <- NULL
  function() {
    if (is.null(text)) {
      fit <- example_fit()
      ex <- example_problem()
      moved <- ex$field
      moved$curves$site1 <- sweep(moved$curves$site1, 2, 0.1 * sin(2 * pi * moved$t), `+`)
      # a real pair: the same model with its bias variances held small
      after <- suppressWarnings(calibrate(ex$emulators, ex$field, ex$iu, chains = 2, seed = 1,
                                          bias = bias_control(fix_tau2 = 1e-4),
                                          sampler = sampler_control(n_draws = 200, n_inner = 20, quiet = TRUE)))
      cmp <- compare_validations(fit, after, holdout = experiment(moved, change = c(x1 = 0.2)), n_boot = 100, seed = 1)
      report_cmp <<- cmp
      out <- withr::local_tempfile(fileext = ".html")
      suppressWarnings(validation_report(fit, file = out, comparison = cmp, quiet = TRUE))
      text <<- iconv(gsub("\\s+", " ", paste(readLines(out, warn = FALSE), collapse = " ")), "UTF-8", "ASCII", sub = "?")
    }
    text
  }
})

# The text of the page between two strings (the first occurrence of each).
between <- function(x, from, to) {
  i <- regexpr(from, x, fixed = TRUE)
  j <- regexpr(to, substring(x, i, nchar(x)), fixed = TRUE)
  substr(x, i, i + j - 2L)
}

test_that("the report opens with a verdict that names the top finding in a sentence", {
  skip_if_not(rmarkdown::pandoc_available())
  html <- report_text()
  fit <- example_fit()
  at <- function(s) regexpr(s, html, fixed = TRUE)[[1]]
  expect_gt(at("id=\"verdict\""), 0)
  # the verdict is the first section: before the inputs, the findings and the print
  expect_lt(at("id=\"verdict\""), at("Inputs</h2>"))
  expect_lt(at("id=\"verdict\""), at("Where the model fails</h2>"))
  expect_lt(at("id=\"verdict\""), at("&lt;wv_fit&gt;"))
  verdict <- between(html, "id=\"verdict\"", "Inputs</h2>")
  lead <- sub("^Top finding \\(1 of [0-9]+\\), ", "", top_finding(where_fails(fit)))
  expect_true(grepl(html_escape(lead), verdict, fixed = TRUE))
  expect_true(grepl("Not shown adequate", verdict, fixed = TRUE))
  expect_true(grepl("Inputs in conflict with their prior: none", verdict, fixed = TRUE))
  # the assumptions that change the answer, with the noise's source
  expect_true(grepl("Assumptions that change the answer", verdict, fixed = TRUE))
  expect_true(grepl("from 4 replicates", verdict, fixed = TRUE))
  expect_true(grepl("Bias prior: one variance per group", verdict, fixed = TRUE))
})

test_that("the report's inputs, findings and comparison are HTML tables, not console prints", {
  skip_if_not(rmarkdown::pandoc_available())
  html <- report_text()
  inputs <- between(html, "Inputs</h2>", "</table>")
  expect_true(grepl("<table", inputs, fixed = TRUE))
  expect_true(grepl("sd_ratio", inputs, fixed = TRUE))
  expect_false(grepl("<pre", inputs, fixed = TRUE))
  expect_match(html, "<table[^>]*>\\s*<caption>\\s*Findings ranked by size")
  expect_match(html, "<table[^>]*>\\s*<caption>\\s*After / before of the held-out RMSE")
  expect_match(html, "<table[^>]*>\\s*<caption>\\s*Metrics before and after")
  # no console print outside the folded appendix
  body <- sub("<details>.*", "", html)
  expect_false(grepl("<pre", body, fixed = TRUE))
})

test_that("with a comparison the verdict gives its verdict word and both held-out ratios", {
  skip_if_not(rmarkdown::pandoc_available())
  html <- report_text()
  verdict <- between(html, "id=\"verdict\"", "Inputs</h2>")
  # the comparison's own numbers, each in its place
  hr <- attr(report_cmp, "holdout_ratio")
  f <- function(z) format(round(z, 2), nsmall = 2)
  expect_false(isTRUE(all.equal(hr$ratio, c(1, 1))))
  expect_true(grepl(sprintf("verdict [^a-z]{1,3}%s[^a-z]{1,3};", attr(report_cmp, "verdict")), verdict))
  expect_true(grepl(sprintf("the model alone errs %s times as much as before (90%% interval %s to %s)",
                            f(hr$ratio[1]), f(hr$lower[1]), f(hr$upper[1])), verdict, fixed = TRUE))
  expect_true(grepl(sprintf("the bias-corrected prediction %s times (%s to %s)", f(hr$ratio[2]), f(hr$lower[2]),
                            f(hr$upper[2])), verdict, fixed = TRUE))
  # and the metrics' table of both fits
  tab <- between(html, "Before and after the model change</h2>", "Appendix")
  m <- stats::setNames(report_cmp$after, report_cmp$metric)
  expect_true(grepl(format(signif(m[["holdout_rmse_model"]], 3)), tab, fixed = TRUE))
  # two figures after the comparison's tables: the bias before and after, and the held-out error
  compared <- between(html, "Before and after the model change</h2>", "Appendix")
  expect_identical(lengths(regmatches(compared, gregexpr("<img", compared, fixed = TRUE))), 2L)
})

test_that("the console print of the fit is kept, folded in a details element at the end", {
  skip_if_not(rmarkdown::pandoc_available())
  html <- report_text()
  folded <- between(html, "<details>", "</details>")
  expect_true(grepl("&lt;wv_fit&gt; 1 site (site1)", folded, fixed = TRUE))
  expect_true(grepl("Acceptance by chain", folded, fixed = TRUE))
  expect_false(grepl("Acceptance by chain", sub("<details>.*", "", html), fixed = TRUE))
})

test_that("the verdict judges the model against the tolerance and names the top candidate", {
  fit <- example_fit()
  t <- fit$field$t
  wide <- where_fails(fit, tolerance = 1)
  v <- report_verdict(fit, wide, 1)
  expect_match(v[1], "Adequate for the tolerance 1", fixed = TRUE)
  tight <- where_fails(fit, tolerance = 0.001)
  v <- report_verdict(fit, tight, 0.001)
  expect_match(v[1], sprintf("Not adequate for the tolerance 0.001**: %d finding", nrow(tight)), fixed = TRUE)
  expl <- structure(data.frame(candidate = "bump_early", inclusion_prob = 0.93, share_explained = 0.6),
                    class = c("wv_explain", "data.frame"))
  v <- report_verdict(fit, tight, 0.001, expl = expl)
  expect_true(any(grepl("most probable candidate is **bump_early**, inclusion probability 0.93", v, fixed = TRUE)))
})

test_that("the verdict never says adequate while another reading of the fit disagrees", {
  fit <- example_fit()
  wide <- where_fails(fit, tolerance = 1)
  expect_match(report_verdict(fit, wide, 1)[1], "Adequate for the tolerance 1", fixed = TRUE)
  # a candidate the data include at probability 0.5 or more
  expl <- structure(data.frame(candidate = "bump_early", inclusion_prob = 0.95, share_explained = 0.6),
                    class = c("wv_explain", "data.frame"))
  v <- report_verdict(fit, wide, 1, expl = expl)
  expect_match(v[1], "Not shown adequate", fixed = TRUE)
  expect_match(v[1], "bump_early is included at probability 0.95", fixed = TRUE)
  expect_false(grepl("**Adequate", v[1], fixed = TRUE))
  # below one half it does not decide
  expl$inclusion_prob <- 0.4
  expect_match(report_verdict(fit, wide, 1, expl = expl)[1], "Adequate for the tolerance 1", fixed = TRUE)
  # an input piled at a bound of its range
  piled <- wide
  bd <- attr(piled, "boundary")
  bd$flagged[1] <- TRUE
  attr(piled, "boundary") <- bd
  v <- report_verdict(fit, piled, 1)
  expect_match(v[1], "Not shown adequate", fixed = TRUE)
  expect_match(v[1], paste0("the posterior of ", bd$input[1], " piles up at a bound"), fixed = TRUE)
})

test_that("a finding's figure shows the bias and its band on the finding's interval with a margin", {
  fit <- example_fit()
  fails <- where_fails(fit)
  # a misfit of the field mean against the model: the band of the point or window that rejects it,
  # beyond zero on the stretch
  m <- which(fails$kind == "misfit")[1]
  pm <- finding_figure(fails, m)
  dm <- pm$data
  on <- dm$t >= fails$start[m] & dm$t < fails$end[m]
  expect_true(all(dm$wlo[on] > 0 | dm$whi[on] < 0))
  mc <- attr(fails, "misfit")
  k <- match(dm$t, mc$t[mc$site == fails$site[m]])
  expect_equal(dm$hi - dm$lo, 2 * mc$crit[1] * mc$se[mc$site == fails$site[m]][k])
  expect_match(pm$labels$title, "misfit", fixed = TRUE)
  i <- which(fails$kind == "interval")[1]
  r <- fails[i, ]
  p <- finding_figure(fails, i)
  expect_s3_class(p, "ggplot")
  d <- p$data
  dt <- diff(fit$basis$t[1:2])
  margin <- max((r$end - r$start) / 2, 2 * dt)
  # the interval and a margin each side, not the whole record
  expect_lte(min(d$t), r$start - margin + dt)
  expect_gte(max(d$t), r$end + margin - dt)
  expect_lt(nrow(d), length(fit$basis$t))
  expect_true(all(d$site == r$site))
  # the band drawn is the table's whole-curve band: it excludes zero on the
  # interval, and nowhere in the margins
  inside <- d$t >= r$start & d$t < r$end
  expect_true(all(d$lo[inside] > 0 | d$hi[inside] < 0))
  expect_false(any(d$lo[!inside] > 0 | d$hi[!inside] < 0))
  # a finding with no place (an input not read again) has no figure
  noplace <- fails
  noplace$site[1] <- NA
  expect_null(finding_figure(noplace, 1))
})

test_that("the verdict's assumptions name the field noise's source", {
  fit <- example_fit()
  a <- report_assumptions(fit)
  expect_match(a[1], "Field noise, source: site1 estimated from 4 replicates.", fixed = TRUE)
  expect_match(a[2], "Bias prior: one variance per group of wavelet levels, 2 groups (site1:0-3, site1:4)",
               fixed = TRUE)
  expect_match(a[3], "Inputs' likelihood", fixed = TRUE)
  # a site with one replicate whose noise the posterior learned
  one <- fit
  one$n_rep$site1 <- 1L
  one$noise_setting[["site1"]] <- "learned"
  one$noise_prior <- list(family = "half-normal", scale = c(site1 = 0.05))
  a <- report_assumptions(one)
  expect_match(a[1], "site1 learned in the posterior from one replicate", fixed = TRUE)
})

test_that("with proposals the report lists the proposed term among the findings and in its own section", {
  skip_if_not(rmarkdown::pandoc_available())
  fit <- example_fit()
  pr <- propose_terms(fit, term_library(fit), n_draws = 20, seed = 1)
  # make the leading proposal a finding whatever its evidence here
  pr$inclusion_prob[1] <- 0.9
  file <- tempfile(fileext = ".html")
  validation_report(fit, file, proposals = pr)
  html <- paste(readLines(file, warn = FALSE), collapse = "\n")
  expect_true(grepl("Proposed terms</h2>", html, fixed = TRUE))
  expect_true(grepl(html_escape(pr$term[1]), html, fixed = TRUE))
  wf <- where_fails(fit, proposals = pr)
  expect_true("term" %in% wf$kind)
  expect_true(grepl(">\\s*term\\s*</td>", between(html, "Where the model fails</h2>", "Proposed terms</h2>"), perl = TRUE))
  expect_error(validation_report(example_fit(2), file, proposals = pr), class = "wavevalid_error_input")
})

test_that("from chains that did not mix, no verdict: the report and where_fails() lead with it", {
  fit <- example_fit()
  wide <- where_fails(fit, tolerance = 1)
  expect_match(report_verdict(fit, wide, 1)[1], "Adequate for the tolerance 1", fixed = TRUE)
  expect_null(attr(wide, "unmixed"))
  unmixed <- fit_set(fit, rhat = replace(fit$rhat, "u1", 1.24))
  wf <- where_fails(unmixed, tolerance = 1)
  expect_equal(attr(wf, "unmixed"), c(u1 = 1.24))
  v <- report_verdict(unmixed, wf, 1)
  expect_match(v[1], "**Not judged**: the chains did not mix (R-hat u1 1.24", fixed = TRUE)
  expect_false(any(grepl("Adequate", v, fixed = TRUE)))
  out <- capture.output(print(wf))
  expect_match(out[1], "The chains did not mix (R-hat u1 1.24, above 1.1)", fixed = TRUE)
})
