/// Boundary recall and single-surface cells of planecells against GT surface ids.
#include "services/eval/segmentation_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/error.hpp"
#include "io/image_io.hpp"
#include "mapping/planecell/extraction.hpp"
#include "mapping/stereo/sgm.hpp"

namespace planecell::services::eval {
namespace {

/// 255 where one of the pixel's 4-neighbours carries another id (CV_8U), for a CV_32S image.
cv::Mat boundary_mask(const cv::Mat& ids) {
  cv::Mat mask = cv::Mat::zeros(ids.size(), CV_8U);
  for (int v = 0; v < ids.rows; ++v) {
    const auto* row = ids.ptr<std::int32_t>(v);
    const auto* above = v > 0 ? ids.ptr<std::int32_t>(v - 1) : nullptr;
    const auto* below = v + 1 < ids.rows ? ids.ptr<std::int32_t>(v + 1) : nullptr;
    auto* out = mask.ptr<std::uint8_t>(v);
    for (int u = 0; u < ids.cols; ++u) {
      const std::int32_t id = row[u];
      const bool edge = (u > 0 && row[u - 1] != id) || (u + 1 < ids.cols && row[u + 1] != id) ||
                        (above && above[u] != id) || (below && below[u] != id);
      out[u] = edge ? 255 : 0;
    }
  }
  return mask;
}

double percent(long part, long whole) {
  return whole > 0 ? 100.0 * static_cast<double>(part) / static_cast<double>(whole)
                   : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

SegmentationScores& SegmentationScores::operator+=(const SegmentationScores& o) {
  gt_boundary_pixels += o.gt_boundary_pixels;
  recalled_boundary_pixels += o.recalled_boundary_pixels;
  cells += o.cells;
  single_surface_cells += o.single_surface_cells;
  return *this;
}

double SegmentationScores::boundary_recall_pct() const {
  return percent(recalled_boundary_pixels, gt_boundary_pixels);
}

double SegmentationScores::single_surface_pct() const {
  return percent(single_surface_cells, cells);
}

SegmentationScores evaluate_segmentation(const cv::Mat& labels, const cv::Mat& surfaces,
                                         const SegmentationOptions& options) {
  if (labels.empty() || labels.type() != CV_32SC1)
    throw InputError("evaluate_segmentation: labels must be a non-empty CV_32S image");
  if (surfaces.empty() || (surfaces.type() != CV_16UC1 && surfaces.type() != CV_32SC1))
    throw InputError("evaluate_segmentation: surfaces must be a non-empty CV_16U or CV_32S image");
  if (labels.size() != surfaces.size())
    throw InputError("evaluate_segmentation: labels are " + std::to_string(labels.cols) + "x" +
                     std::to_string(labels.rows) + " but surfaces " +
                     std::to_string(surfaces.cols) + "x" + std::to_string(surfaces.rows));
  if (options.boundary_tolerance_px < 0)
    throw ConfigError("evaluate_segmentation: boundary_tolerance_px must be >= 0");
  if (!(options.purity > 0.0 && options.purity <= 1.0))
    throw ConfigError("evaluate_segmentation: purity must be in (0, 1]");
  cv::Mat gt;
  surfaces.convertTo(gt, CV_32S);

  SegmentationScores scores;
  // Boundary recall: GT boundary pixels with a cell boundary pixel in their (2r+1)² window.
  const int r = options.boundary_tolerance_px;
  cv::Mat near_cell_boundary;
  cv::dilate(boundary_mask(labels), near_cell_boundary,
             cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * r + 1, 2 * r + 1)));
  const cv::Mat gt_boundary = boundary_mask(gt);
  scores.gt_boundary_pixels = cv::countNonZero(gt_boundary);
  scores.recalled_boundary_pixels = cv::countNonZero(gt_boundary & near_cell_boundary);

  // Single-surface cells: GT id histogram of every cell.
  double max_label = 0.0;
  cv::minMaxLoc(labels, nullptr, &max_label);
  double min_label = 0.0;
  cv::minMaxLoc(labels, &min_label);
  if (min_label < 0) throw InputError("evaluate_segmentation: labels must be >= 0");
  const int n = static_cast<int>(max_label) + 1;
  std::vector<std::unordered_map<std::int32_t, long>> counts(n);
  std::vector<long> area(n, 0);
  for (int v = 0; v < labels.rows; ++v) {
    const auto* cell = labels.ptr<std::int32_t>(v);
    const auto* id = gt.ptr<std::int32_t>(v);
    for (int u = 0; u < labels.cols; ++u) {
      ++counts[cell[u]][id[u]];
      ++area[cell[u]];
    }
  }
  for (int k = 0; k < n; ++k) {
    if (area[k] == 0) continue;
    long majority = 0;
    for (const auto& [surface, count] : counts[k]) majority = std::max(majority, count);
    ++scores.cells;
    scores.single_surface_cells +=
        static_cast<double>(majority) >= options.purity * static_cast<double>(area[k]);
  }
  return scores;
}

cv::Mat synthetic_surface_ids(const io::StereoSampleRef& ref) {
  const std::filesystem::path path =
      ref.left.parent_path().parent_path() / "surface_0" / ref.left.filename();
  if (!std::filesystem::is_regular_file(path)) return {};
  cv::Mat ids = io::read_image_unchanged(path);
  if (ids.type() != CV_16UC1)
    throw InputError("GT surface ids '" + path.string() +
                     "': expected a 16-bit single-channel image");
  return ids;
}

SegmentationScores planecell_segmentation(const io::StereoSample& sample, const cv::Mat& surfaces,
                                          const SgmConfig& sgm, const ExtractionConfig& extraction,
                                          const SegmentationOptions& options) {
  SgmConfig c = sgm;
  c.max_disparity = std::min(sample.max_disparity, sample.left.cols - 1);
  const cv::Mat raw = stereo::compute_disparity(sample.left, sample.right, c);
  const auto frame = extraction::extract_planecells(
      sample.left, raw, sample.camera.value_or(StereoCamera{}), extraction);
  return evaluate_segmentation(frame.labels, surfaces, options);
}

}  // namespace planecell::services::eval
