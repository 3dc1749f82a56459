#pragma once
/// Several planecells of one surface united into fewer polygons on the surface's plane: how the map
/// retires old cells (MapConfig::consolidate_after_frames), so that its cell count grows with the
/// surfaces' extent, not with the frames that saw them.
#include <Eigen/Core>
#include <cstddef>
#include <span>
#include <vector>

#include "core/plane.hpp"
#include "mapping/map/geometry.hpp"

namespace planecell::map {

/// One united polygon and the input polygons it stands for.
struct CellUnion {
  std::vector<Eigen::Vector3f> vertices_m;  ///< outer ring on the plane, world frame (no holes)
  std::vector<std::size_t> members;         ///< indices into the input polygons, ascending
};

/// How finely unite_cells works.
struct CellUnionSettings {
  double resolution_m = 0.05;  ///< raster bit edge
  double tolerance_m = 0.10;   ///< Douglas–Peucker tolerance of the outlines
  double max_hole_m2 = 0.5;    ///< holes up to this area are filled, larger ones cut around
  /// An outline with more vertices is simplified again with twice the tolerance until it fits
  /// (LCM carries up to kMaxLcmCellVertices = 1024 per cell).
  std::size_t max_vertices = 256;
};

/// Unites `polygons` (world frame, lying on or near `plane`) in `basis` (a 2D frame of the plane):
/// 1. each polygon is rasterised on a grid of settings.resolution_m (the bits whose centres it
///    holds, edge bits included, as a footprint does), so polygons that touch, overlap or leave a
///    sliver gap narrower than a bit (their planes differ slightly) share or neighbour bits;
/// 2. the union's holes of at most max_hole_m2 are filled; each 4-connected region with a larger
///    hole is cut along the bit row above the hole into hole-free regions;
/// 3. each region's outline (through its boundary bits' centres: half a bit inside the union's
///    edge) is simplified by Douglas–Peucker to within tolerance_m (doubled until at most
///    max_vertices remain) and lifted onto `plane` (X = basis.to_3d(s, t) moved along n onto
///    n·X + e = 0).
/// A region becomes a CellUnion when two or more polygons lie in it and each of its members lies
/// wholly in regions that become unions (a polygon cut between two regions stands in both); a
/// polygon covering no bit, or lying partly in a region that does not become one (a lone
/// polygon, a region thinner than two bits), is not a member: the caller keeps it. Unions come in
/// region order (raster order of their first bit). Empty when the polygons span more than 4 000
/// bits on a side. Throws InputError unless resolution_m > 0, tolerance_m ≥ 0 and max_hole_m2 ≥ 0
/// (finite) and max_vertices ≥ 3.
std::vector<CellUnion> unite_cells(std::span<const std::span<const Eigen::Vector3f>> polygons,
                                   const PlaneBasis& basis, const Plane3& plane,
                                   const CellUnionSettings& settings = {});

}  // namespace planecell::map
