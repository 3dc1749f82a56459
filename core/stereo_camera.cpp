#include "core/stereo_camera.hpp"

#include <cmath>
#include <limits>

#include "core/error.hpp"

namespace planecell {

double StereoCamera::depth_from_disparity(double disparity_px) const {
  if (!(disparity_px > 0.0)) return std::numeric_limits<double>::infinity();
  return fx * baseline_m / disparity_px;
}

double StereoCamera::disparity_from_depth(double depth_m) const { return fx * baseline_m / depth_m; }

Eigen::Vector3d StereoCamera::back_project(double u_px, double v_px, double disparity_px) const {
  const double z = depth_from_disparity(disparity_px);
  return {(u_px - cx) * z / fx, (v_px - cy) * z / fy, z};
}

Eigen::Vector3d StereoCamera::project(const Eigen::Vector3d& p) const {
  return {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy, fx * baseline_m / p.z()};
}

void StereoCamera::validate(const std::string& source) const {
  auto check = [&](double value, const char* name) {
    if (!std::isfinite(value) || value <= 0.0)
      throw ConfigError(source + ": " + name + " must be finite and > 0, got " +
                        std::to_string(value));
  };
  check(fx, "fx");
  check(fy, "fy");
  check(baseline_m, "baseline");
  if (!std::isfinite(cx) || !std::isfinite(cy))
    throw ConfigError(source + ": principal point (cx, cy) must be finite");
  if (width < 0 || height < 0) throw ConfigError(source + ": image size must be >= 0");
}

}  // namespace planecell
