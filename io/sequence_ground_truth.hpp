#pragma once
/// Ground truth stored beside a KITTI-odometry-layout sequence (written by `planecell synth`):
/// disp_occ_0/<frame>.png (KITTI 16-bit disparity) and surface_0/<frame>.png (16-bit surface ids).
#include <cstddef>
#include <optional>

#include "core/frame.hpp"
#include "io/kitti_odometry.hpp"

namespace planecell::io {

/// True when the sequence has per-frame surface ids (surface_0/).
bool has_surface_ground_truth(const KittiOdometrySequence& sequence);

/// Ground truth of frame `index`: the disparity and/or surface ids that exist for it (empty
/// matrices for the parts that do not); nullopt when neither exists. Throws InputError naming the
/// file when one exists but is unreadable, of the wrong type, or not the size of the frame's images.
std::optional<FrameGroundTruth> load_sequence_ground_truth(const KittiOdometrySequence& sequence,
                                                           std::size_t index, int width, int height);

}  // namespace planecell::io
