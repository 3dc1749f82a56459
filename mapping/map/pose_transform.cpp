#include "mapping/map/pose_transform.hpp"

namespace planecell::map {

Planecell to_world(const Planecell& cell, const Pose& T_world_cam) {
  Planecell out = cell;
  out.plane = transform_plane(T_world_cam, cell.plane);
  const Eigen::Isometry3f pose_f = T_world_cam.cast<float>();
  for (auto& vertex : out.vertices_m) vertex = pose_f * vertex;
  return out;
}

std::vector<Planecell> to_world(std::span<const Planecell> cells, const Pose& T_world_cam) {
  validate_pose(T_world_cam, "frame pose");
  std::vector<Planecell> out;
  out.reserve(cells.size());
  for (const auto& cell : cells)
    if (cell.has_plane) out.push_back(to_world(cell, T_world_cam));
  return out;
}

}  // namespace planecell::map
