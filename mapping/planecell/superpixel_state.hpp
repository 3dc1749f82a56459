#pragma once
/// Internal state of the depth-aware superpixel segmentation (paper §4.2–4.5), shared by the
/// energy, hill-climbing and plane-fitting steps of mapping/planecell. Not a public API.
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/config/planecell_config.hpp"
#include "core/plane.hpp"

namespace planecell::extraction::detail {

/// Colour histogram of the energy's colour term H(S): Lab quantised into 5×5×5 bins.
inline constexpr int kEnergyBinsPerChannel = 5;
inline constexpr int kEnergyBins = kEnergyBinsPerChannel * kEnergyBinsPerChannel *
                                   kEnergyBinsPerChannel;

/// Weights of the block costs c1, c2 (see ExtractionConfig).
struct EnergyWeights {
  double reg_per_px2 = 0.0;       ///< λ_reg / s²
  double depth = 0.0;             ///< λ_depth
  double depth_truncation_px = 3.0;
  bool depth_enabled = false;     ///< the depth term acts once planes exist
};

/// Everything the hill climbing changes or reads. Pixel arrays are row-major, width × height.
struct SuperpixelState {
  int width = 0;
  int height = 0;
  int cell_size_px = 1;             ///< s = ⌊√(|I|/|S|)⌋
  std::vector<std::int32_t> labels;  ///< segment per pixel
  std::vector<std::uint8_t> bins;    ///< energy colour bin per pixel
  std::vector<float> disparity;      ///< px, NaN = invalid
  std::vector<double> disparity_sum;     ///< (W+1)×(H+1) integral of valid disparities
  std::vector<std::int32_t> valid_count; ///< (W+1)×(H+1) integral of valid-disparity counts

  int num_segments = 0;
  std::vector<std::int32_t> histogram;  ///< num_segments × kEnergyBins pixel counts h_{S_i}(q)
  std::vector<std::int32_t> size;       ///< |S_i| in pixels
  std::vector<double> sum_u, sum_v;     ///< Σu, Σv (μ_{S_i} = Σ / |S_i|)
  std::vector<DisparityPlane> planes;   ///< θ_{S_i}
  std::vector<std::uint8_t> has_plane;
  EnergyWeights weights;

  int index(int u, int v) const { return v * width + u; }
  /// Mean valid disparity d̄_b of the pixel rectangle [u0, u1) × [v0, v1) and its valid count.
  double mean_disparity(int u0, int v0, int u1, int v1, int* valid) const;
};

/// Block size at hill-climbing level l = 1..L (L = block_levels): b_L = max(1, ⌊s / 2^L⌋) and
/// b_l = b_L·2^(L−l) ≈ s / 2^l, so that every block nests in the block of the level above and
/// in the initial cells (whose borders lie on multiples of b_1).
inline int block_size(int cell_size_px, int block_levels, int level) {
  const int finest = std::max(1, cell_size_px >> block_levels);
  return finest << (block_levels - level);
}

/// Wall-clock deadline of the hill climbing (none when max_time_ms ≤ 0).
struct Deadline {
  std::chrono::steady_clock::time_point end;
  bool enabled = false;
  bool passed() const { return enabled && std::chrono::steady_clock::now() > end; }
};

/// A block b: its pixel histogram (sparse), size, centre and mean disparity.
struct BlockData {
  std::array<std::uint8_t, kEnergyBins> bin_ids{};  ///< distinct bins present
  std::array<std::uint16_t, kEnergyBins> bin_counts{};
  int distinct_bins = 0;
  int pixels = 0;
  double centre_u = 0.0, centre_v = 0.0;
  double mean_disparity = 0.0;
  bool has_disparity = false;
};

/// Builds the state: colour bins (Lab 5×5×5), disparity integrals, the initial grid of
/// ⌊W/s⌋ × ⌊H/s⌋ cells (s = ⌊√(|I|/|S|)⌋, borders at i·W/n_x rounded to multiples of the
/// level-1 block size so that blocks never straddle two cells) and the segment statistics.
SuperpixelState make_initial_state(const cv::Mat& bgr, const cv::Mat& disparity,
                                   const ExtractionConfig& config);

/// Recomputes histograms, sizes and centre sums from `labels` (after relabelling).
void recompute_statistics(SuperpixelState& state);

/// Block score c1(S_i, b) − c2(S_i, b) (paper §4.5): histogram intersection of the normalised
/// histograms minus λ_reg·‖μ_{S_i} − b‖²/s² and, when the depth term is on and S_i has a plane,
/// λ_depth·min((θ_{S_i}(b) − d̄_b)², τ²)/τ². Higher is better.
double block_score(const SuperpixelState& state, int segment, const BlockData& block);

/// Moves all pixels of the rectangle [u0,u1)×[v0,v1) (all labelled `from`) to segment `to`,
/// updating histograms, sizes and centre sums.
void move_block(SuperpixelState& state, int u0, int v0, int u1, int v1, int from, int to);

/// Coarse-to-fine block hill climbing: block sizes s/2, s/4, … (levels from `first_level`,
/// sizes ≥ 2) with `iterations` sweeps each, then `pixel_iterations` sweeps of single pixels.
/// A boundary block moves to a horizontal/vertical neighbour segment when its score improves
/// and the move keeps the source segment locally connected and non-empty.
void hill_climb(SuperpixelState& state, int block_levels, int first_level, int iterations,
                int pixel_iterations, const Deadline& deadline);

/// Makes every segment 4-connected (smaller pieces join an adjacent segment) and renumbers the
/// segments 0..n−1 without gaps; statistics are recomputed and planes carried along.
void enforce_connectivity(SuperpixelState& state);

/// Per segment: the pixel indices of the segment (counting sort of `labels`).
struct SegmentPixels {
  std::vector<std::int32_t> offsets;  ///< num_segments + 1
  std::vector<std::int32_t> pixels;
};
SegmentPixels group_pixels(const SuperpixelState& state);

/// Result of fitting all segments.
struct SegmentPlaneFits {
  std::vector<std::int32_t> inliers;
  std::vector<std::int32_t> valid;
};

/// RANSAC + least-squares plane per segment (see plane_fit.hpp). Writes state.planes and
/// state.has_plane, and the inlier / valid-disparity counts per segment.
void fit_segment_planes(SuperpixelState& state, const SegmentPixels& groups,
                        const ExtractionConfig& config, SegmentPlaneFits& fits);

}  // namespace planecell::extraction::detail
