/// Planecell extraction pipeline (paper §4.2–5.1): superpixels → planes → depth-aware boundary
/// update → planes again → vertices, 2D→3D, attributes, dense disparity.
#include "mapping/planecell/extraction.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "mapping/planecell/conversion_3d.hpp"
#include "mapping/planecell/photometric_planes.hpp"
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
  if (c.photometric_iterations < 0 || c.photometric_sample_step < 1)
    fail("photometric_iterations must be >= 0 and photometric_sample_step >= 1");
  if (!(c.photometric_min_gradient >= 0.0) || !(c.photometric_huber_grey > 0.0) ||
      !(c.photometric_max_shift_px > 0.0) || !(c.photometric_min_cost_ratio > 0.0 && c.photometric_min_cost_ratio <= 1.0))
    fail("photometric_min_gradient must be >= 0, photometric_huber_grey and photometric_max_shift_px > 0, "
         "photometric_min_cost_ratio in (0, 1]");
}

/// Twice the distance of 8-bit value v from level 0's centre, 2v − 63 = 128·t before clamping:
/// integers, so the weights are exact in 1/128.
constexpr SoftBinTable make_soft_bin_table() {
  SoftBinTable table;
  for (int v = 0; v < 256; ++v) {
    const int t128 = std::clamp(2 * v - 63, 0, 3 * 128);
    SoftBin& bin = table[v];
    bin.lo = std::min(t128 / 128, 2);
    const auto hi = static_cast<std::uint32_t>(t128 - 128 * bin.lo);
    bin.w = {kSoftBinUnit - hi, hi};
  }
  return table;
}
constexpr SoftBinTable kSoftBins = make_soft_bin_table();

/// Mean colour (R, G, B) and normalised 64-bin soft colour histogram (soft_bin_table) of every
/// cell, in one raster pass over runs of equal labels; `area` is each cell's pixel count. A
/// pixel adds 8 integer weights (products of its channels' table weights), so the sums are exact.
void describe_colours(const cv::Mat& bgr, const std::vector<std::int32_t>& labels,
                      const std::vector<std::int32_t>& area, std::vector<Planecell>& cells) {
  const std::size_t n = cells.size();
  std::vector<std::array<std::int64_t, 3>> rgb_sum(n, {0, 0, 0});
  std::vector<std::uint64_t> weights(n * kColourHistogramBins, 0);  // in units of 1/kSoftBinUnit³
  for (int v = 0; v < bgr.rows; ++v) {
    const auto* px = bgr.ptr<cv::Vec3b>(v);
    const std::int32_t* row = labels.data() + static_cast<std::size_t>(v) * bgr.cols;
    for (int u = 0; u < bgr.cols;) {
      const int l = row[u];
      std::int64_t r = 0, g = 0, b = 0;
      std::uint64_t* w = weights.data() + static_cast<std::size_t>(l) * kColourHistogramBins;
      for (; u < bgr.cols && row[u] == l; ++u) {
        const SoftBin& sr = kSoftBins[px[u][2]];
        const SoftBin& sg = kSoftBins[px[u][1]];
        const SoftBin& sb = kSoftBins[px[u][0]];
        r += px[u][2];
        g += px[u][1];
        b += px[u][0];
        const int base = sr.lo * 16 + sg.lo * 4 + sb.lo;
        for (int dr = 0; dr < 2; ++dr)
          for (int dg = 0; dg < 2; ++dg) {
            const std::uint32_t wrg = sr.w[dr] * sg.w[dg];
            if (wrg == 0) continue;
            w[base + dr * 16 + dg * 4] += static_cast<std::uint64_t>(wrg) * sb.w[0];
            w[base + dr * 16 + dg * 4 + 1] += static_cast<std::uint64_t>(wrg) * sb.w[1];
          }
      }
      rgb_sum[l][0] += r;
      rgb_sum[l][1] += g;
      rgb_sum[l][2] += b;
    }
  }
  constexpr double kPixelWeight = static_cast<double>(kSoftBinUnit) * kSoftBinUnit * kSoftBinUnit;
  for (std::size_t k = 0; k < n; ++k) {
    Planecell& cell = cells[k];
    cell.histogram.fill(0.0f);
    if (area[k] == 0) continue;
    const Eigen::Vector3d sum(static_cast<double>(rgb_sum[k][0]),
                              static_cast<double>(rgb_sum[k][1]),
                              static_cast<double>(rgb_sum[k][2]));
    cell.mean_rgb = (sum / area[k]).cast<float>();
    for (int q = 0; q < kColourHistogramBins; ++q)
      cell.histogram[q] = static_cast<float>(static_cast<double>(weights[k * kColourHistogramBins + q]) /
                                             (kPixelWeight * area[k]));
  }
}

