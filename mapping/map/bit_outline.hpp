#pragma once
/// Exact boundaries of sets of grid bits (footprint squares), shared by the surface outline and the
/// cell union: each row's runs of bits become rectangles, united with Boost.Geometry. Internal to
/// planecell_mapping (Boost.Geometry types; see polygon2.hpp).
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "mapping/map/footprint.hpp"
#include "mapping/map/polygon2.hpp"

namespace planecell::map {

using MultiPolygon2 = boost::geometry::model::multi_polygon<Polygon2>;

/// A grid bit (t, s): row t, column s; bit (t, s) covers [s, s + 1) × [t, t + 1) in bit units.
using GridBit = std::pair<std::int64_t, std::int64_t>;

/// The covered bits of `footprint`, sorted by (t, s).
std::vector<GridBit> footprint_bits(const Footprint& footprint);

/// The exact boundary of the union of `bits` (sorted by (t, s), unique) in bit units: outer rings
/// with their holes; bits touching only at a corner may form separate polygons.
MultiPolygon2 bits_union(std::span<const GridBit> bits);

/// `polygon` simplified by Douglas–Peucker to within tolerance (its units); a tolerance of 0 still
/// drops collinear vertices. A polygon narrower than the tolerance (its outer ring simplifies below
/// three vertices) keeps its corners instead of vanishing.
Polygon2 simplify_region(const Polygon2& polygon, double tolerance);

/// The ring's points (bit units of resolution_m, closing point dropped) in the world:
/// X = basis.to_3d(resolution_m · p), moved along n onto `plane` (n·X + e = 0).
std::vector<Eigen::Vector3d> lift_ring(const Polygon2::ring_type& ring, const PlaneBasis& basis,
                                       const Plane3& plane, double resolution_m);

}  // namespace planecell::map
