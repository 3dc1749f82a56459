#pragma once
/// Data association of pose refinement: which map surface each of a frame's planecells lies on,
/// given a pose estimate. One association = one point-to-plane observation of the pose.
#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "core/config/refine_config.hpp"
#include "core/planecell.hpp"
#include "core/plane.hpp"
#include "core/pose.hpp"
#include "core/stereo_camera.hpp"
#include "mapping/map/global_map.hpp"
#include "mapping/refine/surface_planes.hpp"

namespace planecell::refine {

/// A frame cell paired with a map surface. The observation is the cell's vertex centroid (the
/// polygon's most precise point: it averages the corners' independent depth errors), not its
/// plane: a cell normal at 10–20 m is tens of degrees off, the map surface's plane (fitted to many
/// cells) is not.
struct SurfaceAssociation {
  std::uint32_t cell_index = 0;     ///< index into the frame's cells
  std::uint32_t surface = 0;        ///< map surface id
  Eigen::Vector3d centroid_cam = Eigen::Vector3d::Zero();  ///< c: vertex centroid, camera frame (m)
  Plane3 surface_plane;             ///< n_s·X + e_s = 0 (world): the map surface's plane
  double sigma_m = 0.0;             ///< σ of the point-to-plane distance n_s·(T c) + e_s (m)
  double distance_m = 0.0;          ///< n_s·(T c) + e_s with the pose used for association (m)
};

/// σ of the centroid's distance to a surface with normal n (world) seen along the unit ray r
/// (world; camera centre → centroid): the stereo depth error moves the point along its ray, so
///   σ² = σ₀² + (s·σ_Z · (n·r))²,
/// σ_Z = depth_sigma_scale·Planecell::depth_sigma_m, or Z²σ_d/(f_x·B) when the cell has none;
/// σ₀ = plane_sigma_m (surface roughness, map plane error, association slack).
double centroid_sigma_m(double depth_sigma_m, double depth_m, double normal_dot_ray,
                        const StereoCamera& camera, const RefineConfig& config);

/// The world region associate_cells may touch with poses within `slack_m` of `T_world_cam`: the
/// bounds of the used cells' centroids (see associate_cells) grown by max_plane_distance_m +
/// overlap_margin_m + slack_m. Empty when no cell is used.
map::Aabb association_region(std::span<const Planecell> cells_cam, const Pose& T_world_cam,
                             const RefineConfig& config, double slack_m);

/// Associates the frame's camera-frame cells (as from extraction) with the surface planes
/// `surfaces` (surface_planes_near of `map` around the frame), placing them with `T_world_cam`.
/// A cell takes part when it has a plane, ≥ 3 vertices, inlier_ratio ≥ min_inlier_ratio and its
/// vertex centroid c lies within max_range_m of the camera. With X = T c (world) and n_w the
/// cell's normal in the world, a surface S with local plane (n_s, e_s) is a candidate when
///   - one of its on-plane member cells m contains X: X projected onto m's plane lies inside m's
///     polygon or within overlap_margin_m of its boundary (the in-plane test tells a road cell
///     from the sidewalk 15 cm above it, a facade from its neighbour set back 0.5 m),
///   - angle(n_w, ±n_s) ≤ max_normal_angle_deg and |d| = |n_s·X + e_s| ≤ max_plane_distance_m.
/// The candidate with the smallest |d| is chosen, with σ² = σ_cell² + σ_S(X)² (centroid_sigma_m;
/// SurfacePlane::sigma_at); it is kept when σ_S(X) ≤ max_surface_sigma_m and |d| ≤ gate_sigmas·σ,
/// unless another contained candidate within that gate predicts a distance differing by more
/// than ambiguity_m (two parallel surfaces both plausible: road and sidewalk at their curb).
std::vector<SurfaceAssociation> associate_cells(std::span<const Planecell> cells_cam,
                                                const Pose& T_world_cam, const map::GlobalMap& map,
                                                const SurfacePlanes& surfaces,
                                                const StereoCamera& camera,
                                                const RefineConfig& config);

}  // namespace planecell::refine
