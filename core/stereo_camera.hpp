#pragma once
/// Rectified pinhole stereo camera: intrinsics of the left (reference) camera and the baseline.
#include <Eigen/Core>
#include <string>

namespace planecell {

/// A rectified stereo pair: both cameras share fx, fy, cx, cy; the right camera sits
/// `baseline_m` to the right of the left one. Disparity d = u_left - u_right > 0.
///   depth:          Z = fx * B / d
///   back-projection X = (u - cx) Z / fx,  Y = (v - cy) Z / fy
///   projection      u = fx X / Z + cx,    v = fy Y / Z + cy,   d = fx B / Z
struct StereoCamera {
  double fx = 721.5377;  ///< focal length in px (x), KITTI default
  double fy = 721.5377;  ///< focal length in px (y)
  double cx = 609.5593;  ///< principal point (px)
  double cy = 172.854;
  double baseline_m = 0.5372;  ///< distance between the optical centres (m)
  int width = 1242;            ///< image size (px); 0 when unknown
  int height = 375;

  /// Depth (m) of a disparity (px): Z = fx·B/d. Returns +inf for d <= 0.
  double depth_from_disparity(double disparity_px) const;
  /// Disparity (px) of a depth (m): d = fx·B/Z.
  double disparity_from_depth(double depth_m) const;
  /// 3D point in the left camera frame of pixel (u, v) with disparity d (exact).
  Eigen::Vector3d back_project(double u_px, double v_px, double disparity_px) const;
  /// (u, v, d) of a 3D point in the left camera frame (Z must be > 0).
  Eigen::Vector3d project(const Eigen::Vector3d& point_cam) const;

  /// Throws ConfigError naming the bad field when a value is non-finite or non-positive.
  void validate(const std::string& source = "camera") const;
};

}  // namespace planecell
