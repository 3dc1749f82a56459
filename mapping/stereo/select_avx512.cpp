/// Disparity selection (select_row: winner-take-all, uniqueness, right winners, sub-pixel) in
/// AVX-512BW: 32 disparities (uint16) per vector for the minimum, 16 (uint32 keys) for the
/// right-image winners. Same results as select_row in postprocess.cpp. Everything below the
/// target pragma is compiled for AVX-512BW/VL only and reached only when
/// aggregation_kernel_supported(AggregationKernel::avx512).
#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <opencv2/core/mat.hpp>
#include <stdexcept>
#include <vector>

#include "mapping/stereo/sgm_detail.hpp"

#if defined(PLANECELL_SGM_AVX512_KERNEL)
#include <immintrin.h>
#pragma GCC push_options
#pragma GCC target("avx2,avx512f,avx512bw,avx512vl")
// GCC 12's intrinsics start from _mm512_undefined_epi32() (a self-initialised variable), which
// -Wmaybe-uninitialized reports once inlined here: a false positive inside the system header.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include "mapping/stereo/select_pass.hpp"

namespace planecell::stereo::detail {

#if defined(PLANECELL_SGM_AVX512_KERNEL)
namespace {

/// Lanes [0, n) of a 32-lane mask (n clamped to [0, 32]).
inline __mmask32 first_lanes(int n) {
  if (n >= 32) return ~__mmask32{0};
  if (n <= 0) return 0;
  return (__mmask32{1} << n) - 1;
}

/// Right-image winners as in postprocess.cpp: keys[W − 1 − x_r] = min_d (S(x_r + d, d)·2^16 + d).
/// For a fixed x the lanes d0 … d0+31 are contiguous in `keys`. Inside a block x steps by 33:
/// consecutive read-modify-writes never overlap (no store-forwarding stalls), and the S rows
/// read one after the other are not 4 KiB apart (a step of 16 pixels would be, at D_p = 128,
/// and would keep hitting the same L1 set).
void right_winners(const std::uint16_t* S, int width, int dp, std::uint32_t* keys) {
  constexpr int kStep = 33;
  std::fill(keys, keys + width + dp + 32, 0xFFFFFFFFu);
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  for (int d0 = 0; d0 < dp; d0 += 32) {
    const __mmask32 lanes = first_lanes(dp - d0);
    const auto lanes_lo = static_cast<__mmask16>(lanes),
               lanes_hi = static_cast<__mmask16>(lanes >> 16);
    const __m512i dv_lo = _mm512_add_epi32(lane, _mm512_set1_epi32(d0));
    const __m512i dv_hi = _mm512_add_epi32(lane, _mm512_set1_epi32(d0 + 16));
    for (int phase = 0; phase < kStep; ++phase) {
      for (int x = phase; x < width; x += kStep) {
        const __m512i s =
            _mm512_maskz_loadu_epi16(lanes, S + static_cast<std::size_t>(x) * dp + d0);
        const __m512i key_lo = _mm512_or_si512(
            _mm512_slli_epi32(_mm512_cvtepu16_epi32(_mm512_castsi512_si256(s)), 16), dv_lo);
        const __m512i key_hi = _mm512_or_si512(
            _mm512_slli_epi32(_mm512_cvtepu16_epi32(_mm512_extracti64x4_epi64(s, 1)), 16), dv_hi);
        std::uint32_t* dst = keys + (width - 1 - x) + d0;
        _mm512_mask_storeu_epi32(dst, lanes_lo, _mm512_min_epu32(_mm512_loadu_si512(dst), key_lo));
        _mm512_mask_storeu_epi32(dst + 16, lanes_hi,
                                 _mm512_min_epu32(_mm512_loadu_si512(dst + 16), key_hi));
      }
    }
  }
}

inline std::uint16_t horizontal_min(__m512i v) {
  const __m256i h = _mm256_min_epu16(_mm512_castsi512_si256(v), _mm512_extracti64x4_epi64(v, 1));
  const __m128i m = _mm_min_epu16(_mm256_castsi256_si128(h), _mm256_extracti128_si256(h, 1));
  return static_cast<std::uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(m)));
}

/// min_d s[d] over the padded range (D_p a multiple of 16).
inline std::uint16_t min_cost(const std::uint16_t* s, int dp) {
  const __m512i ones = _mm512_set1_epi16(-1);
  __m512i m = _mm512_mask_loadu_epi16(ones, first_lanes(dp), s);
  for (int d = 32; d < dp; d += 32)
    m = _mm512_min_epu16(m, _mm512_mask_loadu_epi16(ones, first_lanes(dp - d), s + d));
  return horizontal_min(m);
}

/// First d with s[d] == value (value is present).
inline int first_index_of(const std::uint16_t* s, int dp, std::uint16_t value) {
  const __m512i v = _mm512_set1_epi16(static_cast<short>(value));
  for (int d = 0; d < dp; d += 32) {
    const __mmask32 lanes = first_lanes(dp - d);
    const __mmask32 eq =
        _mm512_mask_cmpeq_epu16_mask(lanes, _mm512_maskz_loadu_epi16(lanes, s + d), v);
    if (eq != 0) return d + std::countr_zero(static_cast<unsigned>(eq));
  }
  return 0;
}

}  // namespace

void select_row_avx512(std::uint16_t* S, int width, const SgmConfig& config,
                       const WinnerRow& out) {
  // right_winners stores whole 16-lane vectors: up to 32 keys past width + D_p.
  select_row_with<&right_winners, &min_cost, &first_index_of, 32>(S, width, config, out);
}

#else

void select_row_avx512(std::uint16_t*, int, const SgmConfig&, const WinnerRow&) {
  throw std::logic_error("SGM: the AVX-512 selection is not compiled in");
}

#endif

}  // namespace planecell::stereo::detail

#if defined(PLANECELL_SGM_AVX512_KERNEL)
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif
