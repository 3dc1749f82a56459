#pragma once
/// How much of the map lies where the world has a surface: the stored planecells' area against
/// the renderer's GT surfaces (scene.yaml). The counterpart of MapCompleteness, which scores GT
/// points against the map: a map can hold every GT point and still claim surfaces where there are
/// none (a far view's cell spanning the gap between two parked cars), which a planner would take
/// for an obstacle. Synthetic sequences only (they have exact GT polygons).
#include <Eigen/Core>
#include <array>
#include <span>
#include <vector>

#include "core/plane.hpp"
#include "io/synthetic/synthetic_world.hpp"
#include "mapping/map/coverage.hpp"
#include "mapping/map/global_map.hpp"
#include "services/eval/map_completeness.hpp"

namespace planecell::services::eval {

/// A GT surface as the accuracy test reads it: its plane, its corners in the world and their bounds.
struct GtPolygon {
  Plane3 plane;
  std::vector<Eigen::Vector3f> corners;  ///< world frame, ≥ 3, in polygon order (floats: 8 µm at 100 m)
  map::Aabb box;                         ///< bounds of the corners
};

/// The GT polygons of `surfaces` (those with fewer than 3 corners are left out).
std::vector<GtPolygon> gt_polygons(std::span<const io::SyntheticSurface> surfaces);

/// Distance (m) from `point` to the GT polygon: map::distance_to_polygon, the paper's
/// point-to-plane distance |n·X + e| where X projects inside the polygon, the distance to its
/// boundary elsewhere.
double distance_to_gt_polygon(const Eigen::Vector3d& point, const GtPolygon& gt);

struct MapAccuracy {
  double area_m2 = 0.0;  ///< stored planecells' area scored (every stored cell's polygon)
  std::size_t cells = 0;  ///< stored cells scored
  /// Share of that area whose points lie within kCompletenessDistancesM[i] of a GT surface:
  ///   Σ_c area_c · (points of c within d) / (points of c)  /  Σ_c area_c,
  /// each cell sampled on its coverage_grid (kCoverageSamples points over its bounding square).
  std::array<double, kCompletenessDistancesM.size()> within{};
};

/// Scores every stored cell of `map` against `gt` (no cells: area 0, all shares 0).
MapAccuracy map_accuracy(const map::GlobalMap& map, std::span<const GtPolygon> gt);

/// The voxel baseline scored like the map, voxel by voxel (each occupied voxel stands for the
/// same area of surface at one resolution).
struct VoxelAccuracy {
  std::size_t voxels = 0;  ///< occupied voxels scored
  /// Share of the voxels whose centre lies within kCompletenessDistancesM[i] of a GT surface
  /// (a 10 cm voxel a GT surface passes through has its centre within √3·5 cm ≈ 8.7 cm of it).
  std::array<double, kCompletenessDistancesM.size()> within{};
};

/// Scores the occupied voxels' `centres` against `gt` (none: 0 voxels, all shares 0).
VoxelAccuracy voxel_accuracy(std::span<const Eigen::Vector3d> centres, std::span<const GtPolygon> gt);

/// GT points scored against the voxel baseline as map_completeness scores them against the map:
/// a point is held within d when an occupied voxel's cube (centre ± resolution_m/2 on each axis)
/// lies within d of it (0 inside the cube). `centres` are voxel centres on OctoMap's grid
/// ((k + ½)·resolution_m per axis); a non-finite point counts as held by nothing. Throws
/// InputError on a non-positive resolution.
MapCompleteness voxel_completeness(std::span<const Eigen::Vector3d> centres, double resolution_m,
                                   std::span<const Eigen::Vector3d> points);

}  // namespace planecell::services::eval