/// 255 where a valid input disparity lies more than `threshold_px` off its segment's plane.
cv::Mat mark_outliers(const detail::SuperpixelState& s, double threshold_px) {
  cv::Mat outliers(s.height, s.width, CV_8U);
  for (int v = 0; v < s.height; ++v) {
    const std::int32_t* labels = s.labels.data() + static_cast<std::size_t>(v) * s.width;
    const float* disparity = s.disparity.data() + static_cast<std::size_t>(v) * s.width;
    auto* out = outliers.ptr<std::uint8_t>(v);
    for (int u = 0; u < s.width;) {  // one run of equal labels at a time
      const int l = labels[u];
      int end = u;
      while (end < s.width && labels[end] == l) ++end;
      if (!s.has_plane[l]) {
        std::fill(out + u, out + end, std::uint8_t{0});
      } else {
        const DisparityPlane plane = s.planes[l];
        for (; u < end; ++u) {  // branch-free: NaN compares false
          const double d = disparity[u];
          out[u] = std::abs(plane.at(u, v) - d) > threshold_px ? 255 : 0;
        }
      }
      u = end;
    }
  }
  return outliers;
}

}  // namespace

const SoftBinTable& soft_bin_table() { return kSoftBins; }

PlanecellFrame extract_planecells(const cv::Mat& left, const cv::Mat& disparity,
                                  const StereoCamera& camera, const ExtractionConfig& config) {
  return extract_planecells(left, cv::Mat(), disparity, camera, config);
}

PlanecellFrame extract_planecells(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity,
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
  if (!right.empty() && (right.size() != left.size() || (right.type() != CV_8UC3 && right.type() != CV_8UC1)))
    throw InputError("extract_planecells: the right image must be CV_8UC3 or CV_8UC1 of the left image's size");
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
  detail::fit_segment_planes(state, detail::gather_segment_samples(state), config, fits);
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
  const detail::SegmentSamples samples = detail::gather_segment_samples(state);
  detail::fit_segment_planes(state, samples, config, fits);
  frame.timings.planes_ms += elapsed_ms(t);

  // 4b. Photometric refinement of the planes against the pair (removes SGM's slant bias).
  if (!right.empty() && config.photometric_iterations > 0) {
    t = Clock::now();
    cv::Mat left_grey = left, right_grey = right;
    if (left.type() == CV_8UC3) cv::cvtColor(left, left_grey, cv::COLOR_BGR2GRAY);
    if (right.type() == CV_8UC3) cv::cvtColor(right, right_grey, cv::COLOR_BGR2GRAY);
    refine_planes_photometric(left_grey, right_grey, state.labels, state.planes, state.has_plane, config);
    frame.timings.photometric_ms = elapsed_ms(t);
  }

  // 5. Vertices, 2D→3D, attributes, dense disparity.
  t = Clock::now();
  const int w = state.width, h = state.height, n = state.num_segments;
  frame.cell_size_px = state.cell_size_px;
  frame.labels = cv::Mat(h, w, CV_32S);
  std::copy(state.labels.begin(), state.labels.end(), frame.labels.ptr<std::int32_t>(0));
  const auto polygons = extract_polygons(frame.labels, n, config.polygon_tolerance_px,
                                         config.junction_vertices_only);
  frame.cells.resize(n);
  describe_colours(bgr, state.labels, samples.area, frame.cells);
  int with_plane = 0;
  for (int k = 0; k < n; ++k) {
    Planecell& cell = frame.cells[k];
    cell.id = static_cast<std::uint32_t>(k);
    cell.has_plane = state.has_plane[k] != 0;
    cell.disparity_plane = state.planes[k];
    cell.area_px = static_cast<std::uint32_t>(samples.area[k]);
    cell.inlier_count = cell.has_plane ? static_cast<std::uint32_t>(fits.inliers[k]) : 0u;
    cell.inlier_ratio = fits.valid[k] > 0 && cell.has_plane
                            ? static_cast<float>(fits.inliers[k]) / fits.valid[k]
                            : 0.0f;
    if (cell.has_plane)  // 0 when the fit left no covariance
      cell.normal_sigma_rad = static_cast<float>(
          normal_sigma_rad(cell.disparity_plane, fits.slope_covariance[k], fits.inlier_centroid_px[k], camera));
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
  frame.outliers = mark_outliers(state, config.inlier_threshold_px);
  frame.timings.vertices_ms = elapsed_ms(t);
  frame.timings.total_ms = elapsed_ms(t_start);
  return frame;
}

}  // namespace planecell::extraction
