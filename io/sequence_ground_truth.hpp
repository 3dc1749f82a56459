#pragma once
/// Ground-truth surface ids stored beside a KITTI-odometry-layout sequence by `planecell synth`
/// (surface_0/<frame>.png, 16-bit); the GT disparity (disp_occ_0/) is read by io/stereo_datasets.
#include <cstddef>
#include <opencv2/core/mat.hpp>

#include "io/kitti_odometry.hpp"

namespace planecell::io {

/// True when the sequence has per-frame surface ids (surface_0/).
bool has_surface_ground_truth(const KittiOdometrySequence& sequence);

/// GT surface ids of frame `index` (CV_16U), empty when the sequence has none for it. Throws
/// InputError naming the file when it is unreadable, not 16-bit single-channel, or not width×height.
cv::Mat load_surface_ids(const KittiOdometrySequence& sequence, std::size_t index, int width, int height);

}  // namespace planecell::io
