#pragma once
/// Planecell extraction (paper §4.2–5.1): depth-aware superpixels, RANSAC planes, vertices, 2D→3D.
#include <opencv2/core/mat.hpp>
#include <vector>

#include "core/config/planecell_config.hpp"
#include "core/planecell.hpp"
#include "core/stereo_camera.hpp"

namespace planecell::extraction {

/// Wall-clock time of each extraction step (ms).
struct ExtractionTimings {
  double superpixels_ms = 0.0;
  double planes_ms = 0.0;
  double boundary_update_ms = 0.0;
  double vertices_ms = 0.0;
  double total_ms = 0.0;
};

/// One frame's planecells (camera frame).
struct PlanecellFrame {
  cv::Mat labels;                ///< CV_32S segment id per pixel, = index into `cells`
  std::vector<Planecell> cells;  ///< cells[i].id == i; planeless cells have has_plane = false
  cv::Mat dense_disparity;       ///< CV_32F, rendered from the planes (NaN where planeless)
  double plane_fraction = 0.0;   ///< share of segments with a plane
  ExtractionTimings timings;
};

/// Extracts the planecells of a frame from its left colour image (CV_8UC3 BGR, or CV_8UC1) and
/// disparity (CV_32F, NaN = invalid, same size). Throws InputError on size/type mismatches.
PlanecellFrame extract_planecells(const cv::Mat& left, const cv::Mat& disparity,
                                  const StereoCamera& camera, const ExtractionConfig& config);

}  // namespace planecell::extraction
