#pragma once
/// Rigid poses. A pose T_world_cam maps camera-frame points to the world frame.
#include <Eigen/Geometry>
#include <numbers>
#include <string>

#include "core/plane.hpp"

namespace planecell {

using Pose = Eigen::Isometry3d;

inline constexpr double kDegToRad = std::numbers::pi / 180.0;  ///< degrees → radians
inline constexpr double kRadToDeg = 180.0 / std::numbers::pi;  ///< radians → degrees

/// Throws InputError naming `source` when the pose holds NaN/Inf or its rotation is not
/// orthonormal with det +1 (|RᵀR − I|∞ > tolerance or |det R − 1| > tolerance).
void validate_pose(const Pose& pose, const std::string& source, double tolerance = 1e-4);

/// Builds a pose from a row-major 3×4 matrix [R | t] (KITTI convention), validating it.
Pose pose_from_3x4(const double* row_major_12, const std::string& source);

/// Plane transformed by a pose: n' = R n, e' = e − n'·t.
Plane3 transform_plane(const Pose& pose, const Plane3& plane);

}  // namespace planecell
