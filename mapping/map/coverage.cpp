#include "mapping/map/coverage.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "mapping/map/geometry.hpp"

namespace planecell::map {

bool nearly_coplanar(const Planecell& cell, const Planecell& old, double max_angle_deg,
                     double max_distance_m) {
  if (old.vertices_m.empty()) return false;
  const double cos_angle = std::abs(cell.plane.normal.dot(old.plane.normal));
  if (cos_angle < std::cos(max_angle_deg * M_PI / 180.0)) return false;
  double sum_sq = 0.0;
  for (const auto& v : old.vertices_m) {
    const double d = cell.plane.normal.dot(v.cast<double>()) + cell.plane.offset;
    sum_sq += d * d;
  }
  return sum_sq <= max_distance_m * max_distance_m * static_cast<double>(old.vertices_m.size());
}

namespace {

/// Even-odd rule: is (x, y) inside the closed ring?
bool inside(const std::vector<Eigen::Vector2d>& ring, double x, double y) {
  bool in = false;
  for (std::size_t a = 0, b = ring.size() - 1; a < ring.size(); b = a++) {
    const Eigen::Vector2d& p = ring[a];
    const Eigen::Vector2d& q = ring[b];
    if ((p.y() > y) != (q.y() > y) && x < (q.x() - p.x()) * (y - p.y()) / (q.y() - p.y()) + p.x())
      in = !in;
  }
  return in;
}

}  // namespace

double covered_fraction(const Planecell& cell, std::span<const Planecell* const> covering,
                        int samples) {
  if (covering.empty() || cell.vertices_m.size() < 3 || samples < 1) return 0.0;
  const PlaneBasis basis = make_basis(cell.plane, vertex_centroid(cell.vertices_m));
  const auto ring = project_to_basis(cell.vertices_m, basis);
  Eigen::Vector2d lo = ring.front(), hi = ring.front();
  for (const auto& p : ring) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  std::vector<std::vector<Eigen::Vector2d>> rings;
  rings.reserve(covering.size());
  for (const Planecell* old : covering) {
    auto r = project_to_basis(old->vertices_m, basis);
    Eigen::Vector2d olo = r.front(), ohi = r.front();
    for (const auto& p : r) olo = olo.cwiseMin(p), ohi = ohi.cwiseMax(p);
    if (r.size() >= 3 && (olo.array() <= hi.array()).all() && (ohi.array() >= lo.array()).all())
      rings.push_back(std::move(r));
  }
  if (rings.empty()) return 0.0;
  // A square grid of about `samples` points over the cell's bounding box (centres of its squares).
  const Eigen::Vector2d size = hi - lo;
  const double area = polygon_area_m2(cell.vertices_m);
  if (!(area > 0.0) || !std::isfinite(area)) return 0.0;
  const double step = std::max(std::sqrt(size.x() * size.y() / samples), 1e-6);
  const int nx = std::clamp(static_cast<int>(std::ceil(size.x() / step)), 1, 4 * samples);
  const int ny = std::clamp(static_cast<int>(std::ceil(size.y() / step)), 1, 4 * samples);
  int own = 0, covered = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double x = lo.x() + (i + 0.5) * size.x() / nx, y = lo.y() + (j + 0.5) * size.y() / ny;
      if (!inside(ring, x, y)) continue;
      ++own;
      for (const auto& r : rings)
        if (inside(r, x, y)) {
          ++covered;
          break;
        }
    }
  return own > 0 ? static_cast<double>(covered) / own : 0.0;
}

}  // namespace planecell::map
