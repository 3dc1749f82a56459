#pragma once
/// Planecell extraction (paper §4.2–5.1): depth-aware superpixels, RANSAC planes, vertices, 2D→3D.
#include <array>
#include <cstdint>
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
  double photometric_ms = 0.0;   ///< photometric plane refinement (0 without a right image)
  double vertices_ms = 0.0;      ///< vertices, 2D→3D, cell attributes and the dense disparity
  double total_ms = 0.0;
};

/// One frame's planecells (camera frame).
struct PlanecellFrame {
  cv::Mat labels;                ///< CV_32S segment id per pixel, = index into `cells`
  std::vector<Planecell> cells;  ///< cells[i].id == i; planeless cells have has_plane = false
  cv::Mat dense_disparity;       ///< CV_32F, rendered from the planes (see render_dense_disparity)
  cv::Mat outliers;              ///< CV_8U, 255 where a valid input disparity is off its plane
  double plane_fraction = 0.0;   ///< share of segments with a plane
  int cell_size_px = 0;          ///< s = ⌊√(|I|/|S|)⌋, the initial grid step
  ExtractionTimings timings;
};

/// The cell colour histogram has 64 bins, 4 levels per channel (bin = 16·R + 4·G + B level),
/// with level k centred on 64k + 31.5. A pixel is spread over the 2 × 2 × 2 bins around its
/// colour (soft, trilinear binning): per channel value v, t = clamp((v − 31.5) / 64, 0, 3),
/// lo = min(⌊t⌋, 2), and level lo gets weight 1 − (t − lo), level lo + 1 gets t − lo; the bin's
/// weight is the product of its three channels'. A hard histogram jumps when a colour crosses a
/// level edge (a surface of mean 128 lands in either half by a shade of light or texture blur);
/// the soft one moves smoothly, so the CRF's histogram intersection compares colours, not edges.
inline constexpr std::uint32_t kSoftBinUnit = 128;  ///< weights are in 1/128 (exact for 8-bit v)
struct SoftBin {
  int lo = 0;                           ///< lower level (0..2)
  std::array<std::uint32_t, 2> w{};     ///< weights of lo and lo + 1, in 1/kSoftBinUnit; sum 128
};
/// soft bin of every 8-bit channel value
using SoftBinTable = std::array<SoftBin, 256>;
const SoftBinTable& soft_bin_table();

/// Extracts the planecells of a frame from its left colour image (CV_8UC3 BGR, or CV_8UC1) and
/// disparity (CV_32F, NaN = invalid, same size):
///  1. SEEDS-style block hill climbing on E(S) = H(S) + λ_reg·R(S) (no planes yet);
///  2. RANSAC + least-squares plane per segment;
///  3. depth-aware boundary update (λ_depth·D(S) on) at the finest block level and the pixels,
///     connectivity enforcement, and a second plane fit (failed segments are retried);
///  4. vertices, 2D→3D conversion, cell attributes and the dense plane disparity.
/// Throws InputError on empty images or size/type mismatches, ConfigError on a bad config.
PlanecellFrame extract_planecells(const cv::Mat& left, const cv::Mat& disparity,
                                  const StereoCamera& camera, const ExtractionConfig& config);

/// The same, with the right image of the rectified pair (grey or BGR, same size as `left`): after
/// the final plane fit every plane is refined photometrically against the pair
/// (photometric_planes.hpp; ExtractionConfig::photometric_iterations, 0 = off), which removes
/// SGM's slant bias from the planes. An empty `right` skips the refinement.
PlanecellFrame extract_planecells(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity,
                                  const StereoCamera& camera, const ExtractionConfig& config);

}  // namespace planecell::extraction
