#include "core/plane.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "core/error.hpp"

namespace planecell {

Plane3 plane_from_disparity(const DisparityPlane& p, const StereoCamera& cam) {
  Eigen::Vector3d n(p.a * cam.fx, p.b * cam.fy, p.a * cam.cx + p.b * cam.cy + p.c);
  double offset = -cam.fx * cam.baseline_m;
  const double norm = n.norm();
  Plane3 out;
  out.normal = n / norm;
  out.offset = offset / norm;
  return out;
}

double normal_sigma_rad(const DisparityPlane& plane, const Eigen::Matrix2d& cov_ab,
                        const Eigen::Vector2d& centroid_px, const StereoCamera& camera) {
  const Eigen::Vector3d n0 = plane_from_disparity(plane, camera).normal;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> axes(cov_ab);
  double variance = 0.0;
  for (int k = 0; k < 2; ++k) {
    const Eigen::Vector2d step = axes.eigenvectors().col(k) * std::sqrt(std::max(0.0, axes.eigenvalues()(k)));
    const DisparityPlane moved{plane.a + step.x(), plane.b + step.y(), plane.c - step.dot(centroid_px)};
    const double cos_angle = std::min(1.0, std::abs(n0.dot(plane_from_disparity(moved, camera).normal)));
    const double angle = std::acos(cos_angle);
    variance += angle * angle;
  }
  return std::sqrt(variance);
}

DisparityPlane disparity_from_plane(const Plane3& plane, const StereoCamera& cam) {
  const double e = plane.offset;
  if (std::abs(e) < 1e-12)
    throw InputError("disparity_from_plane: plane passes through the camera centre (offset 0)");
  DisparityPlane out;
  out.a = -cam.baseline_m * plane.normal.x() / e;
  out.b = -cam.fx * cam.baseline_m * plane.normal.y() / (cam.fy * e);
  out.c = -cam.fx * cam.baseline_m * plane.normal.z() / e - out.a * cam.cx - out.b * cam.cy;
  return out;
}

Plane3 fit_plane(const Eigen::Ref<const Eigen::Matrix3Xd>& points) {
  if (points.cols() < 3) throw InputError("fit_plane: need at least 3 points");
  const Eigen::Vector3d centroid = points.rowwise().mean();
  const Eigen::Matrix3Xd centred = points.colwise() - centroid;
  const Eigen::Matrix3d scatter = centred * centred.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  Plane3 out;
  out.normal = solver.eigenvectors().col(0).normalized();
  out.offset = -out.normal.dot(centroid);
  return out;
}

}  // namespace planecell
