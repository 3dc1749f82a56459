#pragma once
/// Pose transform stage: planecells from the camera frame to the world frame.
#include <span>
#include <vector>

#include "core/planecell.hpp"
#include "core/pose.hpp"

namespace planecell::map {

/// Moves a cell's 3D plane and 3D polygon by T_world_cam: X_w = R X_c + t, n_w = R n_c,
/// e_w = e_c − n_w·t. Image-space fields (disparity plane, pixel polygon) are kept as they are.
Planecell to_world(const Planecell& cell, const Pose& T_world_cam);

/// Transforms every cell with a plane; planeless cells are dropped. Validates the pose first
/// (throws InputError on NaN/Inf or a non-orthonormal rotation).
std::vector<Planecell> to_world(std::span<const Planecell> cells, const Pose& T_world_cam);

}  // namespace planecell::map
