#pragma once
/// The map surfaces around a frame as references for pose refinement: each surface's plane (the
/// map's information-weighted fit, which includes fused near re-observations) with an upper bound of
/// its uncertainty, and the stored member cells that lie on it.
#include <Eigen/Core>
#include <cstdint>
#include <unordered_map>

#include "core/config/refine_config.hpp"
#include "core/plane.hpp"
#include "mapping/map/geometry.hpp"
#include "mapping/map/global_map.hpp"

namespace planecell::refine {

/// A map surface's plane with its uncertainty, bounded from its stored member cells. With the
/// members' vertices p_j as points of weight w_j = 1/(K σ_c²) (a cell's information 1/σ_c² spread
/// over its K vertices), W = Σ w_j, p̄ the weighted mean, P = [u v] the in-plane principal axes and
/// M = Pᵀ Σ w_j (p_j − p̄)(p_j − p̄)ᵀ P, a least-squares plane through them has at X the offset variance
/// (the regression's prediction variance)
///   σ_S²(X) = 1/W + aᵀ M⁻¹ a,   a = Pᵀ (X − p̄):
/// offset noise plus tilt noise times the lever from the members' centre. The map's plane also
/// holds the re-observations fused into the surface without being stored; each carries about a
/// stored cell's information, so W is multiplied and M⁻¹ divided by f = max(1, observations /
/// stored cells) (Surface::observations counts both).
struct SurfacePlane {
  Plane3 plane;  ///< the map's surface plane (world)
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Vector3d u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d v = Eigen::Vector3d::UnitY();
  Eigen::Matrix2d inverse_scatter = Eigen::Matrix2d::Zero();  ///< M⁻¹ in (u, v)
  double weight = 0.0;   ///< W (1/m²)
  int member_cells = 0;  ///< stored members on the plane in the region

  double sigma_at(const Eigen::Vector3d& x) const;
};

/// The surfaces with stored cells in a region, and the member cells that lie on their plane.
struct SurfacePlanes {
  std::unordered_map<std::uint32_t, SurfacePlane> planes;  ///< by map surface id
  struct OnPlaneCell {
    std::uint32_t surface = 0;  ///< the surface whose plane the cell lies on
    map::Aabb bounds;           ///< bounds of the cell's vertices (computed once per frame)
  };
  std::unordered_map<std::uint32_t, OnPlaneCell> on_plane_cells;  ///< by map cell id
};

/// σ of a stored map cell (m): max(depth_sigma_scale · depth_sigma_m, plane_sigma_m).
double map_cell_sigma_m(double depth_sigma_m, const RefineConfig& config);

/// The planes of the surfaces with stored cells overlapping `region`. A member cell is on its
/// surface's plane when its vertex centroid is within min(gate_sigmas·σ_c, ambiguity_m) of it: a
/// cell of another plane that the CRF merged into the label (the sidewalk 15 cm above the road) is
/// not. Surfaces with fewer than min_surface_cells such cells in the region, or whose cells do not
/// span the plane in two directions, are left out.
SurfacePlanes surface_planes_near(const map::GlobalMap& map, const map::Aabb& region,
                                  const RefineConfig& config);

}  // namespace planecell::refine
