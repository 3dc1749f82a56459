#include "services/eval/map_completeness.hpp"

#include <cmath>
#include <string>

#include "core/error.hpp"

namespace planecell::services::eval {

std::vector<Eigen::Vector3d> gt_points_world(const cv::Mat& gt_disparity, const StereoCamera& camera,
                                             const Pose& T_world_cam, int stride, double max_range_m) {
  if (gt_disparity.type() != CV_32F)
    throw InputError("map completeness: GT disparity must be CV_32F, got type " + std::to_string(gt_disparity.type()));
  if (stride < 1) throw InputError("map completeness: stride must be >= 1, got " + std::to_string(stride));
  if (!T_world_cam.matrix().allFinite()) throw InputError("map completeness: the GT pose is not finite");
  std::vector<Eigen::Vector3d> points;
  for (int v = stride / 2; v < gt_disparity.rows; v += stride) {
    const float* row = gt_disparity.ptr<float>(v);
    for (int u = stride / 2; u < gt_disparity.cols; u += stride) {
      const double d = row[u];
      if (!(d > 0.0) || !std::isfinite(d)) continue;
      const Eigen::Vector3d X = camera.back_project(u, v, d);
      if (X.z() > max_range_m) continue;
      points.push_back(T_world_cam * X);
    }
  }
  return points;
}

MapCompleteness map_completeness(const map::GlobalMap& map, std::span<const Eigen::Vector3d> points) {
  MapCompleteness c;
  c.points = points.size();
  if (points.empty()) return c;
  std::array<std::size_t, kCompletenessDistancesM.size()> hits{};
  for (const Eigen::Vector3d& p : points) {
    const auto nearest = map.nearest_cell(p, kCompletenessDistancesM.back());
    if (!nearest) continue;
    for (std::size_t i = 0; i < hits.size(); ++i)
      if (nearest->distance_m <= kCompletenessDistancesM[i]) ++hits[i];
  }
  for (std::size_t i = 0; i < hits.size(); ++i)
    c.within[i] = static_cast<double>(hits[i]) / static_cast<double>(points.size());
  return c;
}

}  // namespace planecell::services::eval
