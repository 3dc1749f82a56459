#include "mapping/refine/surface_planes.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <vector>

namespace planecell::refine {

double SurfacePlane::sigma_at(const Eigen::Vector3d& x) const {
  const Eigen::Vector3d d = x - mean;
  const Eigen::Vector2d a(d.dot(u), d.dot(v));
  return std::sqrt(1.0 / weight + a.dot(inverse_scatter * a));
}

double map_cell_sigma_m(double depth_sigma_m, const RefineConfig& config) {
  return std::max(config.depth_sigma_scale * depth_sigma_m, config.plane_sigma_m);
}

SurfacePlanes surface_planes_near(const map::GlobalMap& map, const map::Aabb& region,
                                  const RefineConfig& config) {
  SurfacePlanes out;
  if (region.empty()) return out;
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> by_surface;
  for (const std::uint32_t id : map.cells_near(region)) {
    const auto* cell = map.cell(id);
    if (cell == nullptr || cell->surface == kNoSurface || cell->vertices_m.size() < 3) continue;
    by_surface[cell->surface].push_back(id);
  }
  for (const auto& [surface_id, members] : by_surface) {
    const map::Surface* surface = map.surface(surface_id);
    if (surface == nullptr) continue;
    SurfacePlane s;
    s.plane = surface->plane;
    double weight = 0.0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d sum_outer = Eigen::Matrix3d::Zero();
    std::vector<std::uint32_t> on_plane;
    for (const std::uint32_t id : members) {
      const auto* cell = map.cell(id);
      const double sigma = map_cell_sigma_m(cell->depth_sigma_m, config);
      const double distance = std::abs(s.plane.signed_distance(map::vertex_centroid(cell->vertices_m)));
      if (distance > std::min(config.gate_sigmas * sigma, config.ambiguity_m)) continue;
      const double w = 1.0 / (sigma * sigma * static_cast<double>(cell->vertices_m.size()));
      for (const auto& vertex : cell->vertices_m) {
        const Eigen::Vector3d p = vertex.template cast<double>();
        weight += w;
        sum += w * p;
        sum_outer += w * p * p.transpose();
      }
      on_plane.push_back(id);
    }
    if (on_plane.size() < static_cast<std::size_t>(config.min_surface_cells) || !(weight > 0.0)) continue;
    s.mean = sum / weight;
    s.weight = weight;
    s.member_cells = static_cast<int>(on_plane.size());
    // In-plane principal axes of the members' spread (projected onto the map plane).
    const Eigen::Matrix3d scatter = sum_outer - weight * s.mean * s.mean.transpose();
    const Eigen::Vector3d n = s.plane.normal;
    const Eigen::Vector3d e1 = n.unitOrthogonal(), e2 = n.cross(e1);
    Eigen::Matrix<double, 3, 2> basis;
    basis << e1, e2;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(basis.transpose() * scatter * basis);
    const Eigen::Vector2d spread = eigen.eigenvalues();
    if (!(spread[0] > 1e-9 * weight)) continue;  // the members do not span the plane
    s.u = basis * eigen.eigenvectors().col(0);
    s.v = basis * eigen.eigenvectors().col(1);
    s.inverse_scatter = spread.cwiseInverse().asDiagonal();
    // The map's plane also holds the observations fused into the surface without being stored:
    // each carries about a stored cell's information, so the information scales by
    // observations / stored cells (≥ 1).
    const double fused_factor = std::max(
        1.0, static_cast<double>(surface->observations) / static_cast<double>(std::max<std::size_t>(surface->cells.size(), 1)));
    s.weight *= fused_factor;
    s.inverse_scatter /= fused_factor;
    for (const std::uint32_t id : on_plane)
      out.on_plane_cells.emplace(id, SurfacePlanes::OnPlaneCell{surface_id, map::bounds_of(map.cell(id)->vertices_m)});
    out.planes.emplace(surface_id, s);
  }
  return out;
}

}  // namespace planecell::refine
