#include "mapping/map/surface_outline.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.hpp"
#include "mapping/map/bit_outline.hpp"

namespace planecell::map {
std::vector<OutlineRing> surface_outline(const Surface& surface, double tolerance_m) {
  if (!(tolerance_m >= 0.0) || !std::isfinite(tolerance_m))
    throw InputError("surface outline: tolerance must be a finite number ≥ 0 m, got " +
                     std::to_string(tolerance_m));
  const Footprint& footprint = surface.footprint;
  if (footprint.empty()) return {};
  // The exact boundary in bit units, then Douglas–Peucker polygon by polygon (a tolerance of 0
  // still drops the collinear vertices the rectangles left along straight edges).
  const MultiPolygon2 merged = bits_union(footprint_bits(footprint));
  const double res = footprint.resolution_m();
  MultiPolygon2 simple;
  for (const Polygon2& polygon : merged)
    simple.push_back(simplify_region(polygon, tolerance_m / res));

  auto ring_of = [&](const Polygon2::ring_type& points, bool hole) {
    return OutlineRing{lift_ring(points, surface.basis, surface.plane, res), hole};
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
