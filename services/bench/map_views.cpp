#include "services/bench/map_views.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/error.hpp"
#include "services/bench/plot.hpp"
#include "services/render/cell_colours.hpp"

namespace planecell::services::bench {
namespace {

constexpr int kViewLeft = 96, kViewTop = 52, kViewBottom = 72, kViewRight = 28, kColourBar = 120;

/// A cell reduced to what the view needs.
struct DrawnCell {
  std::vector<cv::Point2d> ab;  ///< vertices in (a, b) (m)
  double mean_height_m = 0.0;
  double max_height_m = 0.0;
  std::uint32_t surface = kNoSurface;
};

double percentile(std::vector<double> values, double p) {
  std::sort(values.begin(), values.end());
  const auto index =
      static_cast<std::size_t>(std::lround(p / 100.0 * static_cast<double>(values.size() - 1)));
  return values[std::min(index, values.size() - 1)];
}

cv::Vec3b turbo(double t) {
  cv::Mat grey(1, 1, CV_8UC1, cv::Scalar(std::clamp(t, 0.0, 1.0) * 255.0)), colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  return colour.at<cv::Vec3b>(0, 0);
}

void draw_colour_bar(cv::Mat& image, const cv::Rect& plot, double lo, double hi) {
  const cv::Rect bar(plot.x + plot.width + 30, plot.y, 22, plot.height);
  for (int row = 0; row < bar.height; ++row) {
    const double t = 1.0 - static_cast<double>(row) / std::max(bar.height - 1, 1);
    const cv::Vec3b c = turbo(t);
    cv::line(image, {bar.x, bar.y + row}, {bar.x + bar.width - 1, bar.y + row},
             cv::Scalar(c[0], c[1], c[2]));
  }
  cv::rectangle(image, bar, cv::Scalar(0, 0, 0), 1);
  const Axis axis = linear_axis(lo, hi, "height (m)");
  const auto ticks = nice_ticks(axis, 5);
  for (double v : ticks) {
    const int y = bar.y + bar.height - 1 -
                  static_cast<int>(std::lround((v - lo) / (hi - lo) * (bar.height - 1)));
    cv::line(image, {bar.x + bar.width, y}, {bar.x + bar.width + 5, y}, cv::Scalar(0, 0, 0));
    draw_text(image, tick_label(axis, v, ticks), {bar.x + bar.width + 8, y + 5}, 0.45,
              cv::Scalar(0, 0, 0));
  }
  draw_vertical_text(image, "height (m)", {bar.x + bar.width + 62, bar.y + bar.height / 2}, 0.55);
}

/// The view's horizontal axes and the cells projected onto them.
struct Layout {
  Eigen::Vector3d up, a, b;
  std::vector<DrawnCell> drawn;                       ///< sorted lowest first
  double a_min = 0, a_max = 0, b_min = 0, b_max = 0;  ///< the view's extent (m)
  int plot_w = 0, plot_h = 0;
};

Layout make_layout(std::span<const map::MapCell> cells, const TopViewOptions& options) {
  if (!(options.up.norm() > 0.0)) throw ConfigError("top view: the up vector is zero");
  Layout l;
  l.up = options.up.normalized();
  // a = x made ⟂ up (z when x is parallel to up), b = up × a.
  l.a = Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(l.up) * l.up;
  if (l.a.norm() < 1e-6) l.a = Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ().dot(l.up) * l.up;
  l.a.normalize();
  l.b = l.up.cross(l.a);
  l.drawn.reserve(cells.size());
  for (const map::MapCell& cell : cells) {
    if (cell.vertices_m.empty()) continue;
    DrawnCell d;
    d.surface = cell.surface;
    d.max_height_m = -INFINITY;
    for (const auto& v : cell.vertices_m) {
      const Eigen::Vector3d x = v.cast<double>();
      const cv::Point2d p(l.a.dot(x), l.b.dot(x));
      d.ab.push_back(p);
      const double h = l.up.dot(x);
      d.mean_height_m += h;
      d.max_height_m = std::max(d.max_height_m, h);
    }
    d.mean_height_m /= static_cast<double>(cell.vertices_m.size());
    l.drawn.push_back(std::move(d));
  }
  if (l.drawn.empty()) throw InputError("top view: the map has no cell with vertices to draw");
  std::sort(l.drawn.begin(), l.drawn.end(),
            [](const DrawnCell& p, const DrawnCell& q) { return p.max_height_m < q.max_height_m; });
  // The view spans the 1st–99th percentile of the vertices: a few long cells far away (grazing
  // planes) would otherwise shrink everything else; they are clipped at the edge.
  std::vector<double> as, bs;
  for (const auto& d : l.drawn)
    for (const auto& p : d.ab) as.push_back(p.x), bs.push_back(p.y);
  l.a_min = percentile(as, 1.0), l.a_max = percentile(as, 99.0);
  l.b_min = percentile(bs, 1.0), l.b_max = percentile(bs, 99.0);
  // Equal scale on both axes: the longer extent gets max_plot_px pixels (at least 1 m shown).
  const double pad = 0.05 * std::max({l.a_max - l.a_min, l.b_max - l.b_min, 1.0});
  l.a_min -= pad, l.a_max += pad, l.b_min -= pad, l.b_max += pad;
  const double extent = std::max(l.a_max - l.a_min, l.b_max - l.b_min);
  const double px_per_m = static_cast<double>(std::max(options.max_plot_px, 100)) / extent;
  l.plot_w = std::max(480, static_cast<int>(std::lround((l.a_max - l.a_min) * px_per_m)));
  l.plot_h = std::max(240, static_cast<int>(std::lround((l.b_max - l.b_min) * px_per_m)));
  // Pixel centres of the first and last column are a_min and a_max (PlotArea maps onto
  // width − 1 pixels): keep the scale equal when a minimum size stretched one side.
  l.a_max = l.a_min + (l.plot_w - 1) / px_per_m;
  l.b_max = l.b_min + (l.plot_h - 1) / px_per_m;
  return l;
}

PlotArea layout_area(const Layout& l) {
  const bool y_up = std::abs(std::abs(l.up.y()) - 1.0) < 1e-6;
  const Axis ax = linear_axis(l.a_min, l.a_max, y_up ? "x (m)" : "a (m), x made horizontal");
  const Axis bx = linear_axis(l.b_min, l.b_max, y_up ? "z (m), forward" : "b (m) = up x a");
  return PlotArea(cv::Rect(kViewLeft, kViewTop, l.plot_w, l.plot_h), ax, bx);
}

}  // namespace

PlotArea top_view_area(std::span<const map::MapCell> cells, const TopViewOptions& options) {
  return layout_area(make_layout(cells, options));
}

cv::Mat render_top_view(std::span<const map::MapCell> cells, const TopViewOptions& options) {
  const Layout layout = make_layout(cells, options);
  const PlotArea area = layout_area(layout);
  const bool height = options.colour == TopViewColour::kHeight;
  const cv::Size size(kViewLeft + layout.plot_w + kViewRight + (height ? kColourBar : 0),
                      kViewTop + layout.plot_h + kViewBottom);
  cv::Mat image(size, CV_8UC3, cv::Scalar(255, 255, 255));

  double lo = 0.0, hi = 1.0;
  if (height) {
    std::vector<double> heights;
    for (const auto& d : layout.drawn) heights.push_back(d.mean_height_m);
    lo = percentile(heights, 2.0);
    hi = percentile(heights, 98.0);
    if (hi - lo < 0.1) hi = lo + 0.1;
  }
  cv::Mat inside = image(area.rect());
  constexpr int kShift = 3;
  for (const auto& d : layout.drawn) {
    std::vector<cv::Point> polygon;
    for (const auto& p : d.ab) {
      const cv::Point2d q = area.to_pixel(p.x, p.y) - cv::Point2d(area.rect().tl());
      polygon.emplace_back(static_cast<int>(std::lround(q.x * (1 << kShift))),
                           static_cast<int>(std::lround(q.y * (1 << kShift))));
    }
    const cv::Vec3b c =
        height ? turbo((d.mean_height_m - lo) / (hi - lo)) : render::surface_colour_bgr(d.surface);
    const cv::Scalar colour(c[0], c[1], c[2]);
    const std::vector<std::vector<cv::Point>> polygons{polygon};
    cv::fillPoly(inside, polygons, colour, cv::LINE_AA, kShift);
    cv::polylines(inside, polygons, true, colour, 1, cv::LINE_AA, kShift);
  }
  draw_axes(image, area, options.title, /*grid=*/false);
  if (height) draw_colour_bar(image, area.rect(), lo, hi);
  return image;
}

}  // namespace planecell::services::bench
