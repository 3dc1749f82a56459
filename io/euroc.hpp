#pragma once
/// EuRoC MAV sequences (ASL layout): mav0/cam0, mav0/cam1 (data.csv + data/*.png + sensor.yaml),
/// ground truth as a TUM file ("t tx ty tz qx qy qz qw") or the EuRoC csv
/// (state_groundtruth_estimate0/data.csv). The raw pair is rectified with OpenCV on load.
#include <cstdint>
#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <vector>

#include "core/frame.hpp"
#include "core/pose.hpp"
#include "core/stereo_camera.hpp"

namespace planecell::io {

/// One raw EuRoC camera from its sensor.yaml.
struct EurocCameraCalibration {
  cv::Mat K;            ///< 3×3 CV_64F [fu 0 cu; 0 fv cv; 0 0 1]
  cv::Mat distortion;   ///< 1×4 CV_64F radial-tangential k1 k2 p1 p2
  Pose T_body_sensor = Pose::Identity();  ///< T_BS: sensor frame → body (IMU) frame
  int width = 0;
  int height = 0;
};

/// Parses a EuRoC camera sensor.yaml (the leading "%YAML:1.0" line is tolerated). Only the
/// pinhole model with radial-tangential distortion is accepted. Throws InputError naming the file
/// and key on a missing/malformed entry.
EurocCameraCalibration read_euroc_camera(const std::filesystem::path& sensor_yaml);

/// A time-stamped pose of the body (IMU) frame in the world: T_W_B.
struct StampedPose {
  std::int64_t timestamp_ns = 0;
  Pose pose = Pose::Identity();
};

/// Reads ground truth: a TUM file ("t[s] tx ty tz qx qy qz qw", '#' comments) or, for a .csv, the
/// EuRoC state estimate ("t[ns], px, py, pz, qw, qx, qy, qz, ..."). Sorted by time on return.
/// Quaternions are normalised; errors name the file and line.
std::vector<StampedPose> read_euroc_groundtruth(const std::filesystem::path& path);

/// The sample nearest in time to `timestamp_ns`, or nullopt when it is farther than
/// `max_gap_ns` (or `trajectory` is empty). `trajectory` must be sorted by time.
std::optional<Pose> nearest_pose(const std::vector<StampedPose>& trajectory,
                                 std::int64_t timestamp_ns, std::int64_t max_gap_ns);

/// An opened EuRoC sequence with its rectification.
struct EurocSequence {
  std::filesystem::path mav0;
  EurocCameraCalibration raw_left, raw_right;  ///< cam0, cam1 as calibrated
  StereoCamera camera;  ///< rectified pair: fx = fy, shared (cx, cy), baseline = |t_cam1_cam0|
  /// Rotation of the rectified left camera w.r.t. raw cam0 (R1 of cv::stereoRectify):
  /// X_rect = R_rect_left · X_cam0.
  Eigen::Matrix3d R_rect_left = Eigen::Matrix3d::Identity();
  cv::Mat left_map1, left_map2, right_map1, right_map2;  ///< cv::remap maps (CV_16SC2 + CV_16UC1)
  std::vector<std::int64_t> timestamps_ns;  ///< stereo pairs (cam0 and cam1 share the stamp)
  std::vector<std::filesystem::path> left_images, right_images;
  /// T_W_camrect = T_WB(t) · T_BS(cam0) · R_rect_leftᵀ per frame; nullopt when no GT sample
  /// lies within 20 ms of the frame (or there is no ground truth).
  std::vector<std::optional<Pose>> poses;
  std::filesystem::path groundtruth_file;  ///< empty when none was found
  std::size_t size() const { return timestamps_ns.size(); }
};

/// Maximal gap between a frame and its ground-truth sample (20 ms).
inline constexpr std::int64_t kEurocMaxGroundTruthGapNs = 20'000'000;

/// Opens `mav0_or_root` (the mav0 folder or the folder holding it). Ground truth: `gt_file`
/// when given; else mav0/state_groundtruth_estimate0/data.csv; else the only *.txt in
/// <root>/groundtruth/; else no poses. Rectifies with cv::stereoRectify (CALIB_ZERO_DISPARITY,
/// alpha 0) and pairs cam0/cam1 images by equal timestamps (data.csv rows whose image is
/// absent are skipped with a warning). Throws InputError on a missing
/// folder/calibration/image or when no stereo pair exists.
EurocSequence open_euroc(const std::filesystem::path& mav0_or_root,
                         const std::optional<std::filesystem::path>& gt_file = std::nullopt);

/// Loads frame `index`: decodes both raw images, rectifies them (bilinear remap) and returns
/// BGR CV_8UC3 images with the rectified camera, timestamp (s) and pose.
StereoFrame load_euroc_frame(const EurocSequence& sequence, std::size_t index);

}  // namespace planecell::io
