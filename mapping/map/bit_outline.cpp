#include "mapping/map/bit_outline.hpp"

#include <algorithm>
#include <bit>

namespace planecell::map {
namespace {

namespace bg = boost::geometry;

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

std::vector<GridBit> footprint_bits(const Footprint& footprint) {
  constexpr int N = FootprintTile::kSize;
  std::vector<GridBit> bits;
  for (const auto& tile : footprint.tiles())
    for (int j = 0; j < N; ++j)
      for (std::uint32_t row = tile.rows[j]; row != 0; row &= row - 1)
        bits.emplace_back(std::int64_t{tile.t} * N + j, std::int64_t{tile.s} * N + std::countr_zero(row));
  std::sort(bits.begin(), bits.end());
  return bits;
}

MultiPolygon2 bits_union(std::span<const GridBit> bits) {
  // Each row's runs of consecutive bits as rectangles [i0, i1) × [t, t + 1): one disjoint
  // multipolygon per row.
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
  return cascaded_union(std::move(rows));
}

Polygon2 simplify_region(const Polygon2& polygon, double tolerance) {
  constexpr double kCollinear = 1e-9;
  Polygon2 simplified;
  bg::simplify(polygon, simplified, std::max(tolerance, kCollinear));
  if (simplified.outer().size() < 4) bg::simplify(polygon, simplified, kCollinear);
  return simplified;
}

std::vector<Eigen::Vector3d> lift_ring(const Polygon2::ring_type& ring, const PlaneBasis& basis,
                                       const Plane3& plane, double resolution_m) {
  const Eigen::Vector3d n = plane.normal.normalized();
  const double e = plane.offset / plane.normal.norm();
  std::vector<Eigen::Vector3d> out;
  out.reserve(ring.size());
  for (std::size_t k = 0; k + 1 < ring.size(); ++k) {  // the last point closes the ring
    const Eigen::Vector3d x =
        basis.to_3d({bg::get<0>(ring[k]) * resolution_m, bg::get<1>(ring[k]) * resolution_m});
    out.push_back(x - (n.dot(x) + e) * n);
  }
  return out;
}

}  // namespace planecell::map
