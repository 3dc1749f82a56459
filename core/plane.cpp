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
