#include "mapping/refine/surface_association.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "mapping/map/geometry.hpp"

namespace planecell::refine {
namespace {

/// In-plane distance (m) from the projection of `x` onto `plane` to the polygon `vertices` (which
/// lie on `plane`): 0 inside (even–odd crossing test), else the distance to the nearest edge.
template <class Vertices>
double in_plane_distance(const Eigen::Vector3d& x, const Plane3& plane, const Vertices& vertices) {
  const Eigen::Vector3d n = plane.normal;
  const Eigen::Vector3d u = n.unitOrthogonal();
  const Eigen::Vector3d v = n.cross(u);
  const Eigen::Vector3d p = x - plane.signed_distance(x) * n;
  bool inside = false;
  double best_sq = std::numeric_limits<double>::infinity();
  const std::size_t k = vertices.size();
  Eigen::Vector2d prev;
  {
    const Eigen::Vector3d d = vertices[k - 1].template cast<double>() - p;
    prev = {d.dot(u), d.dot(v)};
  }
  for (std::size_t i = 0; i < k; ++i) {
    const Eigen::Vector3d d = vertices[i].template cast<double>() - p;
    const Eigen::Vector2d cur(d.dot(u), d.dot(v));
    // Crossing of the ray from the origin (the projected point) along +s.
    if ((cur.y() > 0.0) != (prev.y() > 0.0)) {
      const double s = prev.x() + (0.0 - prev.y()) * (cur.x() - prev.x()) / (cur.y() - prev.y());
      if (s > 0.0) inside = !inside;
    }
    const Eigen::Vector2d edge = cur - prev;
    const double len_sq = edge.squaredNorm();
    const double t = len_sq > 0.0 ? std::clamp(-prev.dot(edge) / len_sq, 0.0, 1.0) : 0.0;
    best_sq = std::min(best_sq, (prev + t * edge).squaredNorm());
    prev = cur;
  }
  return inside ? 0.0 : std::sqrt(best_sq);
}

struct Candidate {
  std::uint32_t surface = 0;
  const SurfacePlane* local = nullptr;
  double distance_m = 0.0;  ///< signed n_s·X + e_s
  bool contained = false;   ///< a member cell holds X (in-plane)
  bool passes = false;      ///< normal and distance gates
};

}  // namespace

double centroid_sigma_m(double depth_sigma_m, double depth_m, double normal_dot_ray,
                        const StereoCamera& camera, const RefineConfig& config) {
  const double sigma_z = depth_sigma_m > 0.0
                             ? config.depth_sigma_scale * depth_sigma_m
                             : depth_m * depth_m * config.disparity_sigma_px / (camera.fx * camera.baseline_m);
  const double along_normal = sigma_z * normal_dot_ray;
  return std::sqrt(config.plane_sigma_m * config.plane_sigma_m + along_normal * along_normal);
}

namespace {

/// The cell's vertex centroid (camera frame) when the cell takes part in association.
std::optional<Eigen::Vector3d> usable_centroid(const Planecell& cell, const RefineConfig& config) {
  if (!cell.has_plane || cell.vertices_m.size() < 3) return std::nullopt;
  if (!(cell.inlier_ratio >= config.min_inlier_ratio)) return std::nullopt;
  const Eigen::Vector3d c_cam = map::vertex_centroid(cell.vertices_m);
  const double range_m = c_cam.norm();
  if (!(range_m > 0.0) || range_m > config.max_range_m) return std::nullopt;
  return c_cam;
}

}  // namespace

map::Aabb association_region(std::span<const Planecell> cells_cam, const Pose& T_world_cam,
                             const RefineConfig& config, double slack_m) {
  map::Aabb box;
  for (const Planecell& cell : cells_cam)
    if (const auto c_cam = usable_centroid(cell, config)) box.extend(T_world_cam * *c_cam);
  if (box.empty()) return box;
  return box.inflated(config.max_plane_distance_m + config.overlap_margin_m + slack_m);
}

std::vector<SurfaceAssociation> associate_cells(std::span<const Planecell> cells_cam,
                                                const Pose& T_world_cam, const map::GlobalMap& map,
                                                const SurfacePlanes& surfaces,
                                                const StereoCamera& camera,
                                                const RefineConfig& config) {
  std::vector<SurfaceAssociation> out;
  if (surfaces.planes.empty()) return out;
  const double cos_max = std::cos(config.max_normal_angle_deg * kDegToRad);
  const Eigen::Vector3d centre = T_world_cam.translation();
  const double search_m = config.max_plane_distance_m + config.overlap_margin_m;
  std::vector<Candidate> candidates;
  for (std::size_t i = 0; i < cells_cam.size(); ++i) {
    const Planecell& cell = cells_cam[i];
    const auto usable = usable_centroid(cell, config);
    if (!usable) continue;
    const Eigen::Vector3d c_cam = *usable;
    const double range_m = c_cam.norm();
    const Eigen::Vector3d x = T_world_cam * c_cam;
    const Eigen::Vector3d ray = (x - centre) / range_m;
    const Eigen::Vector3d normal_w = T_world_cam.linear() * cell.plane.normal;

    map::Aabb box;
    box.extend(x);
    candidates.clear();
    // The index's candidates; on-plane cells only, tested against their bounds computed once.
    const map::Aabb reach = box.inflated(search_m);
    for (const std::uint32_t id : map.cell_candidates(reach)) {
      const auto inlier = surfaces.on_plane_cells.find(id);
      if (inlier == surfaces.on_plane_cells.end()) continue;  // not on its surface's plane
      if (!inlier->second.bounds.overlaps(reach)) continue;
      const std::uint32_t surface_id = inlier->second.surface;
      auto it = std::find_if(candidates.begin(), candidates.end(),
                             [&](const Candidate& c) { return c.surface == surface_id; });
      if (it != candidates.end() && (it->contained || !it->passes)) continue;
      if (it == candidates.end()) {
        const SurfacePlane& local = surfaces.planes.at(surface_id);
        const double d = local.plane.signed_distance(x);
        const bool passes = std::abs(local.plane.normal.dot(normal_w)) >= cos_max &&
                            std::abs(d) <= config.max_plane_distance_m;
        candidates.push_back({surface_id, &local, d, false, passes});
        if (!passes) continue;
        it = candidates.end() - 1;
      }
      const auto* member = map.cell(id);
      it->contained = in_plane_distance(x, member->plane, member->vertices_m) <= config.overlap_margin_m;
    }
    const Candidate* best = nullptr;
    for (const Candidate& c : candidates)
      if (c.contained && (best == nullptr || std::abs(c.distance_m) < std::abs(best->distance_m))) best = &c;
    if (best == nullptr) continue;
    const double sigma_surface = best->local->sigma_at(x);
    if (sigma_surface > config.max_surface_sigma_m) continue;
    const double sigma_cell = centroid_sigma_m(cell.depth_sigma_m, c_cam.z(),
                                               std::abs(best->local->plane.normal.dot(ray)), camera, config);
    const double sigma = std::hypot(sigma_cell, sigma_surface);
    const double gate = std::min(config.max_plane_distance_m, config.gate_sigmas * sigma);
    if (std::abs(best->distance_m) > gate) continue;
    bool ambiguous = false;
    for (const Candidate& c : candidates)
      ambiguous = ambiguous || (c.contained && c.surface != best->surface && std::abs(c.distance_m) <= gate &&
                                std::abs(c.distance_m - best->distance_m) > config.ambiguity_m);
    if (ambiguous) continue;
    out.push_back({static_cast<std::uint32_t>(i), best->surface, c_cam, best->local->plane, sigma,
                   best->distance_m});
  }
  return out;
}

}  // namespace planecell::refine
