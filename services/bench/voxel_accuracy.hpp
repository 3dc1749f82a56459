#pragma once
/// 3D accuracy of the voxel baseline (OctoMap ColorOcTree) on one frame's GT pixels.
#include <opencv2/core/mat.hpp>

#include "core/pose.hpp"
#include "core/stereo_camera.hpp"
#include "mapping/voxel/voxel_map.hpp"
#include "services/eval/stereo_metrics.hpp"

namespace planecell::services::bench {

/// For every GT pixel (u, v) of a frame, the distance from the centre of the occupied voxel that
/// its SGM point falls in to its GT point, exactly as voxel::back_project feeds the map:
///   X = X_cam(u, v, d_sgm), kept when ‖X‖ ≤ max_range_m (farther points are never inserted);
///   c = centre of the voxel (full resolution) containing T_world_cam·X, scored only when that
///       voxel is occupied in `voxels` (after this frame's insertion);
///   distance = ‖T_world_cam⁻¹·c − X_cam(u, v, d_gt)‖.
/// A pixel without an SGM disparity, out of range or in an unoccupied voxel counts as "no point".
/// Throws InputError on size/type mismatches (as eval::for_each_point_distance).
eval::AccuracyCurve voxel_accuracy_curve(const cv::Mat& sgm_disparity, const cv::Mat& gt_disparity,
                                         const StereoCamera& camera, const Pose& T_world_cam,
                                         const voxel::VoxelMap& voxels, double max_range_m,
                                         double curve_max_m = 1.0, int curve_steps = 100);

}  // namespace planecell::services::bench
