# The call graph among the package's R files: file A depends on file B when a
# function defined in A names a function defined in B. Prints the circles
# (files that reach each other), then the files in layers: layer 0 calls no
# other file, layer k only files of lower layers.
#   Rscript tools/graph.R [R directory]
# Exits with status 1 when there is a circle, or two modules (a file's prefix:
# data-field.R is in "data") call each other.
dir <- if (length(commandArgs(TRUE))) commandArgs(TRUE)[1] else "R"
files <- sort(list.files(dir, pattern = "[.]R$", full.names = TRUE))
# The functions an expression calls: names in call position, and names passed
# to the functions that take a function as an argument.
higher <- c("lapply", "sapply", "vapply", "mapply", "Map", "Filter", "Reduce", "do.call", "apply", "outer",
            "future_lapply", "tapply", "match.fun", "Recall")
called <- function(e) {
  if (!is.call(e)) return(character(0))
  head <- e[[1]]
  out <- if (is.name(head)) as.character(head) else called(head)
  args <- as.list(e)[-1]
  if (is.name(head) && sub(".*::", "", as.character(head)) %in% higher) {
    out <- c(out, unlist(lapply(args, function(a) if (is.name(a)) as.character(a) else if (is.character(a)) a)))
  }
  unique(c(out, unlist(lapply(args, function(a) if (is.call(a)) called(a)))))
}
defs <- list()
bodies <- list()
sizes <- NULL
for (f in files) {
  exprs <- parse(f, keep.source = TRUE)
  refs <- attr(exprs, "srcref")
  for (i in seq_along(exprs)) {
    e <- exprs[[i]]
    if (is.call(e) && is.name(e[[1]]) && as.character(e[[1]]) %in% c("<-", "=") && is.name(e[[2]]) &&
        is.call(e[[3]]) && identical(e[[3]][[1]], as.name("function"))) {
      nm <- as.character(e[[2]])
      defs[[nm]] <- basename(f)
      bodies[[length(bodies) + 1]] <- list(file = basename(f), fun = nm, names = called(e[[3]]))
      sizes <- rbind(sizes, data.frame(fun = nm, file = basename(f), lines = refs[[i]][3] - refs[[i]][1] + 1L,
                                       args = length(e[[3]][[2]])))
    }
  }
}
edges <- unique(do.call(rbind, lapply(bodies, function(b) {
  used <- intersect(b$names, names(defs))
  to <- unique(unlist(defs[used]))
  to <- setdiff(to, b$file)
  if (length(to)) data.frame(from = b$file, to = to) else NULL
})))
nodes <- basename(files)
adj <- lapply(setNames(nodes, nodes), function(n) edges$to[edges$from == n])
# Tarjan's strongly connected components
index <- 0; stack <- character(0); idx <- c(); low <- c(); on <- c(); comps <- list()
strong <- function(v) {
  index <<- index + 1; idx[v] <<- index; low[v] <<- index; stack <<- c(stack, v); on[v] <<- TRUE
  for (w in adj[[v]]) {
    if (is.na(idx[w])) { strong(w); low[v] <<- min(low[v], low[w]) }
    else if (isTRUE(on[w])) low[v] <<- min(low[v], idx[w])
  }
  if (low[v] == idx[v]) {
    comp <- character(0)
    repeat { w <- stack[length(stack)]; stack <<- stack[-length(stack)]; on[w] <<- FALSE; comp <- c(comp, w); if (w == v) break }
    comps[[length(comps) + 1]] <<- comp
  }
}
idx <- setNames(rep(NA_real_, length(nodes)), nodes); low <- idx
for (v in nodes) if (is.na(idx[v])) strong(v)
circles <- Filter(function(cmp) length(cmp) > 1L, comps)
cat(sprintf("%d files, %d functions, %d edges between files\n", length(nodes), length(defs), nrow(edges)))
if (length(circles)) {
  cat("Circles (files that call each other):\n")
  for (cmp in circles) {
    cat("  ", paste(sort(cmp), collapse = ", "), "\n")
    sub <- edges[edges$from %in% cmp & edges$to %in% cmp, ]
    for (i in seq_len(nrow(sub))) {
      who <- vapply(Filter(function(b) b$file == sub$from[i], bodies), function(b) {
        hit <- intersect(b$names, names(defs)[unlist(defs) == sub$to[i]])
        if (length(hit)) paste0(b$fun, " -> ", paste(hit, collapse = ", ")) else ""
      }, "")
      cat("     ", sub$from[i], "->", sub$to[i], ":", paste(who[nzchar(who)], collapse = "; "), "\n")
    }
  }
} else {
  cat("No circles.\n")
}
# layers of the condensed graph
comp_of <- setNames(rep(NA_integer_, length(nodes)), nodes)
for (k in seq_along(comps)) comp_of[comps[[k]]] <- k
layer <- setNames(rep(NA_integer_, length(comps)), seq_along(comps))
get_layer <- function(k) {
  if (!is.na(layer[k])) return(layer[k])
  to <- unique(comp_of[unlist(adj[comps[[k]]])])
  to <- setdiff(to, k)
  layer[k] <<- if (length(to)) 1L + max(vapply(to, get_layer, integer(1))) else 0L
  layer[k]
}
for (k in seq_along(comps)) get_layer(k)
file_layer <- layer[comp_of]
names(file_layer) <- nodes
cat("Layers (each file calls only files of lower layers):\n")
for (l in sort(unique(file_layer), decreasing = TRUE)) {
  cat(sprintf("  %2d: %s\n", l, paste(sort(names(file_layer)[file_layer == l]), collapse = ", ")))
}
# the modules: a file's prefix (data-field.R is in "data"), and which modules each calls
module <- function(f) sub("-.*", "", sub("[.]R$", "", f))
medges <- unique(data.frame(from = module(edges$from), to = module(edges$to)))
medges <- medges[medges$from != medges$to, ]
mods <- sort(unique(module(nodes)))
cat(sprintf("Modules (%d), each with the modules it calls:\n", length(mods)))
calls_back <- FALSE
for (m in mods) {
  to <- sort(medges$to[medges$from == m])
  back <- to[vapply(to, function(o) any(medges$from == o & medges$to == m), logical(1))]
  calls_back <- calls_back || length(back) > 0L
  cat(sprintf("  %-12s %s%s\n", m, paste(to, collapse = ", "),
              if (length(back)) paste0("   (calls back: ", paste(back, collapse = ", "), ")") else ""))
}
cat("Largest functions (lines):\n")
top <- sizes[order(-sizes$lines), ][1:5, ]
cat(sprintf("  %-28s %-22s %4d\n", top$fun, top$file, top$lines), sep = "")
cat("Longest argument lists:\n")
top <- sizes[order(-sizes$args), ][1:5, ]
cat(sprintf("  %-28s %-22s %4d\n", top$fun, top$file, top$args), sep = "")
quit(status = if (length(circles) || calls_back) 1L else 0L)
