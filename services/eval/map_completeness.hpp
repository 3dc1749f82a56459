#pragma once
/// How much of what the camera saw the global map holds, and how close: ground-truth points of
/// the views (back-projected GT disparity, moved to the world with the GT pose) against the map's
/// stored planecells. Per-frame planes can be exact while the map drops or misplaces them (range
/// gate, pruning, fusion, pose error); this scores the map a planner queries.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <opencv2/core/mat.hpp>
#include <span>
#include <vector>

#include "core/pose.hpp"
#include "core/stereo_camera.hpp"
#include "mapping/map/global_map.hpp"

namespace planecell::services::eval {

/// Distances at which MapCompleteness counts a GT point as held by the map (m).
inline constexpr std::array<double, 3> kCompletenessDistancesM = {0.10, 0.20, 0.50};

struct MapCompleteness {
  std::size_t points = 0;  ///< GT points scored
  /// Share of the points with a stored planecell within kCompletenessDistancesM[i]
  /// (GlobalMap::nearest_cell: point-to-plane inside the polygon, to the boundary outside).
  std::array<double, kCompletenessDistancesM.size()> within{};
};

/// World points of the pixels (u, v) = (stride·i + stride/2, stride·j + stride/2) with GT disparity
/// d > 0 (CV_32F, the left image's size) whose depth Z = f_x·B/d is at most max_range_m:
/// X_world = T_world_cam · camera.back_project(u, v, d). Throws InputError on a disparity image
/// that is not CV_32F, a stride < 1 or a non-finite pose.
std::vector<Eigen::Vector3d> gt_points_world(const cv::Mat& gt_disparity, const StereoCamera& camera,
                                             const Pose& T_world_cam, int stride, double max_range_m);

/// Scores `points` against `map` (an empty point list scores 0 points, all shares 0).
MapCompleteness map_completeness(const map::GlobalMap& map, std::span<const Eigen::Vector3d> points);

}  // namespace planecell::services::eval
