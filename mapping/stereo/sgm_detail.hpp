#pragma once
/// Building blocks of the SGM stage (one job per file): census.cpp, cost.cpp, aggregate_paths.cpp,
/// postprocess.cpp, glued by sgm.cpp. Exposed for tests and the scalar reference.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "core/config/sgm_config.hpp"

namespace planecell::stereo::detail {

/// Disparities are processed in blocks of 16 (one AVX2 vector of uint16): D rounded up to 16.
inline int padded_disparities(int max_disparity) { return (max_disparity + 15) / 16 * 16; }

/// Census descriptors T(p) of a grey image: bit k is set when the k-th window pixel (row-major,
/// centre skipped) is darker than the centre; the window is clamped at the image border.
struct CensusImage {
  int width = 0, height = 0;
  std::vector<std::uint64_t> bits;  ///< row-major, width·height descriptors
  std::uint64_t at(int x, int y) const { return bits[static_cast<std::size_t>(y) * width + x]; }
};

/// Census transform over a window_w × window_h window (odd, ≤ 65 pixels), rows split in stripes.
CensusImage census_transform(const cv::Mat& gray, int window_w, int window_h, int threads);

/// G(p, e): derivative of the grey image along the epipolar line (rows), Sobel 3×3 / 4, so that
/// a step of Δ grey levels gives G = Δ. CV_16S.
cv::Mat epipolar_gradient(const cv::Mat& gray);

/// Gradient part of Eq. 1 in the integer cost scale: round(λ_grad · min(|ΔG|, cap)) computed
/// in fixed point as (min(|ΔG|, cap) · round(16 λ_grad) + 8) >> 4.
inline int gradient_cost(int gradient_difference, int grad_cap, int lambda_q4) {
  const int g = std::min(std::abs(gradient_difference), grad_cap);
  return (g * lambda_q4 + 8) >> 4;
}
inline int lambda_q4(double lambda_grad) { return static_cast<int>(std::lround(lambda_grad * 16)); }

/// The uint8 cost of Eq. 1, saturated at 255: C = H(T_L(p), T_R(q)) + λ_grad·min(|G_L − G_R|, cap).
inline int matching_cost(std::uint64_t census_l, std::uint64_t census_r, int grad_l, int grad_r,
                         int grad_cap, int lambda_q4) {
  const int ham = std::popcount(census_l ^ census_r);
  return std::min(255, ham + gradient_cost(grad_l - grad_r, grad_cap, lambda_q4));
}

/// The largest cost of Eq. 1, C_max = min(255, w·h − 1 + λ_grad·cap); also the cost of the
/// padding lanes d ≥ max_disparity (outside the search range: they never win).
inline int largest_cost(const SgmConfig& c) {
  return std::min(255, c.census_width * c.census_height - 1 +
                           gradient_cost(c.grad_cap, c.grad_cap, lambda_q4(c.lambda_grad)));
}

/// Cost of a disparity d < max_disparity whose match q = p − d falls left of the right image:
/// round(SgmConfig::out_of_image_cost · C_max), a neutral cost (the match is unobservable).
inline int out_of_image_cost(const SgmConfig& c) {
  return static_cast<int>(std::lround(c.out_of_image_cost * largest_cost(c)));  // share checked in [0, 1]
}

/// Whether the path costs fit in uint8: L_r(p, d) = C(p, d) + min(…) − min_k L_r(p − r, k) lies in
/// [C, C + P2], so every L_r ≤ 255 when the largest cost + P2 ≤ 255 (the SIMD kernels then keep
/// their row buffers in uint8: 64 disparities per AVX-512 vector, 32 per AVX2 one; the sums stay
/// uint16). True for the defaults (62 + 15 + 120 = 197).
inline bool narrow_entries_fit(const SgmConfig& c) { return largest_cost(c) + c.p2 <= 255; }

/// Per-pixel P2 for an intensity step |I(p) − I(p − r)| along a path (P2 adaptation):
/// P2' = max(P1, round(P2 − slope·|ΔI|)), or P2 when adaptation is off. Indexed by |ΔI| ∈ [0, 255].
std::vector<std::uint16_t> p2_table(const SgmConfig& c);

/// Large uninitialised buffer (no zero fill) for the volumes: 2 MiB aligned and marked for
/// transparent huge pages, so that first touch costs one fault per 2 MiB instead of per 4 KiB.
void* allocate_volume_bytes(std::size_t bytes);
void free_volume_bytes(void* p) noexcept;

template <class T>
struct Volume {
  struct Free {
    void operator()(T* p) const noexcept { free_volume_bytes(p); }
  };
  std::unique_ptr<T[], Free> data;
  std::size_t size = 0;
  explicit Volume(std::size_t n)
      : data(static_cast<T*>(allocate_volume_bytes(n * sizeof(T)))), size(n) {}
  T* get() { return data.get(); }
  const T* get() const { return data.get(); }
};

/// Everything Eq. 1 needs to produce cost rows C(·, y, ·) of one image pair (read only, shared
/// by the threads). Built by cost_inputs().
struct CostInputs {
  const CensusImage* census_l = nullptr;
  const CensusImage* census_r = nullptr;
  const cv::Mat* gradient_l = nullptr;  ///< CV_16S, epipolar_gradient of the left image
  const cv::Mat* gradient_r = nullptr;
  int max_disparity = 0, dp = 0;        ///< D and D rounded up to 16 (padded_disparities)
  int grad_cap = 0, lambda_q4 = 0;      ///< cap and round(16 λ_grad) of gradient_cost
  std::uint8_t out_of_image = 0;        ///< out_of_image_cost: x − d < 0, d < max_disparity
  std::uint8_t padding = 0;             ///< largest_cost: d ≥ max_disparity
};
CostInputs cost_inputs(const CensusImage& census_l, const CensusImage& census_r,
                       const cv::Mat& gradient_l, const cv::Mat& gradient_r,
                       const SgmConfig& config);

/// Per-thread scratch of the cost rows: the right image's census and gradient row y reversed
/// (j = W − 1 − x_r), so that the match q = p − d walks forward in memory as d grows, padded
/// so that whole vectors may be read past the last match. load() once per row.
struct ReversedRightRow {
  int y = -1;
  std::vector<std::uint64_t> census;
  std::vector<std::int16_t> gradient;
  void load(const CostInputs& in, int row);
};

/// Costs of pixels x ∈ [x_begin, x_end) of row y (= right.y, loaded):
/// out[(x − x_begin)·D_p + d] = C(x, y, d) as uint8 (Eq. 1, matching_cost),
/// out_of_image_cost for matches left of the right image (x − d < 0, d < max_disparity) and
/// largest_cost for the padding d ≥ max_disparity.
using CostRowFunction = void (*)(const CostInputs& in, const ReversedRightRow& right,
                                 int x_begin, int x_end, std::uint8_t* out);
/// The build's baseline: AVX2 (nibble-table popcount, 16 disparities per vector) or portable C++.
void cost_row(const CostInputs& in, const ReversedRightRow& right, int x_begin, int x_end,
              std::uint8_t* out);
/// AVX-512 VPOPCNTDQ + VBMI (64 disparities per vector); only when cost_row_avx512_supported().
void cost_row_avx512(const CostInputs& in, const ReversedRightRow& right, int x_begin, int x_end,
                     std::uint8_t* out);
bool cost_row_avx512_supported();

/// One image row of the winner-take-all, before the image-wide filters (filter_winners).
struct WinnerRow {
  float* disparity;     ///< sub-pixel disparity of the left winner d_L(x); NaN = not unique
  std::uint16_t* left;  ///< d_L(x) = argmin_d S(x, d) (smallest d on ties)
  /// d_R(x_r) = argmin_d S(x_r + d, d) over x_r + d < W (smallest d on ties): the right image's
  /// winner from the same volume. Written only when config.lr_check.
  std::uint16_t* right;
};

/// The winner maps of a whole image: disparity CV_32F, left and right CV_16U.
struct Winners {
  cv::Mat disparity, left, right;
  Winners(int width, int height);
  WinnerRow row(int y);
};

/// Winner-take-all with sub-pixel refinement and uniqueness on one row of the aggregated cost
/// S(x, d) = Σ_r L_r (Eq. 2), layout [x][d_padded], plus the right image's winners for the
/// left-right check. `S` is modified (padding lanes set to 0xFFFF).
void select_row(std::uint16_t* S, int width, const SgmConfig& config, const WinnerRow& out);

/// select_row in AVX-512BW (same results); only when
/// aggregation_kernel_supported(AggregationKernel::avx512).
void select_row_avx512(std::uint16_t* S, int width, const SgmConfig& config,
                       const WinnerRow& out);
using SelectRowFunction = void (*)(std::uint16_t* S, int width, const SgmConfig& config,
                                   const WinnerRow& out);

/// The image-wide filters on the winners, in place; returns winners.disparity (NaN = invalid).
/// With config.median_filter, each of the three maps becomes its 3×3 median (cv::medianBlur;
/// the disparity of pixels rejected as not unique is taken as d_L for the median and stays
/// rejected). Then a pixel is invalid when its match leaves the right image, x − d_L < 0, or,
/// with config.lr_check, when |d_L(x) − d_R(x − d_L(x))| > lr_max_diff_px.
cv::Mat filter_winners(Winners& winners, const SgmConfig& config);

/// Parabola through (d−1, s_m), (d, s_0), (d+1, s_p): d + (s_m − s_p) / (2 (s_m + s_p − 2 s_0)).
inline float subpixel_parabola(int d, int s_m, int s_0, int s_p) {
  const int denom = s_m + s_p - 2 * s_0;
  if (denom <= 0) return static_cast<float>(d);
  return static_cast<float>(d) + static_cast<float>(s_m - s_p) / (2.0f * static_cast<float>(denom));
}

/// Uniqueness: the best cost must beat every cost at |d − d_best| > 1 by `ratio` percent.
inline bool is_unique(int best, int second, int ratio) {
  return static_cast<long>(second) * (100 - ratio) >= static_cast<long>(best) * 100;
}

/// The AVX-512 aggregation kernel is compiled with GCC's target pragma (x86-64 GCC only).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define PLANECELL_SGM_AVX512_KERNEL 1
#endif

/// SIMD kernel of the aggregation (Eq. 2); all give bit-identical results.
enum class AggregationKernel { portable, avx2, avx512 };
/// Whether `kernel` was compiled in (AVX2) and this CPU and OS run it (AVX-512BW/VL, checked
/// at run time).
bool aggregation_kernel_supported(AggregationKernel kernel);
/// The fastest supported kernel: AVX-512BW, else AVX2, else portable.
AggregationKernel best_aggregation_kernel();

/// Eq. 2 over all paths for the whole image, then the winners and filter_winners: returns the
/// disparity before speckle removal.
/// Each aggregation pass computes its own cost rows (`cost_row`, no cost volume); `parked`
/// (≥ W·H·D_p values) holds the partial sums handed between the two passes.
/// Throws std::invalid_argument when `kernel` is not supported.
cv::Mat aggregate_and_select(const CostInputs& costs, CostRowFunction cost_row,
                             const cv::Mat& gray_left, const SgmConfig& config,
                             Volume<std::uint16_t>& parked, AggregationKernel kernel);

/// compute_disparity with an explicit aggregation kernel (tests compare every kernel).
cv::Mat compute_disparity_with(const cv::Mat& left, const cv::Mat& right,
                               const SgmConfig& config, AggregationKernel kernel);

/// Small-speckle removal (cv::filterSpeckles on a 1/16 px fixed-point copy); in place, NaN = invalid.
void remove_speckles(cv::Mat& disparity, const SgmConfig& config);

}  // namespace planecell::stereo::detail
