# The suspension test bed's storage as CSV files (load_testbed()), its time
# grid and event windows.

# --- CSV storage ---------------------------------------------------------------

testbed_files <- function() {
  c("testbed_iu.csv", "testbed_design.csv.xz", "testbed_runs.csv.xz", "testbed_field.csv.xz",
    "testbed_reality.csv.xz", "testbed_truth.csv", "testbed_warps.csv")
}

# Writes a test bed as CSV files in `dir` (curves rounded to `digits`
# significant digits). Used by data-raw/make-testbed.R. The curves are stored
# wide, one row per curve: its keys (condition, run or replicate, site), then
# its values at the grid points, columns y1..yT for testbed_grid(); xz
# compresses this layout much better than one row per value.
write_testbed <- function(tb, dir, digits = 6L) {
  dir.create(dir, showWarnings = FALSE, recursive = TRUE)
  conds <- c("A", "B", "added_mass")
  wide <- function(curves, id_name, condition) {
    do.call(rbind, lapply(names(curves), function(s) {
      m <- curves[[s]]
      keys <- data.frame(condition = rep(condition, nrow(m)), id = seq_len(nrow(m)), site = s,
                         stringsAsFactors = FALSE)
      names(keys)[2] <- id_name
      y <- as.data.frame(unname(m))
      names(y) <- paste0("y", seq_len(ncol(m)))
      cbind(keys, y)
    }))
  }
  write_xz <- function(d, file) {
    y <- grepl("^y[0-9]+$", names(d))
    d[y] <- lapply(d[y], signif, digits)
    con <- xzfile(file.path(dir, file), "w", compression = 9)
    on.exit(close(con))
    utils::write.csv(d, con, row.names = FALSE)
  }
  utils::write.csv(as.data.frame(tb$iu), file.path(dir, "testbed_iu.csv"), row.names = FALSE)
  design <- do.call(rbind, lapply(conds, function(cd) {
    cbind(condition = cd, run = seq_len(nrow(tb[[cd]]$runs$design)), tb[[cd]]$runs$design)
  }))
  write_xz(design, "testbed_design.csv.xz")
  write_xz(do.call(rbind, lapply(conds, function(cd) wide(tb[[cd]]$runs$curves, "run", cd))),
           "testbed_runs.csv.xz")
  write_xz(do.call(rbind, lapply(conds, function(cd) wide(tb[[cd]]$field$curves, "replicate", cd))),
           "testbed_field.csv.xz")
  real <- list(A = tb$truth$reality, B = tb$truth$reality_B,
               added_mass = tb$truth$reality_added_mass)
  real_wide <- do.call(rbind, lapply(conds, function(cd) {
    wide(lapply(real[[cd]], function(y) matrix(y, nrow = 1L)), "replicate", cd)
  }))
  write_xz(real_wide[names(real_wide) != "replicate"], "testbed_reality.csv.xz")
  tr <- tb$truth
  vec <- function(what, v) data.frame(what = what, name = names(v), value = unname(v))
  truth <- rbind(vec("u", tr$u), vec("delta", tr$delta), vec("delta_B", tr$delta_B),
                 vec("x_nom_B", tr$x_nom_B), vec("added_mass", tb$added_mass$delta),
                 data.frame(what = "seed", name = "seed", value = tr$seed),
                 data.frame(what = "hidden", name = tr$hidden, value = 1))
  utils::write.csv(truth, file.path(dir, "testbed_truth.csv"), row.names = FALSE)
  utils::write.csv(tr$warps, file.path(dir, "testbed_warps.csv"), row.names = FALSE)
  invisible(file.path(dir, testbed_files()))
}

read_testbed <- function(dir) {
  rd <- function(f, classes = NA) {
    utils::read.csv(file.path(dir, f), stringsAsFactors = FALSE, colClasses = classes)
  }
  t <- testbed_grid()
  # curves: keys, then the values at the grid points
  rd_curves <- function(f, keys) {
    cols <- c(keys, paste0("y", seq_along(t)))
    found <- names(utils::read.csv(file.path(dir, f), nrows = 1L, check.names = FALSE))
    if (!identical(found, cols)) {
      wv_abort(c(
        "{.file {f}} in {.path {dir}} does not hold test bed curves.",
        "i" = "Expected one row per curve: {.field {keys}}, then the values at the {length(t)} grid points ({.field y1} to {.field y{length(t)}})."
      ), call = NULL)
    }
    rd(f,
       c(ifelse(keys %in% c("run", "replicate"), "integer", "character"),
         rep("numeric", length(t))))
  }
  iu_df <- rd("testbed_iu.csv")
  iu <- iu_map(iu_df$name, iu_df$type, iu_df$lower, iu_df$upper, iu_df$nominal,
               ifelse(is.na(iu_df$prior_sd), 1, iu_df$prior_sd))
  design <- rd("testbed_design.csv.xz")
  runs <- rd_curves("testbed_runs.csv.xz", c("condition", "run", "site"))
  field <- rd_curves("testbed_field.csv.xz", c("condition", "replicate", "site"))
  real <- rd_curves("testbed_reality.csv.xz", c("condition", "site"))
  truth <- rd("testbed_truth.csv")
  warps <- rd("testbed_warps.csv")
  sites <- c("site1", "site2")
  y_cols <- paste0("y", seq_along(t))
  to_curves <- function(d, id_name) {
    stats::setNames(lapply(sites, function(s) {
      ds <- d[d$site == s, ]
      m <- as.matrix(ds[order(ds[[id_name]]), y_cols, drop = FALSE])
      dimnames(m) <- NULL
      m
    }), sites)
  }
  tv <- function(what) {
    v <- truth[truth$what == what, ]
    stats::setNames(v$value, v$name)
  }
  build_cond <- function(cd, x_nom) {
    dd <- design[design$condition == cd, setdiff(names(design), c("condition", "run"))]
    rownames(dd) <- NULL
    list(runs = new_wv_runs(dd, t, to_curves(runs[runs$condition == cd, ], "run")),
         field = new_wv_field(t, to_curves(field[field$condition == cd, ], "replicate"), x_nom))
  }
  x_nom_A <- stats::setNames(iu$nominal[iu$type == "variation"], iu$name[iu$type == "variation"])
  dm <- tv("added_mass")
  x_nom_m <- x_nom_A
  x_nom_m[names(dm)] <- x_nom_m[names(dm)] + dm
  reality <- lapply(c("A", "B", "added_mass"), function(cd) {
    lapply(to_curves(cbind(real[real$condition == cd, ], replicate = 1L), "replicate"), as.numeric)
  })
  B <- build_cond("B", tv("x_nom_B"))
  B$x_nom <- tv("x_nom_B")
  am <- build_cond("added_mass", x_nom_m)
  am$delta <- dm
  rownames(warps) <- NULL
  validate_wv_testbed(new_wv_testbed(kind = "suspension", list(
    iu = iu,
    A = build_cond("A", x_nom_A),
    B = B,
    added_mass = am,
    truth = list(u = tv("u"), delta = tv("delta"), delta_B = tv("delta_B"), x_nom_B = tv("x_nom_B"),
                 reality = reality[[1]], reality_B = reality[[2]],
                 reality_added_mass = reality[[3]],
                 warps = warps, hidden = truth$name[truth$what == "hidden"],
                 seed = as.integer(tv("seed"))),
    windows = testbed_windows()
  )))
}

# --- grid and windows ---------------------------------------------------------

# The test bed's time grid and its event windows.
testbed_grid <- function() 65 * (0:4095) / 4096

testbed_windows <- function() list(c(6, 11), c(37, 41))
