#pragma once
/// Per-frame value types that flow through the pipeline.
#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <optional>

#include "core/pose.hpp"
#include "core/stereo_camera.hpp"

namespace planecell {

/// A rectified stereo frame as it enters the pipeline.
struct StereoFrame {
  std::uint64_t frame_id = 0;
  double timestamp_s = 0.0;
  cv::Mat left;   ///< CV_8UC3 (BGR) or CV_8UC1, rectified
  cv::Mat right;  ///< same size and type as left
  StereoCamera camera;
  std::optional<Pose> pose;  ///< T_world_cam of the left camera, when known
};

/// Ground truth that comes with a frame (synthetic renderer, KITTI/Middlebury GT).
struct FrameGroundTruth {
  cv::Mat disparity;   ///< CV_32F px, NaN = unknown
  cv::Mat surface_id;  ///< CV_16U surface ids (synthetic only), empty otherwise
};

/// Disparity convention inside the library: CV_32F, pixels, NaN = invalid.
bool is_valid_disparity(float d);

}  // namespace planecell
