/// Planecell extraction pipeline (paper §4.2–5.1): superpixels → planes → depth-aware boundary
/// update → planes again → vertices, 2D→3D, attributes, dense disparity.
#include "mapping/planecell/extraction.hpp"

#include <chrono>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "mapping/planecell/conversion_3d.hpp"
#include "mapping/planecell/superpixel_state.hpp"
#include "mapping/planecell/vertex_extraction.hpp"

namespace planecell::extraction {
namespace {

using Clock = std::chrono::steady_clock;

double elapsed_ms(Clock::time_point since) {
  return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

void validate(const ExtractionConfig& c) {
  auto fail = [](const std::string& what) { throw ConfigError("extraction." + what); };
  if (c.target_cells < 1) fail("target_cells must be >= 1");
  if (c.block_levels < 0 || c.iterations_per_level < 0 || c.pixel_iterations < 0 ||
      c.depth_iterations < 0)
    fail("block_levels and *_iterations must be >= 0");
  if (!(c.lambda_reg >= 0.0) || !(c.lambda_depth >= 0.0) || !std::isfinite(c.lambda_reg) ||
      !std::isfinite(c.lambda_depth))
    fail("lambda_reg and lambda_depth must be finite and >= 0");
  if (!(c.depth_truncation_px > 0.0)) fail("depth_truncation_px must be > 0");
  if (c.ransac_iterations < 1) fail("ransac_iterations must be >= 1");
  if (!(c.inlier_threshold_px > 0.0)) fail("inlier_threshold_px must be > 0");
  if (!(c.target_inlier_ratio > 0.0 && c.target_inlier_ratio <= 1.0))
    fail("target_inlier_ratio must be in (0, 1]");
  if (!(c.min_inlier_ratio >= 0.0 && c.min_inlier_ratio <= 1.0))
    fail("min_inlier_ratio must be in [0, 1]");
  if (!(c.min_valid_ratio >= 0.0 && c.min_valid_ratio <= 1.0))
    fail("min_valid_ratio must be in [0, 1]");
  if (!(c.polygon_tolerance_px >= 0.0)) fail("polygon_tolerance_px must be >= 0");
  if (!(c.max_time_ms >= 0.0)) fail("max_time_ms must be >= 0");
}

}  // namespace

PlanecellFrame extract_planecells(const cv::Mat& left, const cv::Mat& disparity,
                                  const StereoCamera& camera, const ExtractionConfig& config) {
  const auto t_start = Clock::now();
  if (left.empty()) throw InputError("extract_planecells: left image is empty");
  if (left.type() != CV_8UC3 && left.type() != CV_8UC1)
    throw InputError("extract_planecells: left image must be CV_8UC3 (BGR) or CV_8UC1");
  if (disparity.empty() || disparity.type() != CV_32FC1)
    throw InputError("extract_planecells: disparity must be a non-empty CV_32F map");
  if (disparity.size() != left.size())
    throw InputError("extract_planecells: disparity is " + std::to_string(disparity.cols) + "x" +
                     std::to_string(disparity.rows) + " but the left image is " +
                     std::to_string(left.cols) + "x" + std::to_string(left.rows));
  validate(config);
  camera.validate("extract_planecells camera");

  cv::Mat bgr = left;
  if (left.type() == CV_8UC1) cv::cvtColor(left, bgr, cv::COLOR_GRAY2BGR);

  PlanecellFrame frame;
  detail::Deadline deadline;
  if (config.max_time_ms > 0.0) {
    deadline.enabled = true;
    deadline.end = t_start + std::chrono::microseconds(
                                 static_cast<long long>(config.max_time_ms * 1000.0));
  }

  // 1. Superpixels on colour + regularisation.
  auto t = Clock::now();
  detail::SuperpixelState state = detail::make_initial_state(bgr, disparity, config);
  detail::hill_climb(state, config.block_levels, 1, config.iterations_per_level,
                     config.pixel_iterations, deadline);
  frame.timings.superpixels_ms = elapsed_ms(t);

  // 2. First plane fit.
  t = Clock::now();
  detail::SegmentPlaneFits fits;
  detail::fit_segment_planes(state, detail::group_pixels(state), config, fits);
  frame.timings.planes_ms = elapsed_ms(t);

  // 3. Depth-aware boundary update, then connected, gap-free segments.
  t = Clock::now();
  state.weights.depth_enabled = config.lambda_depth > 0.0;
  detail::hill_climb(state, config.block_levels, config.block_levels, config.depth_iterations,
                     config.depth_iterations, deadline);
  detail::enforce_connectivity(state);
  frame.timings.boundary_update_ms = elapsed_ms(t);

  // 4. Final plane fit (segments that failed before are retried on their new boundaries).
  t = Clock::now();
  const detail::SegmentPixels groups = detail::group_pixels(state);
  detail::fit_segment_planes(state, groups, config, fits);
  frame.timings.planes_ms += elapsed_ms(t);

  // 5. Vertices, 2D→3D, attributes, dense disparity.
  t = Clock::now();
  const int w = state.width, h = state.height, n = state.num_segments;
  frame.cell_size_px = state.cell_size_px;
  frame.labels = cv::Mat(h, w, CV_32S);
  std::copy(state.labels.begin(), state.labels.end(), frame.labels.ptr<std::int32_t>(0));
  const auto polygons = extract_polygons(frame.labels, n, config.polygon_tolerance_px,
                                         config.junction_vertices_only);
  frame.cells.resize(n);
  int with_plane = 0;
  for (int k = 0; k < n; ++k) {
    Planecell& cell = frame.cells[k];
    cell.id = static_cast<std::uint32_t>(k);
    cell.has_plane = state.has_plane[k] != 0;
    cell.disparity_plane = state.planes[k];
    cell.area_px = static_cast<std::uint32_t>(groups.offsets[k + 1] - groups.offsets[k]);
    cell.inlier_count = cell.has_plane ? static_cast<std::uint32_t>(fits.inliers[k]) : 0u;
    cell.inlier_ratio =
        fits.valid[k] > 0 && cell.has_plane ? static_cast<float>(fits.inliers[k]) / fits.valid[k]
                                            : 0.0f;
    Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
    cell.histogram.fill(0.0f);
    for (int j = groups.offsets[k]; j < groups.offsets[k + 1]; ++j) {
      const int i = groups.pixels[j];
      const cv::Vec3b& px = bgr.at<cv::Vec3b>(i / w, i % w);
      rgb += Eigen::Vector3d(px[2], px[1], px[0]);
      cell.histogram[colour_histogram_bin(px[0], px[1], px[2])] += 1.0f;
    }
    if (cell.area_px > 0) {
      cell.mean_rgb = (rgb / cell.area_px).cast<float>();
      for (float& bin : cell.histogram) bin /= static_cast<float>(cell.area_px);
    }
    cell.vertices_px = polygons[k];
    convert_to_3d(cell, camera);
    if (cell.has_plane && !cell.vertices_m.empty()) {
      double z = 0.0;
      for (const auto& v : cell.vertices_m) z += v.z();
      z /= static_cast<double>(cell.vertices_m.size());
      const double sigma_d_px = config.inlier_threshold_px / std::sqrt(3.0);
      cell.depth_sigma_m = static_cast<float>(z * z * sigma_d_px / (camera.fx * camera.baseline_m));
    }
    with_plane += cell.has_plane;
  }
  frame.plane_fraction = n > 0 ? static_cast<double>(with_plane) / n : 0.0;
  frame.dense_disparity = render_dense_disparity(frame.labels, frame.cells, config.fill_planeless);
  if (config.background_fill_holes)
    prefer_background_in_holes(frame.dense_disparity, disparity, frame.labels, frame.cells);
  frame.outliers = cv::Mat::zeros(h, w, CV_8U);
  for (int i = 0; i < w * h; ++i) {
    const float d = state.disparity[i];
    const int l = state.labels[i];
    if (!std::isnan(d) && state.has_plane[l] &&
        std::abs(state.planes[l].at(i % w, i / w) - d) > config.inlier_threshold_px)
      frame.outliers.at<std::uint8_t>(i / w, i % w) = 255;
  }
  frame.timings.vertices_ms = elapsed_ms(t);
  frame.timings.total_ms = elapsed_ms(t_start);
  return frame;
}

}  // namespace planecell::extraction
