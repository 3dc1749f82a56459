#pragma once
/// Stereo pairs with ground-truth disparity: Middlebury 2001–2006 and 2014, KITTI stereo 2012/2015,
/// Scene Flow (FlyingThings3D, Monkaa, Driving) and synthetic sequences (planecell synth). Used by eval-stereo and the tests.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/stereo_camera.hpp"

namespace planecell::io {

enum class StereoDataset { kMiddlebury, kKitti, kSceneFlow, kSynthetic };

/// Parses "middlebury" | "kitti" | "sceneflow" | "synthetic" (throws ConfigError otherwise).
StereoDataset parse_stereo_dataset(const std::string& name);

/// Where one pair and its ground truth live (found by find_stereo_samples).
struct StereoSampleRef {
  StereoDataset dataset = StereoDataset::kMiddlebury;
  std::string name;  ///< e.g. "teddy", "kitti2015/000000_10", "seq/000004"
  std::filesystem::path left, right;
  std::filesystem::path gt_disparity;      ///< all pixels with GT (occluded included)
  std::filesystem::path gt_disparity_noc;  ///< non-occluded GT, empty when the dataset has none
  /// Scene Flow: occlusion mask (non-zero = occluded in the right view); the non-occluded GT is
  /// gt_disparity with these pixels unknown. Empty when absent.
  std::filesystem::path occlusion_mask;
  double gt_scale = 1.0;  ///< stored value / gt_scale = disparity (Middlebury 8-bit, KITTI 256)
};

/// A loaded pair. Disparities are CV_32F px with NaN = unknown.
struct StereoSample {
  std::string name;
  cv::Mat left, right;      ///< CV_8UC3 BGR
  cv::Mat gt_disparity;     ///< all GT pixels
  cv::Mat gt_disparity_noc; ///< empty when not available
  std::optional<StereoCamera> camera;  ///< when the dataset gives calibration
  int max_disparity = 0;    ///< suggested search range (≥ max GT disparity, multiple of 16)
};

/// Every pair with ground truth under `root` (searched recursively, sorted by name).
/// Throws InputError when root does not exist; returns empty when nothing is found.
std::vector<StereoSampleRef> find_stereo_samples(StereoDataset dataset,
                                                 const std::filesystem::path& root);

/// Loads a pair. Throws InputError naming the file on a missing/corrupt image or size mismatch.
StereoSample load_stereo_sample(const StereoSampleRef& ref);

}  // namespace planecell::io
