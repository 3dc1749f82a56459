#include "core/pose.hpp"

#include <cmath>

#include "core/error.hpp"

namespace planecell {

void validate_pose(const Pose& pose, const std::string& source, double tolerance) {
  const auto& m = pose.matrix();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(m(r, c))) throw InputError(source + ": pose contains NaN or Inf");
  const Eigen::Matrix3d rotation = pose.linear();
  const double orth_error =
      (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orth_error > tolerance)
    throw InputError(source + ": pose rotation is not orthonormal (|RᵀR − I| = " +
                     std::to_string(orth_error) + ")");
  if (std::abs(rotation.determinant() - 1.0) > tolerance)
    throw InputError(source + ": pose rotation has determinant " +
                     std::to_string(rotation.determinant()) + " (must be +1)");
}

Pose pose_from_3x4(const double* v, const std::string& source) {
  Pose pose = Pose::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) pose.matrix()(r, c) = v[r * 4 + c];
  validate_pose(pose, source);
  return pose;
}

Plane3 transform_plane(const Pose& pose, const Plane3& plane) {
  Plane3 out;
  out.normal = pose.linear() * plane.normal;
  out.offset = plane.offset - out.normal.dot(pose.translation());
  return out;
}

}  // namespace planecell
