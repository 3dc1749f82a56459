#pragma once
/// A surface's outline: the boundary of its footprint (every observation fused into it, stored or
/// not) as polygons on its plane, simplified. A compact view of the map for planners and export: a
/// surface of thousands of cells becomes a few rings.
#include <Eigen/Core>
#include <vector>

#include "mapping/map/global_map.hpp"

namespace planecell::map {

/// One closed ring of an outline (no repeated closing vertex), world frame; its area is
/// polygon_area_m2(vertices_m).
struct OutlineRing {
  std::vector<Eigen::Vector3d> vertices_m;
  bool hole = false;  ///< a hole inside the preceding outer ring
};

/// The outline of a surface on `plane` with detail `detail` (GlobalMap::surface_detail): the exact
/// boundary of the union of its footprint's covered bits (squares of footprint.resolution_m() on
/// the detail's basis; each row's runs of bits as
/// rectangles, united with Boost.Geometry), simplified by Douglas–Peucker
/// (boost::geometry::simplify) to within tolerance_m (0 keeps every corner, dropping only collinear
/// vertices), then lifted from the basis onto the surface's current plane (X = o + s·u + t·v, moved
/// along n onto n·X + e = 0; the basis is fixed when the detail is made, so a surface whose
/// plane has since turned by α encloses cos α of its footprint area). Outer rings come each
/// followed by their holes. A polygon narrower than the tolerance keeps its unsimplified corners; a
/// hole that simplifies below three vertices is dropped. Empty for an empty footprint. Throws
/// InputError when tolerance_m is negative or not finite.
std::vector<OutlineRing> surface_outline(const Plane3& plane, const SurfaceDetail& detail,
                                         double tolerance_m);

}  // namespace planecell::map
