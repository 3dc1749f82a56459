#pragma once
/// EuRoC → KITTI odometry layout: a EuRoC MAV sequence, rectified, written so that `replay`,
/// `feed`, `bench` and `eval` read it like any other sequence.
#include <cstddef>
#include <filesystem>
#include <vector>

#include "io/euroc.hpp"

namespace planecell::io {

/// What write_euroc_as_kitti wrote.
struct EurocExport {
  std::size_t frames = 0;          ///< stereo pairs written (those with a ground-truth pose)
  std::size_t skipped_frames = 0;  ///< pairs without a ground-truth pose within 20 ms
  StereoCamera camera;             ///< the rectified pair (calib.txt)
  std::vector<Pose> poses;         ///< poses/00.txt as written (first frame = identity)
};

/// Writes the frames of `sequence` that have a ground-truth pose to `out_dir` in KITTI odometry
/// layout: image_0/NNNNNN.png and image_1/NNNNNN.png (rectified grey, renumbered from 0),
/// calib.txt with P0 = P2 = [f 0 c_x 0; 0 f c_y 0; 0 0 1 0] and P1 = P3 with −f·B in the last
/// column of the first row, times.txt (seconds since the first written frame) and poses/00.txt.
/// Poses are expressed in the first written frame's rectified camera: P_i = T_0⁻¹ · T_i with
/// T_i = T_W_camrect(t_i), so the world is KITTI's (x right, y down, z forward at frame 0).
/// Throws InputError when no frame has a pose, StorageError when the output cannot be written.
EurocExport write_euroc_as_kitti(const EurocSequence& sequence, const std::filesystem::path& out_dir);

}  // namespace planecell::io
