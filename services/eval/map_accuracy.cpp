#include "services/eval/map_accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mapping/map/coverage.hpp"
#include "mapping/map/geometry.hpp"

namespace planecell::services::eval {

std::vector<GtPolygon> gt_polygons(std::span<const io::SyntheticSurface> surfaces) {
  std::vector<GtPolygon> out;
  out.reserve(surfaces.size());
  for (const auto& s : surfaces) {
    if (s.polygon.size() < 3) continue;
    GtPolygon g{s.plane, s.origin, s.u_axis, s.v_axis, s.polygon, {}, {}};
    g.box_min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    g.box_max = -g.box_min;
    for (const Eigen::Vector3d& c : s.corners_world()) {
      g.box_min = g.box_min.cwiseMin(c);
      g.box_max = g.box_max.cwiseMax(c);
    }
    out.push_back(std::move(g));
  }
  return out;
}

double distance_to_gt_polygon(const Eigen::Vector3d& point, const GtPolygon& gt) {
  const Eigen::Vector3d d = point - gt.origin;
  const Eigen::Vector2d st(d.dot(gt.u), d.dot(gt.v));
  const double h = gt.plane.signed_distance(point);
  if (map::point_in_ring(gt.polygon, st)) return std::abs(h);
  double best2 = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0, n = gt.polygon.size(); i < n; ++i) {
    const Eigen::Vector2d& a = gt.polygon[i];
    const Eigen::Vector2d& b = gt.polygon[(i + 1) % n];
    const Eigen::Vector2d ab = b - a;
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0.0 ? std::clamp((st - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    best2 = std::min(best2, (a + t * ab - st).squaredNorm());
  }
  return std::sqrt(h * h + best2);
}

MapAccuracy map_accuracy(const map::GlobalMap& map, std::span<const GtPolygon> gt) {
  MapAccuracy acc;
  const double reach = kCompletenessDistancesM.back();
  std::array<double, kCompletenessDistancesM.size()> area_within{};
  std::vector<Eigen::Vector3f> vertices;
  std::vector<const GtPolygon*> near;
  for (const auto& [id, cell] : map.cells()) {
    cell.vertices_m.vertices_into(vertices);
    const double area = map::polygon_area_m2(vertices);
    const Plane3 plane = cell.plane;
    const map::CoverageGrid grid = map::coverage_grid(plane, vertices);
    if (!(area > 0.0) || grid.points.empty()) continue;
    ++acc.cells;
    acc.area_m2 += area;
    // The GT polygons whose bounds come within the largest distance of the cell's.
    const map::Aabb box = map::bounds_of(vertices);
    near.clear();
    for (const GtPolygon& g : gt)
      if ((g.box_min.array() <= box.max.array() + reach).all() && (g.box_max.array() >= box.min.array() - reach).all())
        near.push_back(&g);
    std::array<std::size_t, kCompletenessDistancesM.size()> hits{};
    for (const Eigen::Vector2d& st : grid.points) {
      const Eigen::Vector3d p = grid.basis.to_3d(st);
      double nearest = std::numeric_limits<double>::infinity();
      for (const GtPolygon* g : near) nearest = std::min(nearest, distance_to_gt_polygon(p, *g));
      for (std::size_t i = 0; i < hits.size(); ++i)
        if (nearest <= kCompletenessDistancesM[i]) ++hits[i];
    }
    for (std::size_t i = 0; i < hits.size(); ++i)
      area_within[i] += area * static_cast<double>(hits[i]) / static_cast<double>(grid.points.size());
  }
  if (acc.area_m2 > 0.0)
    for (std::size_t i = 0; i < area_within.size(); ++i) acc.within[i] = area_within[i] / acc.area_m2;
  return acc;
}

}  // namespace planecell::services::eval
