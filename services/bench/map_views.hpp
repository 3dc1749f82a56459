#pragma once
/// Top-down pictures of a planecell map (the paper's last figures: the map coloured by height
/// and by CRF surface label), read only through each cell's world polygon, surface and colour.
#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <span>
#include <string>

#include "mapping/map/map_cell.hpp"
#include "services/bench/plot.hpp"

namespace planecell::services::bench {

enum class TopViewColour {
  kHeight,   ///< height of the cell above the lowest cells (colour bar in metres)
  kSurface,  ///< one colour per CRF surface label (render::surface_colour_bgr)
};

struct TopViewOptions {
  Eigen::Vector3d up{0.0, -1.0, 0.0};  ///< world "up" (KITTI camera convention: y down)
  TopViewColour colour = TopViewColour::kHeight;
  std::string title;
  int max_plot_px = 900;  ///< the longer side of the plot area (the image adds margins)
};

/// Orthographic view from above, looking along −up. With a = the world x axis made ⟂ up and
/// b = up × a (for up = (0, −1, 0): a = x, b = z, the direction of travel), a point X is drawn at
/// (a·X, b·X) on equal-scale axes with metre ticks, b growing upwards. Each cell is a filled
/// polygon of its world vertices (outlined, so vertical walls show as lines), drawn lowest first
/// (by the maximum height up·X of its vertices) so that higher cells cover lower ones. Height
/// colours run over the 2nd–98th percentile of the cells' mean heights (TURBO map, colour bar).
/// Cells without vertices are skipped. Throws InputError when no cell has a vertex, ConfigError
/// on a zero up vector.
cv::Mat render_top_view(std::span<const map::MapCell> cells, const TopViewOptions& options);

/// The plot area render_top_view draws `cells` into: x axis = a (m), y axis = b (m), equal
/// scale. A world point X lands at area.to_pixel(a·X, b·X). Same errors as render_top_view.
PlotArea top_view_area(std::span<const map::MapCell> cells, const TopViewOptions& options);

}  // namespace planecell::services::bench
