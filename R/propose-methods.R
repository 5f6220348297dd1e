# print, autoplot and the conversion to candidates of the wv_proposals table
# of propose_terms().

#' @export
print.wv_proposals <- function(x, ...) {
  nt <- attr(x, "n_terms")
  cli::cat_line(sprintf("<wv_proposals> %d families (%d terms) ranked by posterior inclusion probability",
                        nt[["families"]], nt[["terms"]]))
  top <- x[x$inclusion_prob >= 0.01, , drop = FALSE]
  if (!nrow(top)) top <- x[seq_len(min(3L, nrow(x))), , drop = FALSE]
  top <- utils::head(top, 8L)
  df <- data.frame(term = top$term, inclusion = signif(top$inclusion_prob, 2),
                   strength = signif(top$strength, 3),
                   interval = sprintf("[%s, %s]", signif(top$strength_lower, 3),
                                      signif(top$strength_upper, 3)),
                   share = signif(top$share_of_bias, 2),
                   acts = sprintf("%s [%s, %s]", top$site, signif(top$from, 4), signif(top$to, 4)))
  print(df, row.names = FALSE)
  labels <- attr(x, "labels")
  named <- top$term[!is.na(labels[top$term]) & labels[top$term] != top$term]
  for (tm in named) cli::cat_line("  ", tm, ": ", labels[[tm]])
  lead <- x[1, ]
  if (lead$inclusion_prob >= 0.5) {
    what <- if (lead$term %in% named) sprintf("%s (%s)", lead$term, labels[[lead$term]]) else lead$term
    cli::cat_line(sprintf("Proposed: %s (inclusion %.2f), acting most at %s [%s, %s].", what,
                          lead$inclusion_prob, lead$site, signif(lead$from, 4), signif(lead$to, 4)))
  } else {
    cli::cat_line(sprintf("No term proposed: none reaches inclusion 0.5 (probability of no term %.2f).",
                          attr(x, "none")))
  }
  eq <- attr(x, "equivalent")
  eq <- eq[eq$same_as %in% utils::head(x$term[x$inclusion_prob >= 0.1], 3L), , drop = FALSE]
  for (k in unique(eq$same_as)) {
    cli::cat_line("The data cannot tell ", k, " from: ",
                  paste(eq$term[eq$same_as == k], collapse = ", "), ".")
  }
  from <- attr(x, "effects_from")
  cli::cat_line(if (identical(from, "simulated")) {
    paste0("Effects: output terms act on the output as they are; state terms through the simulated ",
           "equations", if (isTRUE(attr(x, "memory"))) {
             paste0(", but terms with memory (filters, delays, integrals) and products act on the ",
                    "output as they are (`simulate` takes a function of a state's value, not of its ",
                    "history)")
           }, ".")
  } else {
    paste0("Effects: each term's curve taken as its effect on the output (a state term acting through the ",
           "equations can differ: give `simulate`).")
  })
  cli::cat_line("In every model, never proposed: ", paste(attr(x, "nuisance"), collapse = "; "),
                ".")
  eta <- attr(x, "eta")
  if (!is.null(eta) && stats::median(eta) < 0.995) {
    cli::cat_line(sprintf(paste0("Evidence tempered by the jackknife over time segments: eta = %.2f ",
                                 "(median over terms and draws)."), stats::median(eta)))
  }
  invisible(x)
}

#' @rdname propose_terms
#' @param object A `wv_proposals` table.
#' @export
autoplot.wv_proposals <- function(object, ...) {
  check_dots_none(...)
  cur <- attr(object, "curves")
  ggplot2::ggplot(cur, ggplot2::aes(x = .data$t, y = .data$value, colour = .data$curve)) +
    ggplot2::geom_line() +
    ggplot2::facet_wrap(~site, ncol = 1, scales = "free_y") +
    ggplot2::labs(x = "t", y = "bias", colour = NULL,
                  title = "Posterior mean bias and the leading proposed terms") +
    ggplot2::theme_minimal() + ggplot2::theme(legend.position = "bottom")
}

#' Proposed terms as candidates
#'
#' Turns the leading proposals of [propose_terms()] into candidate curves for
#' [explain_bias()] (each its effect on the output, by site), so that a
#' proposal can be weighed beside the user's own candidates, or gives the
#' function of one proposal for the simulator.
#'
#' @param x A `wv_proposals` table.
#' @param n The number of leading proposals.
#' @param fit The `wv_fit` the proposals were made on.
#' @return A named list of candidates (each a list of curves by site).
#' @export
#' @examples
#' fit <- example_fit()
#' pr <- propose_terms(fit, term_library(fit), seed = 1)
#' cand <- proposed_candidates(pr, fit, n = 2)
#' explain_bias(fit, cand, positive = FALSE, seed = 1)
proposed_candidates <- function(x, fit, n = 3L) {
  check_class(x, "wv_proposals")
  check_class(fit, "wv_fit")
  check_number(n, min = 1, integer = TRUE)
  check_proposals_of(x, fit)
  sig <- attr(x, "signatures")
  sites <- fit_sites(fit)
  nc <- vapply(fit_get(fit, "wb"), ncol, 1L)
  offs <- c(0L, cumsum(nc))
  k <- seq_len(min(n, nrow(x)))
  out <- lapply(x$term[k], function(tm) {
    stats::setNames(lapply(seq_along(sites), function(i) {
      drop(fit_get(fit, "basis")$Psi %*% sig[(offs[i] + 1L):offs[i + 1L], tm])
    }), sites)
  })
  stats::setNames(out, x$term[k])
}

# Aborts unless the proposals `x` were made on `fit` (its sites, grid and
# retained coefficients).
check_proposals_of <- function(x, fit, call = rlang::caller_env()) {
  check_class(x, "wv_proposals", arg = "proposals", call = call)
  made <- attr(x, "made_on")
  if (!identical(made, proposal_fingerprint(fit))) {
    wv_abort(c("The proposals were not made on this fit.",
               "i" = "Run {.code propose_terms(fit, term_library(fit))} on it."), call = call)
  }
  invisible(x)
}

proposal_fingerprint <- function(fit) {
  list(sites = fit_sites(fit), n = vapply(fit_get(fit, "wb"), ncol, 1L),
       t = range(fit_get(fit, "basis")$t),
       draws = nrow(fit_get(fit, "wb")[[1]]), wbar = vapply(fit_get(fit, "wbar"), sum, numeric(1)))
}
