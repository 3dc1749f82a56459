#pragma once
/// The paper's voxel baseline: an OctoMap ColorOcTree (default 10 cm) holding occupied voxels with
/// their average colour, fed with points back-projected from a disparity map.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <span>
#include <vector>

#include "core/config/map_config.hpp"
#include "core/pose.hpp"
#include "core/stereo_camera.hpp"

namespace octomap {
class ColorOcTree;
}

namespace planecell::voxel {

using Rgb = std::array<std::uint8_t, 3>;  ///< R, G, B

/// World-frame points with their colours and the sensor origin they were seen from.
struct ColouredPoints {
  std::vector<Eigen::Vector3f> points_m;
  std::vector<Rgb> rgb;
  Eigen::Vector3f origin_m = Eigen::Vector3f::Zero();
};

/// Back-projects every valid disparity (finite, > 0) of a CV_32F map to the world:
///   X_cam = ((u − cx) Z / fx, (v − cy) Z / fy, Z), Z = fx·B / d;  X_world = T_world_cam · X_cam,
/// keeping points with ‖X_cam‖ ≤ max_range_m, coloured from the BGR CV_8UC3 image (or CV_8UC1).
/// `stride` samples every stride-th row and column. Throws InputError on type/size mismatches.
ColouredPoints back_project(const cv::Mat& disparity_px, const cv::Mat& image,
                            const StereoCamera& camera, const Pose& T_world_cam,
                            double max_range_m, int stride = 1);

/// Timing and counts of one insertion.
struct VoxelInsertStats {
  std::size_t points = 0;
  std::size_t voxels = 0;  ///< distinct voxels hit by the points
  double insert_ms = 0.0;
};

/// Voxel map sizes.
struct VoxelMapStats {
  std::size_t occupied_voxels = 0;  ///< at full resolution (pruned leaves counted as 8^k voxels)
  std::size_t memory_bytes = 0;     ///< ColorOcTree::memoryUsage()
  std::size_t ot_bytes = 0;         ///< size of the full .ot serialisation (with colour)
  std::size_t bt_bytes = 0;  ///< size of the binary .bt serialisation (occupancy only), as
                             ///< writeBinaryConst writes it (counted without calling it)
};

class VoxelMap {
 public:
  /// Throws ConfigError on a non-positive resolution or range.
  explicit VoxelMap(const VoxelConfig& config = {});
  ~VoxelMap();
  VoxelMap(const VoxelMap&) = delete;
  VoxelMap& operator=(const VoxelMap&) = delete;

  /// Inserts a frame's points. Default (paper): the points are binned per voxel; each voxel hit
  /// gets one occupancy update (updateNode, no free-space ray casting) and the mean colour of its
  /// points (integrateNodeColor; the first observation sets the colour exactly, later ones blend
  /// with OctoMap's occupancy-weighted rule). With config.ray_casting: insertPointCloud from
  /// `points.origin_m` (free space carved along each ray, max_range_m), then the same colours.
  /// Throws InputError when points and colours differ in count.
  VoxelInsertStats insert(const ColouredPoints& points);

  /// Sizes of the map; prints nothing (OctoMap's debug-enabled writeBinaryConst is not called).
  VoxelMapStats stats() const;
  std::size_t occupied_voxels() const;
  /// The centres of the occupied voxels at full resolution (a pruned leaf of edge 2^k·r stands for
  /// its 8^k voxels, each listed), in OctoMap's leaf order.
  std::vector<Eigen::Vector3d> occupied_centres() const;
  double resolution_m() const { return config_.resolution_m; }
  /// Colour of the occupied voxel containing `point`, nullopt when none.
  std::optional<Rgb> colour_at(const Eigen::Vector3d& point) const;
  const octomap::ColorOcTree& tree() const { return *tree_; }

 private:
  VoxelConfig config_;
  std::unique_ptr<octomap::ColorOcTree> tree_;
};

}  // namespace planecell::voxel
