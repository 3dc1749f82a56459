#include "mapping/map/coverage.hpp"

#include <algorithm>
#include <boost/container/small_vector.hpp>
#include <cmath>
#include <vector>

#include "mapping/map/geometry.hpp"

namespace planecell::map {

bool nearly_coplanar(const Plane3& plane, const Plane3& vertices_plane,
                     std::span<const Eigen::Vector3f> vertices, double max_angle_deg,
                     double max_distance_m) {
  if (vertices.empty()) return false;
  const double cos_angle = std::abs(plane.normal.dot(vertices_plane.normal));
  if (cos_angle < std::cos(max_angle_deg * M_PI / 180.0)) return false;
  double sum_sq = 0.0;
  for (const auto& v : vertices) {
    const double d = plane.signed_distance(v.cast<double>());
    sum_sq += d * d;
  }
  return sum_sq <= max_distance_m * max_distance_m * static_cast<double>(vertices.size());
}

bool nearly_coplanar(const Planecell& cell, const MapCell& old, double max_angle_deg,
                     double max_distance_m) {
  return nearly_coplanar(cell.plane, old.plane, old.vertices_m.vertices(), max_angle_deg, max_distance_m);
}

CoverageGrid coverage_grid(const Plane3& plane, std::span<const Eigen::Vector3f> vertices, int samples) {
  CoverageGrid grid;
  if (vertices.size() < 3 || samples < 1) return grid;
  grid.basis = make_basis(plane, vertex_centroid(vertices));
  boost::container::small_vector<Eigen::Vector2d, 32> ring;
  for (const auto& v : vertices) ring.push_back(grid.basis.to_2d(v.cast<double>()));
  Eigen::Vector2d lo = ring.front(), hi = ring.front();
  for (const auto& p : ring) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  grid.box = Eigen::AlignedBox2d(lo, hi);
  // A square grid of about `samples` points over the cell's bounding box (centres of its squares).
  const Eigen::Vector2d size = hi - lo;
  const double area = polygon_area_m2(vertices);
  if (!(area > 0.0) || !std::isfinite(area)) return grid;
  const double step = std::max(std::sqrt(size.x() * size.y() / samples), 1e-6);
  const int nx = std::clamp(static_cast<int>(std::ceil(size.x() / step)), 1, 4 * samples);
  const int ny = std::clamp(static_cast<int>(std::ceil(size.y() / step)), 1, 4 * samples);
  boost::container::small_vector<double, 16> crossings;
  grid.points.reserve(static_cast<std::size_t>(samples) + static_cast<std::size_t>(samples) / 2);
  for (int j = 0; j < ny; ++j) {
    const double t = lo.y() + (j + 0.5) * size.y() / ny;
    // point_in_ring's even-odd rule, one grid row at a time: the row's crossings
    // (edge_crosses_row, as point_in_ring) once, then a point is inside iff an odd number of them
    // lie right of it.
    crossings.clear();
    for (std::size_t a = 0, b = ring.size() - 1; a < ring.size(); b = a++)
      if (double x = 0.0; edge_crosses_row(ring[a], ring[b], t, x)) crossings.push_back(x);
    if (crossings.empty()) continue;
    for (int i = 0; i < nx; ++i) {
      const Eigen::Vector2d st(lo.x() + (i + 0.5) * size.x() / nx, t);
      const auto right = std::count_if(crossings.begin(), crossings.end(), [&](double x) { return st.x() < x; });
      if (right % 2 == 1) grid.points.push_back(st);
    }
  }
  return grid;
}

double covered_fraction(const CoverageGrid& grid, const CoverageTest& covered, double min_fraction) {
  return covered_fraction_by(grid, [&](const Eigen::Vector2d& st) { return covered(st, grid.basis); }, min_fraction);
}

double covered_fraction(const Plane3& plane, std::span<const Eigen::Vector3f> vertices,
                        const CoverageTest& covered, int samples, double min_fraction) {
  return covered_fraction(coverage_grid(plane, vertices, samples), covered, min_fraction);
}

double covered_fraction(const Plane3& plane, std::span<const Eigen::Vector3f> vertices,
                        std::span<const std::span<const Eigen::Vector3f>> covering, int samples,
                        double min_fraction) {
  if (covering.empty() || vertices.size() < 3) return 0.0;
  return covered_fraction(coverage_grid(plane, vertices, samples), covering, min_fraction);
}

double covered_fraction(const CoverageGrid& grid, std::span<const std::span<const Eigen::Vector3f>> covering,
                        double min_fraction) {
  if (covering.empty() || grid.points.empty()) return 0.0;
  std::vector<BoxedRing> rings;  // the covering polygons whose box meets the cell's
  rings.reserve(covering.size());
  for (const auto polygon : covering) {
    if (polygon.size() < 3) continue;
    BoxedRing r(project_to_basis(polygon, grid.basis));
    if (r.box.intersects(grid.box)) rings.push_back(std::move(r));
  }
  if (rings.empty()) return 0.0;
  return covered_fraction_by(
      grid,
      [&](const Eigen::Vector2d& st) {
        return std::any_of(rings.begin(), rings.end(), [&](const BoxedRing& r) { return r.contains(st); });
      },
      min_fraction);
}

}  // namespace planecell::map
