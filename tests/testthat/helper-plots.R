# What a ggplot draws, read from the built plot (ggplot2::ggplot_build()):
# `geoms` the class of each layer's geom in order, `data` each layer's built
# data, `labels` the plot's labels, `panels` the number of facets.
plot_drawn <- function(p) {
  b <- ggplot2::ggplot_build(p)
  list(geoms = vapply(p$layers, function(l) class(l$geom)[1], ""), data = b$data, labels = p$labels,
       panels = nrow(b$layout$layout))
}
