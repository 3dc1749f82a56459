#include "mapping/map/surface_outline.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.hpp"
#include "mapping/map/polygon2.hpp"

namespace planecell::map {
namespace {

namespace bg = boost::geometry;
using MultiPolygon2 = bg::model::multi_polygon<Polygon2>;

/// The union of many multipolygons, merged pairwise in rounds (neighbours first), so each
/// coordinate takes part in about log₂(parts) unions instead of one per part.
MultiPolygon2 cascaded_union(std::vector<MultiPolygon2> parts) {
  if (parts.empty()) return {};
  while (parts.size() > 1) {
    std::vector<MultiPolygon2> next;
    next.reserve((parts.size() + 1) / 2);
    for (std::size_t k = 0; k + 1 < parts.size(); k += 2) {
      MultiPolygon2 merged;
      bg::union_(parts[k], parts[k + 1], merged);
      next.push_back(std::move(merged));
    }
    if (parts.size() % 2 == 1) next.push_back(std::move(parts.back()));
    parts = std::move(next);
  }
  return std::move(parts.front());
}

}  // namespace

std::vector<OutlineRing> surface_outline(const Plane3& plane, const SurfaceDetail& detail,
                                         double tolerance_m) {
  if (!(tolerance_m >= 0.0) || !std::isfinite(tolerance_m))
    throw InputError("surface outline: tolerance must be a finite number ≥ 0 m, got " +
                     std::to_string(tolerance_m));
  const Footprint& footprint = detail.footprint;
  if (footprint.empty()) return {};
  constexpr int N = FootprintTile::kSize;
  // Covered bits per row t (bit indices), then each row's runs of consecutive bits as rectangles
  // [i0, i1) × [t, t + 1) in bit units: one disjoint multipolygon per row.
  std::vector<std::pair<std::int64_t, std::int64_t>> bits;  // (t, s)
  for (const auto& tile : footprint.tiles())
    for (int j = 0; j < N; ++j)
      for (std::uint32_t row = tile.rows[j]; row != 0; row &= row - 1)
        bits.emplace_back(std::int64_t{tile.t} * N + j,
                          std::int64_t{tile.s} * N + std::countr_zero(row));
  std::sort(bits.begin(), bits.end());
  std::vector<MultiPolygon2> rows;
  for (std::size_t k = 0; k < bits.size();) {
    const std::int64_t t = bits[k].first;
    MultiPolygon2 row;
    while (k < bits.size() && bits[k].first == t) {
      const std::int64_t i0 = bits[k].second;
      std::int64_t i1 = i0 + 1;
      for (++k; k < bits.size() && bits[k].first == t && bits[k].second == i1; ++k) ++i1;
      const auto x0 = static_cast<double>(i0), x1 = static_cast<double>(i1);
      const auto y0 = static_cast<double>(t), y1 = static_cast<double>(t + 1);
      Polygon2 rectangle;  // clockwise, closed
      bg::append(rectangle.outer(), Point2(x0, y0));
      bg::append(rectangle.outer(), Point2(x0, y1));
      bg::append(rectangle.outer(), Point2(x1, y1));
      bg::append(rectangle.outer(), Point2(x1, y0));
      bg::append(rectangle.outer(), Point2(x0, y0));
      row.push_back(std::move(rectangle));
    }
    rows.push_back(std::move(row));
  }
  const MultiPolygon2 merged = cascaded_union(std::move(rows));
  // Douglas–Peucker in bit units, polygon by polygon; a tolerance of 0 still drops the collinear
  // vertices the rectangles left along straight edges. A polygon narrower than the tolerance
  // (its outer ring simplifies below three vertices) keeps its corners instead of vanishing.
  constexpr double kCollinear = 1e-9;
  const double res = footprint.resolution_m();
  MultiPolygon2 simple;
  for (const Polygon2& polygon : merged) {
    Polygon2 simplified;
    bg::simplify(polygon, simplified, std::max(tolerance_m / res, kCollinear));
    if (simplified.outer().size() < 4) bg::simplify(polygon, simplified, kCollinear);
    simple.push_back(std::move(simplified));
  }

  const Eigen::Vector3d n = plane.normal.normalized();
  const double e = plane.offset / plane.normal.norm();
  auto ring_of = [&](const auto& points, bool hole) {
    OutlineRing ring;
    ring.hole = hole;
    for (std::size_t k = 0; k + 1 < points.size(); ++k) {  // the last point closes the ring
      const Eigen::Vector3d x =
          detail.basis.to_3d({bg::get<0>(points[k]) * res, bg::get<1>(points[k]) * res});
      ring.vertices_m.push_back(x - (n.dot(x) + e) * n);  // onto the surface's current plane
    }
    return ring;
  };
  std::vector<OutlineRing> out;
  for (const Polygon2& polygon : simple) {
    OutlineRing outer = ring_of(polygon.outer(), false);
    if (outer.vertices_m.size() < 3) continue;
    out.push_back(std::move(outer));
    for (const auto& inner : polygon.inners())
      if (OutlineRing hole = ring_of(inner, true); hole.vertices_m.size() >= 3)
        out.push_back(std::move(hole));
  }
  return out;
}

}  // namespace planecell::map
