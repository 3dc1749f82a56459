#pragma once
/// Internal state of the depth-aware superpixel segmentation (paper §4.2–4.5), shared by the
/// energy, hill-climbing and plane-fitting steps of mapping/planecell. Not a public API.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "core/config/planecell_config.hpp"
#include "core/plane.hpp"
#include "mapping/planecell/plane_fit.hpp"

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

/// What the block costs read of a segment, derived from its statistics after every change.
struct SegmentCentre {
  double inv_size = 1.0;  ///< 1 / max(1, |S_i|)
  double mean_u = 0.0;    ///< μ_{S_i} = (Σu, Σv) / |S_i|
  double mean_v = 0.0;
};

/// Everything the hill climbing changes or reads. Pixel arrays are row-major, width × height.
struct SuperpixelState {
  int width = 0;
  int height = 0;
  int cell_size_px = 1;             ///< s = ⌊√(|I|/|S|)⌋
  std::vector<std::int32_t> labels;  ///< segment per pixel
  std::vector<std::uint8_t> bins;    ///< energy colour bin per pixel
  std::vector<float> disparity;      ///< px, NaN = invalid

  int num_segments = 0;
  std::vector<std::int32_t> histogram;  ///< num_segments × kEnergyBins pixel counts h_{S_i}(q)
  std::vector<std::int32_t> size;       ///< |S_i| in pixels
  std::vector<double> sum_u, sum_v;     ///< Σu, Σv (μ_{S_i} = Σ / |S_i|)
  std::vector<SegmentCentre> centre;    ///< derived from size, sum_u, sum_v (see refresh_centre)
  std::vector<DisparityPlane> planes;   ///< θ_{S_i}
  std::vector<std::uint8_t> has_plane;
  EnergyWeights weights;

