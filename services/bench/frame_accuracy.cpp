#include "services/bench/frame_accuracy.hpp"

#include "core/error.hpp"
#include "services/bench/voxel_accuracy.hpp"

namespace planecell::services::bench {

const char* representation_name(std::size_t representation) {
  switch (representation) {
    case kPlanecell:
      return "planecell";
    case kPoints:
      return "points";
    case kVoxel:
      return "voxel";
    default:
      return "?";
  }
}

Curves& operator+=(Curves& a, const Curves& b) {
  for (std::size_t r = 0; r < kRepresentations; ++r) a[r] += b[r];
  return a;
}

Curves score_frame(const FrameWork& work, const cv::Mat& gt_disparity,
                   const voxel::VoxelMap& voxels, double voxel_max_range_m) {
  const std::string frame = "bench: frame " + std::to_string(work.frame_id);
  if (work.disparity.empty() || work.cells.dense_disparity.empty())
    throw InputError(frame + " has no SGM or plane disparity to score (were the images released?)");
  if (!work.frame.pose) throw InputError(frame + " has no pose");
  const StereoCamera& camera = work.frame.camera;
  Curves curves;
  curves[kPlanecell] = eval::point_accuracy_curve(work.cells.dense_disparity, gt_disparity, camera);
  curves[kPoints] = eval::point_accuracy_curve(work.disparity, gt_disparity, camera);
  curves[kVoxel] = voxel_accuracy_curve(work.disparity, gt_disparity, camera, *work.frame.pose,
                                        voxels, voxel_max_range_m);
  return curves;
}

}  // namespace planecell::services::bench
