#pragma once
/// KITTI odometry layout: SEQ/{image_0,image_1 | image_2,image_3}/NNNNNN.png, SEQ/calib.txt,
/// SEQ/times.txt, poses in SEQ/poses/NN.txt (synthetic) or SEQ/../../poses/NN.txt (KITTI).
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/frame.hpp"
#include "core/pose.hpp"
#include "core/stereo_camera.hpp"

namespace planecell::io {

/// The four 3×4 projection matrices of a KITTI calib.txt (P0..P3), row-major.
struct KittiCalibration {
  std::array<std::array<double, 12>, 4> projection{};
};

/// Parses calib.txt ("P0: 12 numbers" ... "P3: ..."; other lines such as Tr are ignored), or
/// KITTI raw's calib_cam_to_cam.txt, whose "P_rect_00" … "P_rect_03" are read as P0 … P3.
/// Throws InputError naming the path and line when a P line is missing or malformed.
KittiCalibration read_kitti_calibration(const std::filesystem::path& path);
/// Writes P0..P3 (and Tr = identity) in KITTI format. Throws StorageError on failure.
void write_kitti_calibration(const std::filesystem::path& path, const KittiCalibration& calib);

/// Stereo camera of a camera pair (0/1 gray or 2/3 colour) from the projection matrices:
/// fx = P[0], cx = P[2], fy = P[5], cy = P[6], baseline = (P_left[3] − P_right[3]) / fx.
/// Throws InputError when the pair is not a valid rectified stereo pair.
StereoCamera stereo_camera_from_kitti(const KittiCalibration& calib, int left_index,
                                      int width, int height);

/// Reads a KITTI pose file: one row-major 3×4 T_world_cam0 per line. Each pose is validated
/// (NaN/Inf, orthonormal rotation); errors name the file and line.
std::vector<Pose> read_kitti_poses(const std::filesystem::path& path);
/// Writes poses in KITTI format (12 numbers per line, %.9e). Throws StorageError on failure.
void write_kitti_poses(const std::filesystem::path& path, const std::vector<Pose>& poses);

/// Reads times.txt (one time in seconds per line). Errors name the file and line.
std::vector<double> read_kitti_times(const std::filesystem::path& path);
void write_kitti_times(const std::filesystem::path& path, const std::vector<double>& times_s);
/// The image file name of frame `index` in the layout: six digits, zero-padded ("000042.png").
std::string kitti_frame_name(std::size_t index);

/// The pose file of a sequence folder, looked up in this order: SEQ/poses/<seqname>.txt;
/// SEQ/poses/00.txt or the only *.txt in SEQ/poses; SEQ/../../poses/<seqname>.txt (official
/// layout dataset/sequences/NN + dataset/poses/NN.txt). nullopt when none exists; InputError when
/// SEQ/poses holds several candidates and none of the expected names.
std::optional<std::filesystem::path> find_kitti_poses_file(
    const std::filesystem::path& sequence_dir);

/// An opened KITTI-odometry-layout sequence. Frames are loaded lazily by index.
struct KittiOdometrySequence {
  std::filesystem::path root;
  std::filesystem::path left_dir;   ///< image_2 (colour) or image_0 (gray)
  std::filesystem::path right_dir;  ///< image_3 or image_1
  StereoCamera camera;              ///< rectified pair of left_dir/right_dir
  Pose T_cam0_left = Pose::Identity();  ///< offset of the used left camera from cam0
  std::vector<std::filesystem::path> left_images;   ///< sorted
  std::vector<std::filesystem::path> right_images;  ///< same names as left
  std::vector<double> times_s;      ///< empty when times.txt is absent
  std::vector<Pose> poses;          ///< T_world_left (cam0 poses × T_cam0_left); may be empty
  std::size_t size() const { return left_images.size(); }
};

/// Opens a sequence. Prefers the colour pair (image_2/3) and falls back to gray (image_0/1).
/// `poses_file` overrides the pose lookup. Throws InputError with a clear message when the
/// folder, calibration or images are missing or inconsistent (counts, poses vs frames).
KittiOdometrySequence open_kitti_odometry(const std::filesystem::path& sequence_dir,
                                          const std::optional<std::filesystem::path>& poses_file =
                                              std::nullopt);

/// Throws InputError naming `image` when width×height differs from the sequence's camera size
/// (when the calibration gives one).
void check_frame_size(const KittiOdometrySequence& sequence, const std::filesystem::path& image, int width,
                      int height);

/// Loads frame `index`: decodes both images (colour BGR; the right one on a second thread at the
/// same time), checks equal sizes, attaches the camera, timestamp and pose. Throws InputError
/// naming the image on failure.
StereoFrame load_kitti_frame(const KittiOdometrySequence& sequence, std::size_t index);

}  // namespace planecell::io
