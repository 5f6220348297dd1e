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
  # the report leads with the largest finding, as the print does
  lead <- sub(",.*", "", top_finding(fit))
  first <- grep("Top finding|No finding", html)
  expect_true(length(first) > 0L && any(grepl(lead, html[first[1]], fixed = TRUE)))
  expect_lt(first[1], grep("The fit</h2>", html, fixed = TRUE)[1])
})
