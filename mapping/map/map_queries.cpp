/// Planner queries of the global map: nearest cell, ground under a point, height map.
#include <cmath>
#include <limits>
#include <numbers>
#include <set>

#include "core/error.hpp"
#include "mapping/map/global_map.hpp"
#include "mapping/map/polygon2.hpp"

namespace planecell::map {
namespace bg = boost::geometry;
namespace {

/// Horizontal axes (a, b) ⟂ up: a = world x made orthogonal to up (world z when up ∥ x), b = up × a.
/// For up = (0, −1, 0): a = (1, 0, 0), b = (0, 0, 1).
std::pair<Eigen::Vector3d, Eigen::Vector3d> horizontal_axes(const Eigen::Vector3d& up) {
  Eigen::Vector3d seed = std::abs(up.x()) > 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d a = (seed - seed.dot(up) * up).normalized();
  return {a, up.cross(a)};
}

}  // namespace

std::optional<CellDistance> GlobalMap::nearest_cell(const Eigen::Vector3d& point,
                                                    double max_distance_m) const {
  if (!point.allFinite()) throw InputError("nearest_cell: query point is not finite");
  // Grow the search box until it holds a hit no farther than its half-size (or reaches the max).
  for (double radius = std::min(config_.index_cell_m, max_distance_m);; radius *= 2.0) {
    radius = std::min(radius, max_distance_m);
    Aabb box;
    box.extend(point);
    std::optional<CellDistance> best;
    for (std::uint32_t id : query_cells(box.inflated(radius))) {
      const MapCell& c = cells_.at(id);
      const double d = distance_to_polygon(point, c.plane, c.vertices_m);
      if (d <= max_distance_m && (!best || d < best->distance_m)) best = CellDistance{id, d};
    }
    if ((best && best->distance_m <= radius) || radius >= max_distance_m) return best;
  }
}

std::optional<GroundHit> GlobalMap::ground_under(const Eigen::Vector3d& point,
                                                 double max_drop_m) const {
  if (!point.allFinite()) throw InputError("ground_under: query point is not finite");
  Aabb column;
  column.extend(point);
  column.extend(point - max_drop_m * up_);
  const double min_cos = std::cos(config_.max_ground_tilt_deg * std::numbers::pi / 180.0);
  const auto [axis_a, axis_b] = horizontal_axes(up_);
  const Eigen::Vector2d point_ab(point.dot(axis_a), point.dot(axis_b));
  std::optional<GroundHit> best;
  std::vector<Eigen::Vector2d> ring;
  for (std::uint32_t id : query_cells(column.inflated(1e-6))) {
    const MapCell& cell = cells_.at(id);
    const Surface& s = surfaces_.at(cell.surface);
    const double n_up = s.plane.normal().dot(up_);
    if (std::abs(n_up) < min_cos) continue;
    // Vertical line X = p − h·up meets the surface's plane where n·p − h·(n·up) + e = 0.
    const double h = s.plane.signed_distance(point) / n_up;
    if (h < 0.0 || h > max_drop_m || (best && h >= best->height_above_m)) continue;
    // The vertical line passes through the cell: the point inside its polygon seen along up.
    ring.clear();
    for (const auto& v : cell.vertices_m) ring.emplace_back(v.cast<double>().dot(axis_a), v.cast<double>().dot(axis_b));
    if (!point_in_ring(ring, point_ab)) continue;
    best = GroundHit{cell.surface, h, point - h * up_};
  }
  return best;
}

HeightMap GlobalMap::height_map(const Eigen::Vector2d& origin_ab, int cols, int rows,
                                double resolution_m) const {
  if (cols <= 0 || rows <= 0 || !(resolution_m > 0.0))
    throw InputError("height_map: grid size and resolution must be positive (cols " +
                     std::to_string(cols) + ", rows " + std::to_string(rows) + ", resolution " +
                     std::to_string(resolution_m) + " m)");
  HeightMap out;
  std::tie(out.axis_a, out.axis_b) = horizontal_axes(up_);
  out.origin_ab = origin_ab;
  out.resolution_m = resolution_m;
  out.height_m = cv::Mat(rows, cols, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
  if (cells_.empty()) return out;

  // Region box in 3D: the grid rectangle swept over the map's height range.
  double h_min = std::numeric_limits<double>::infinity(), h_max = -h_min;
  for (const auto& [id, s] : surfaces_) {
    const Aabb box = s.bounds;
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d c((corner & 1) ? box.max.x() : box.min.x(), (corner & 2) ? box.max.y() : box.min.y(),
                              (corner & 4) ? box.max.z() : box.min.z());
      h_min = std::min(h_min, c.dot(up_));
      h_max = std::max(h_max, c.dot(up_));
    }
  }
  Aabb region;
  for (int corner = 0; corner < 8; ++corner) {
    const double a = origin_ab.x() + ((corner & 1) ? cols * resolution_m : 0.0);
    const double b = origin_ab.y() + ((corner & 2) ? rows * resolution_m : 0.0);
    const double h = (corner & 4) ? h_max : h_min;
    region.extend(a * out.axis_a + b * out.axis_b + h * up_);
  }

  auto raise = [&](int col, int row, double height) {
    if (col < 0 || row < 0 || col >= cols || row >= rows) return;
    float& cell = out.height_m.at<float>(row, col);
    if (std::isnan(cell) || height > cell) cell = static_cast<float>(height);
  };
  for (std::uint32_t id : query_cells(region)) {
    const MapCell& c = cells_.at(id);
    // The polygon in grid coordinates (a, b), and its extent in grid squares.
    Polygon2 poly;
    double a_lo = std::numeric_limits<double>::infinity(), a_hi = -a_lo, b_lo = a_lo, b_hi = -a_lo;
    for (const auto& v : c.vertices_m) {
      const double a = v.cast<double>().dot(out.axis_a), b = v.cast<double>().dot(out.axis_b);
      bg::append(poly.outer(), Point2(a, b));
      a_lo = std::min(a_lo, a), a_hi = std::max(a_hi, a), b_lo = std::min(b_lo, b), b_hi = std::max(b_hi, b);
    }
    bg::correct(poly);
    const double n_up = c.plane.normal().dot(up_);
    if (std::abs(n_up) > 0.2) {
      // Sloped cell: its plane's height at each covered square centre, X = a·â + b·b̂ + h·up.
      const int c0 = static_cast<int>(std::floor((a_lo - origin_ab.x()) / resolution_m));
      const int c1 = static_cast<int>(std::floor((a_hi - origin_ab.x()) / resolution_m));
      const int r0 = static_cast<int>(std::floor((b_lo - origin_ab.y()) / resolution_m));
      const int r1 = static_cast<int>(std::floor((b_hi - origin_ab.y()) / resolution_m));
      for (int row = std::max(r0, 0); row <= std::min(r1, rows - 1); ++row)
        for (int col = std::max(c0, 0); col <= std::min(c1, cols - 1); ++col) {
          const double a = origin_ab.x() + (col + 0.5) * resolution_m;
          const double b = origin_ab.y() + (row + 0.5) * resolution_m;
          if (!bg::covered_by(Point2(a, b), poly)) continue;
          const Eigen::Vector3d g = a * out.axis_a + b * out.axis_b;
          raise(col, row, -c.plane.signed_distance(g) / n_up);
        }
    } else {
      // Near-vertical cell: sample its edges every half square.
      for (std::size_t k = 0; k < c.vertices_m.size(); ++k) {
        const Eigen::Vector3d p = c.vertices_m[k].cast<double>();
        const Eigen::Vector3d q = c.vertices_m[(k + 1) % c.vertices_m.size()].cast<double>();
        const int steps = 1 + static_cast<int>((q - p).norm() / (0.5 * resolution_m));
        for (int i = 0; i <= steps; ++i) {
          const Eigen::Vector3d x = p + (q - p) * (static_cast<double>(i) / steps);
          raise(static_cast<int>(std::floor((x.dot(out.axis_a) - origin_ab.x()) / resolution_m)),
                static_cast<int>(std::floor((x.dot(out.axis_b) - origin_ab.y()) / resolution_m)),
                x.dot(up_));
        }
      }
    }
  }
  return out;
}

}  // namespace planecell::map
