/// Disparity selection on the aggregated cost S (Eq. 2) and the post-filters: winner-take-all,
/// uniqueness ratio, sub-pixel parabola, 3×3 median, left-right check, small-speckle removal.
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "mapping/stereo/select_pass.hpp"
#include "mapping/stereo/sgm_detail.hpp"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace planecell::stereo::detail {
namespace {

constexpr std::uint16_t kMaxCost = 0xFFFF;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// Right-image winners from the same volume (no second SGM run): for every right pixel x_r,
/// key(x_r) = min_d (S(x_r + d, d) · 2^16 + d), i.e. the lowest cost and, on ties, the smallest d.
/// Stored reversed: keys[W − 1 − x_r], so that for a fixed x the d lanes are contiguous.
void right_winners(const std::uint16_t* S, int width, int dp, std::uint32_t* keys) {
  std::fill(keys, keys + width + dp, 0xFFFFFFFFu);
#if defined(__AVX2__)
  // x steps by 17 inside a d block so that consecutive read-modify-writes never overlap, and
  // the S rows read one after the other are not 4 KiB apart (as a step of 16 would be at
  // D_p = 128, hitting one L1 set).
  constexpr int kStep = 17;
  const __m256i lane = _mm256_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  for (int d0 = 0; d0 < dp; d0 += 16) {
    const __m256i dv = _mm256_add_epi16(lane, _mm256_set1_epi16(static_cast<short>(d0)));
    for (int phase = 0; phase < kStep; ++phase) {
      for (int x = phase; x < width; x += kStep) {
        const __m256i s = _mm256_loadu_si256(
            reinterpret_cast<const __m256i*>(S + static_cast<std::size_t>(x) * dp + d0));
        const __m256i lo = _mm256_unpacklo_epi16(dv, s);  // lanes 0-3, 8-11
        const __m256i hi = _mm256_unpackhi_epi16(dv, s);  // lanes 4-7, 12-15
        const __m256i k0 = _mm256_permute2x128_si256(lo, hi, 0x20);  // lanes 0-7
        const __m256i k1 = _mm256_permute2x128_si256(lo, hi, 0x31);  // lanes 8-15
        std::uint32_t* dst = keys + (width - 1 - x) + d0;
        __m256i* p0 = reinterpret_cast<__m256i*>(dst);
        __m256i* p1 = reinterpret_cast<__m256i*>(dst + 8);
        _mm256_storeu_si256(p0, _mm256_min_epu32(_mm256_loadu_si256(p0), k0));
        _mm256_storeu_si256(p1, _mm256_min_epu32(_mm256_loadu_si256(p1), k1));
      }
    }
  }
#else
  for (int x = 0; x < width; ++x) {
    const std::uint16_t* s = S + static_cast<std::size_t>(x) * dp;
    std::uint32_t* dst = keys + (width - 1 - x);
    for (int d = 0; d < dp; ++d)
      dst[d] = std::min(dst[d], (static_cast<std::uint32_t>(s[d]) << 16) | static_cast<std::uint32_t>(d));
  }
#endif
}

/// min_d s[d] over the padded range.
inline std::uint16_t min_cost(const std::uint16_t* s, int dp) {
#if defined(__AVX2__)
  __m256i m = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(s));
  for (int d = 16; d < dp; d += 16)
    m = _mm256_min_epu16(m, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(s + d)));
  const __m128i h = _mm_min_epu16(_mm256_castsi256_si128(m), _mm256_extracti128_si256(m, 1));
  return static_cast<std::uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(h)));
#else
  std::uint16_t m = kMaxCost;
  for (int d = 0; d < dp; ++d) m = std::min(m, s[d]);
  return m;
#endif
}

