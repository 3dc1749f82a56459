#include "services/bench/voxel_accuracy.hpp"

#include <octomap/ColorOcTree.h>

#include <cmath>
#include <limits>

namespace planecell::services::bench {

eval::AccuracyCurve voxel_accuracy_curve(const cv::Mat& sgm_disparity, const cv::Mat& gt_disparity,
                                         const StereoCamera& camera, const Pose& T_world_cam,
                                         const voxel::VoxelMap& voxels, double max_range_m,
                                         double curve_max_m, int curve_steps) {
  constexpr double kNoPoint = std::numeric_limits<double>::quiet_NaN();
  const octomap::ColorOcTree& tree = voxels.tree();
  // Same arithmetic as voxel::back_project (float pose on the double camera point), so that each
  // point lands in the voxel the map inserted it into.
  const Eigen::Isometry3f world_from_cam = T_world_cam.cast<float>();
  const Pose cam_from_world = T_world_cam.inverse();
  eval::AccuracyCurve curve(curve_max_m, curve_steps);
  // The GT pixels and "SGM has a point" come from the one Table 1 definition; the distance is
  // replaced by the voxel centre's.
  eval::for_each_point_distance(
      sgm_disparity, gt_disparity, camera, [&](int u, int v, double ray_distance_m) {
        if (std::isnan(ray_distance_m)) {
          curve.add(kNoPoint);
          return;
        }
        const Eigen::Vector3d x_cam = camera.back_project(u, v, sgm_disparity.at<float>(v, u));
        if (x_cam.norm() > max_range_m) {
          curve.add(kNoPoint);
          return;
        }
        const Eigen::Vector3f x_world = world_from_cam * x_cam.cast<float>();
        octomap::OcTreeKey key;
        if (!tree.coordToKeyChecked(octomap::point3d(x_world.x(), x_world.y(), x_world.z()), key)) {
          curve.add(kNoPoint);
          return;
        }
        const octomap::ColorOcTreeNode* node = tree.search(key);
        if (node == nullptr || !tree.isNodeOccupied(node)) {
          curve.add(kNoPoint);
          return;
        }
        const octomap::point3d c = tree.keyToCoord(key);
        const Eigen::Vector3d centre_cam = cam_from_world * Eigen::Vector3d(c.x(), c.y(), c.z());
        const Eigen::Vector3d gt_cam = camera.back_project(u, v, gt_disparity.at<float>(v, u));
        curve.add((centre_cam - gt_cam).norm());
      });
  return curve;
}

}  // namespace planecell::services::bench
