#pragma once
/// Per-frame 3D accuracy of the three map representations the bench compares, on the same GT
/// pixels of the same frame (the paper's Fig. "Reconstruction accuracy" and Table 1).
#include <array>
#include <cstddef>
#include <opencv2/core/mat.hpp>

#include "mapping/voxel/voxel_map.hpp"
#include "services/eval/stereo_metrics.hpp"
#include "services/pipeline/stages.hpp"

namespace planecell::services::bench {

/// The representations, in report order.
enum Representation : std::size_t { kPlanecell = 0, kPoints = 1, kVoxel = 2, kRepresentations = 3 };

/// "planecell", "points", "voxel".
const char* representation_name(std::size_t representation);

/// One accuracy curve per representation (indexed by Representation).
using Curves = std::array<eval::AccuracyCurve, kRepresentations>;

/// Adds `b` to `a` curve by curve.
Curves& operator+=(Curves& a, const Curves& b);

/// Scores a replayed frame against its GT disparity (CV_32F px, NaN = none), every GT pixel once
/// per representation:
///  - planecell: the frame's dense plane disparity (PlanecellFrame::dense_disparity), X(u, v,
///  d_plane);
///  - points: the raw SGM disparity, X(u, v, d_sgm) (eval::point_accuracy_curve);
///  - voxel: the centre of the occupied voxel its SGM point falls in (voxel_accuracy_curve, with
///    the voxel map already holding this frame).
/// Throws InputError when the frame has no disparity, planecells or pose, or sizes differ.
Curves score_frame(const FrameWork& work, const cv::Mat& gt_disparity,
                   const voxel::VoxelMap& voxels, double voxel_max_range_m);

}  // namespace planecell::services::bench