  int index(int u, int v) const { return v * width + u; }
  /// Recomputes centre[l] from size[l], sum_u[l], sum_v[l].
  void refresh_centre(int l) {
    const double inv = 1.0 / std::max(1, size[l]);
    centre[l] = {inv, sum_u[l] * inv, sum_v[l] * inv};
  }
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

/// A block b: its pixel histogram (sparse, owned by the caller), size, centre and mean
/// disparity d̄_b (set only while the depth term is on).
struct BlockData {
  const std::uint8_t* bin_ids = nullptr;      ///< the distinct bins present
  const std::uint16_t* bin_counts = nullptr;  ///< their pixel counts h_b(q)
  int distinct_bins = 0;
  int pixels = 0;
  double centre_u = 0.0, centre_v = 0.0;
  double mean_disparity = 0.0;
  bool has_disparity = false;
};

/// Builds the state: colour bins (Lab 5×5×5), disparities, the initial grid of
/// ⌊W/s⌋ × ⌊H/s⌋ cells (s = ⌊√(|I|/|S|)⌋, borders at i·W/n_x rounded to multiples of the
/// level-1 block size so that blocks never straddle two cells) and the segment statistics.
SuperpixelState make_initial_state(const cv::Mat& bgr, const cv::Mat& disparity,
                                   const ExtractionConfig& config);

/// Recomputes histograms, sizes, centre sums and centres from `labels`.
void recompute_statistics(SuperpixelState& state);

/// Block score c1(S_i, b) − c2(S_i, b) (paper §4.5): histogram intersection of the normalised
/// histograms minus λ_reg·‖μ_{S_i} − b‖²/s² and, when the depth term is on and S_i has a plane,
/// λ_depth·min((θ_{S_i}(b) − d̄_b)², τ²)/τ². Higher is better.
double block_score(const SuperpixelState& state, int segment, const BlockData& block);

/// Moves all pixels of the rectangle [u0,u1)×[v0,v1) (all labelled `from`) to segment `to`,
/// updating histograms, sizes, centre sums and centres (the statistics stay exact: they are
/// integer counts and integer coordinate sums).
void move_block(SuperpixelState& state, int u0, int v0, int u1, int v1, int from, int to);

/// block_score for the single-pixel block b = (u, v) with colour bin q and disparity d (NaN =
/// unmatched): c1 = min(h_{S_i}(q)/|S_i|, 1), c2 as in block_score with d̄_b = d. Inline: it is
/// the innermost call of the pixel sweeps.
inline double pixel_score(const SuperpixelState& s, int segment, int bin, int u, int v, float d) {
  const SegmentCentre& c = s.centre[segment];
  const double c1 = std::min(
      s.histogram[static_cast<std::size_t>(segment) * kEnergyBins + bin] * c.inv_size, 1.0);
  const double du = c.mean_u - u;
  const double dv = c.mean_v - v;
  double c2 = s.weights.reg_per_px2 * (du * du + dv * dv);
  if (s.weights.depth_enabled && !std::isnan(d)) {
    const double tau = s.weights.depth_truncation_px;
    if (s.has_plane[segment]) {
      const double r = s.planes[segment].at(u, v) - static_cast<double>(d);
      c2 += s.weights.depth * std::min(r * r, tau * tau) / (tau * tau);
    } else {
      c2 += 0.5 * s.weights.depth;  // no plane yet: a neutral, half-saturated residual
    }
  }
  return c1 - c2;
}

/// move_block for the single pixel (u, v).
inline void move_pixel(SuperpixelState& s, int u, int v, int from, int to) {
  const int i = s.index(u, v);
  s.labels[i] = to;
  const int q = s.bins[i];
  --s.histogram[static_cast<std::size_t>(from) * kEnergyBins + q];
  ++s.histogram[static_cast<std::size_t>(to) * kEnergyBins + q];
  --s.size[from];
  ++s.size[to];
  s.sum_u[from] -= u;
  s.sum_u[to] += u;
  s.sum_v[from] -= v;
  s.sum_v[to] += v;
  s.refresh_centre(from);
  s.refresh_centre(to);
}

/// Coarse-to-fine block hill climbing: block sizes s/2, s/4, … (levels from `first_level`,
/// sizes ≥ 2) with `iterations` sweeps each, then `pixel_iterations` sweeps of single pixels.
/// A boundary block moves to a horizontal/vertical neighbour segment when its score improves
/// and the move keeps the source segment locally connected and non-empty. Only boundary blocks
/// and pixels are examined; block histograms are gathered once per level.
void hill_climb(SuperpixelState& state, int block_levels, int first_level, int iterations,
                int pixel_iterations, const Deadline& deadline);

/// Makes every segment 4-connected and renumbers the segments 0..n−1 without gaps, in raster
/// order of their first pixel; statistics and planes are carried along. The largest piece of a
/// label keeps it (the first in raster order on ties); every other piece joins the segment of
/// the first neighbouring pixel, in breadth-first order from the piece's first pixel, that
/// belongs to a kept piece (or to a piece already joined to one), else the label of the left
/// or upper neighbour from another piece of the first pixel that has one. Components are found
/// on horizontal runs with a union–find.
void enforce_connectivity(SuperpixelState& state);

/// Per segment: its valid disparities as (u, v, d) sample lanes, in raster order, plus its
/// pixel count. One raster pass: each segment has room for all its pixels (state.size).
struct SegmentSamples {
  std::vector<std::int32_t> begin;   ///< num_segments + 1 offsets, multiples of kSampleLane
  std::vector<std::int32_t> count;   ///< valid disparities of each segment
  std::vector<std::int32_t> area;    ///< pixels of each segment
  std::unique_ptr<float[]> u, v, d;  ///< each segment's samples padded with kPaddingDisparity
  SampleLanes lanes(int segment) const {
    const std::size_t at = static_cast<std::size_t>(begin[segment]);
    return {u.get() + at, v.get() + at, d.get() + at, count[segment]};
  }
};
/// Gathers the samples of every segment (valid disparities, raster order); reads state.size.
SegmentSamples gather_segment_samples(const SuperpixelState& state);

/// Result of fitting all segments.
struct SegmentPlaneFits {
  std::vector<std::int32_t> inliers;
  std::vector<std::int32_t> valid;
  /// Of a fitted segment, its slopes' covariance and inliers' centroid (PlaneFitResult); zero
  /// when it has no plane.
  std::vector<Eigen::Matrix2d> slope_covariance;
  std::vector<Eigen::Vector2d> inlier_centroid_px;
};

/// The first kPrecomputedDraws outputs of std::mt19937(seed) for kSeedBatch seeds at once
/// (out[j·kPrecomputedDraws + k] = k-th output for seeds[j]). The seeding recurrence
/// x_i = 1812433253·(x_{i−1} ⊕ (x_{i−1} ≫ 30)) + i is a long serial chain per generator, so
/// running kSeedBatch chains side by side replaces a per-segment std::mt19937 construction,
/// which seeds and twists all 624 state words. Output k < 624 − 397 is the tempered word
/// x_{k+397} ⊕ A(upper(x_k) | lower(x_{k+1})).
inline constexpr int kPrecomputedDraws = 96;  ///< covers 32 RANSAC hypotheses (3 draws each)
inline constexpr int kSeedBatch = 8;
static_assert(kPrecomputedDraws <= 624 - 397);
void mt19937_first_outputs(const std::uint32_t* seeds, std::uint32_t* out);

/// A uniform random bit generator replaying precomputed std::mt19937(seed) outputs and
/// continuing with a real std::mt19937 past them: the same sequence as std::mt19937(seed).
class ReplayedMt19937 {
 public:
  using result_type = std::uint32_t;
  static constexpr result_type min() { return std::mt19937::min(); }
  static constexpr result_type max() { return std::mt19937::max(); }
  ReplayedMt19937(std::uint32_t seed, const std::uint32_t* first_outputs)
      : seed_(seed), first_(first_outputs) {}
  result_type operator()() {
    if (next_ < kPrecomputedDraws) return first_[next_++];
    if (!rest_) {
      rest_ = std::make_unique<std::mt19937>(seed_);
      rest_->discard(kPrecomputedDraws);
    }
    return (*rest_)();
  }

 private:
  std::uint32_t seed_;
  const std::uint32_t* first_;
  int next_ = 0;
  std::unique_ptr<std::mt19937> rest_;  ///< only made when the precomputed outputs run out
};

/// RANSAC + least-squares plane per segment (see plane_fit.hpp) on the segments with at least
/// config.min_valid_ratio of their pixels matched; segment k draws from
/// std::mt19937(random_seed·7919 + k), exactly as fit_disparity_plane with that seed. Writes
/// state.planes and state.has_plane, and the inlier / valid-disparity counts per segment.
void fit_segment_planes(SuperpixelState& state, const SegmentSamples& samples,
                        const ExtractionConfig& config, SegmentPlaneFits& fits);

}  // namespace planecell::extraction::detail