/// First d with s[d] == value (value is present).
inline int first_index_of(const std::uint16_t* s, int dp, std::uint16_t value) {
#if defined(__AVX2__)
  const __m256i v = _mm256_set1_epi16(static_cast<short>(value));
  for (int d = 0; d < dp; d += 16) {
    const int mask = _mm256_movemask_epi8(
        _mm256_cmpeq_epi16(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(s + d)), v));
    if (mask != 0) return d + std::countr_zero(static_cast<unsigned>(mask)) / 2;
  }
  return 0;
#else
  for (int d = 0; d < dp; ++d)
    if (s[d] == value) return d;
  return 0;
#endif
}

/// std::lround for the float values here (|v| < 2^24), without the libm call: v + 0.5 is exact
/// in double, so floor gives round-half-up, mirrored for negative v (half away from zero).
inline short round_half_away(float v) {
  const double a = std::floor(std::abs(static_cast<double>(v)) + 0.5);
  return static_cast<short>(v < 0.0f ? -a : a);
}

}  // namespace

Winners::Winners(int width, int height)
    : disparity(height, width, CV_32F), left(height, width, CV_16U), right(height, width, CV_16U) {}

WinnerRow Winners::row(int y) {
  return {disparity.ptr<float>(y), left.ptr<std::uint16_t>(y), right.ptr<std::uint16_t>(y)};
}

void select_row(std::uint16_t* S, int width, const SgmConfig& config, const WinnerRow& out) {
  select_row_with<&right_winners, &min_cost, &first_index_of, 0>(S, width, config, out);
}

cv::Mat filter_winners(Winners& winners, const SgmConfig& config) {
  cv::Mat& disparity = winners.disparity;
  if (config.median_filter) {
    // Only the uniqueness test leaves NaN here; with it off there is nothing to mask.
    cv::Mat not_unique;
    if (config.uniqueness_ratio > 0) not_unique = disparity != disparity;
    const bool any_not_unique = !not_unique.empty() && cv::countNonZero(not_unique) > 0;
    if (any_not_unique) {
      cv::Mat as_float;
      winners.left.convertTo(as_float, CV_32F);
      as_float.copyTo(disparity, not_unique);
    }
    // Each median into a new matrix: cv::medianBlur cannot work in place.
    const auto median = [](cv::Mat& m) {
      cv::Mat filtered;
      cv::medianBlur(m, filtered, 3);
      m = filtered;
    };
    median(disparity);
    if (any_not_unique) disparity.setTo(kNaN, not_unique);
    median(winners.left);
    if (config.lr_check) median(winners.right);
  }
  for (int y = 0; y < disparity.rows; ++y) {
    float* out = disparity.ptr<float>(y);
    const std::uint16_t* left = winners.left.ptr<std::uint16_t>(y);
    const std::uint16_t* right = winners.right.ptr<std::uint16_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      const int d = left[x];
      const bool valid =
          x - d >= 0 && (!config.lr_check || std::abs(d - right[x - d]) <= config.lr_max_diff_px);
      if (!valid) out[x] = kNaN;
    }
  }
  return disparity;
}

void remove_speckles(cv::Mat& disparity, const SgmConfig& config) {
  if (config.speckle_window_size <= 0) return;
  constexpr short kInvalid = -16;
  cv::Mat fixed(disparity.size(), CV_16S);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    short* f = fixed.ptr<short>(y);
    for (int x = 0; x < disparity.cols; ++x)
      f[x] = std::isnan(d[x]) ? kInvalid : round_half_away(d[x] * 16.0f);
  }
  const int max_diff = static_cast<int>(std::lround(config.speckle_range_px * 16.0));
  cv::filterSpeckles(fixed, kInvalid, config.speckle_window_size, max_diff);
  for (int y = 0; y < disparity.rows; ++y) {
    float* d = disparity.ptr<float>(y);
    const short* f = fixed.ptr<short>(y);
    for (int x = 0; x < disparity.cols; ++x)
      if (f[x] == kInvalid) d[x] = kNaN;
  }
}

}  // namespace planecell::stereo::detail
