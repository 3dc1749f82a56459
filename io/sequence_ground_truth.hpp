#pragma once
/// Ground truth stored beside a KITTI-odometry-layout sequence (written by `planecell synth`):
/// surface ids (surface_0/<frame>.png, 16-bit) and disparity (disp_occ_0/<frame>.png, KITTI 16-bit).
#include <cstddef>
#include <opencv2/core/mat.hpp>

#include "io/kitti_odometry.hpp"

namespace planecell::io {

/// True when the sequence has per-frame surface ids (surface_0/).
bool has_surface_ground_truth(const KittiOdometrySequence& sequence);

/// GT surface ids of frame `index` (CV_16U), empty when the sequence has none for it. Throws
/// InputError naming the file when it is unreadable, not 16-bit single-channel, or not width×height.
cv::Mat load_surface_ids(const KittiOdometrySequence& sequence, std::size_t index, int width, int height);

/// True when the sequence has per-frame GT disparity (disp_occ_0/).
bool has_disparity_ground_truth(const KittiOdometrySequence& sequence);

/// GT disparity of frame `index` (CV_32F px, NaN = none: KITTI value / 256, 0 = none), empty when
/// the sequence has none for it. Throws InputError naming the file when it is unreadable or not
/// width×height.
cv::Mat load_disparity_ground_truth(const KittiOdometrySequence& sequence, std::size_t index,
                                    int width, int height);

}  // namespace planecell::io
