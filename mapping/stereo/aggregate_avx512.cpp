/// AVX-512BW kernel of the aggregation (Eq. 2): 32 disparities (uint16) per vector. Everything
/// defined below the target pragma is compiled for AVX-512BW/VL and only reached after
/// aggregation_kernel_supported(AggregationKernel::avx512) said the CPU runs it; the headers
/// (standard library, OpenCV) are included first and keep the build's baseline target.
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <stdexcept>
#include <vector>

#include "core/config/sgm_config.hpp"
#include "mapping/stereo/sgm_detail.hpp"

#if defined(PLANECELL_SGM_AVX512_KERNEL)
#include <immintrin.h>
#pragma GCC push_options
#pragma GCC target("avx2,avx512f,avx512bw,avx512vl")
#endif

#include "mapping/stereo/aggregate_pass.hpp"

namespace planecell::stereo::detail {

#if defined(PLANECELL_SGM_AVX512_KERNEL)
namespace {

/// Lanes [0, n) of a 32-lane mask (n clamped to [0, 32]).
inline __mmask32 first_lanes(int n) {
  if (n >= 32) return ~__mmask32{0};
  if (n <= 0) return 0;
  return (__mmask32{1} << n) - 1;
}

inline std::uint16_t horizontal_min(__m512i v) {
  const __m256i h = _mm256_min_epu16(_mm512_maskz_extracti64x4_epi64(0xFF, v, 0),
                                     _mm512_maskz_extracti64x4_epi64(0xFF, v, 1));
  const __m128i m = _mm_min_epu16(_mm256_castsi256_si128(h), _mm256_extracti128_si256(h, 1));
  return static_cast<std::uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(m)));
}

/// Same integers as the portable loop: per block of 32 disparities (the last one masked when
/// D_p is an odd multiple of 16),
/// L(d) = C(d) + min(L'(d), min(L'(d−1), L'(d+1)) + P1, m' + P2') − m',  m' = min_k L'(k).
/// L'(d − 1) for the next block is loaded before this block is stored, because prev may equal
/// out (in-place row buffers); base[−1] is the +∞ sentinel for d = 0.
struct Avx512Kernel {
  template <int NP>
  static void update(const std::uint8_t* cost, const std::uint16_t* const* prev,
                     std::uint16_t* const* out, const std::uint16_t* p2, std::uint16_t p1, int dp,
                     std::uint16_t* sum) {
    const __m512i v_p1 = _mm512_set1_epi16(static_cast<short>(p1));
    __m512i v_min_prev[NP], v_min_prev_p2[NP], v_min_new[NP], lm[NP];
    const __mmask32 first = first_lanes(dp);
    for (int k = 0; k < NP; ++k) {
      const std::uint16_t m = prev[k][dp + 1];
      v_min_prev[k] = _mm512_set1_epi16(static_cast<short>(m));
      v_min_prev_p2[k] = _mm512_set1_epi16(static_cast<short>(m + p2[k]));
      v_min_new[k] = _mm512_set1_epi16(static_cast<short>(kMaxCost));
      lm[k] = _mm512_maskz_loadu_epi16(first, prev[k] - 1);
    }
    for (int d = 0; d < dp; d += 32) {
      const __mmask32 mask = first_lanes(dp - d);
      const __mmask32 next = first_lanes(dp - d - 32);
      const __m512i c = _mm512_cvtepu8_epi16(_mm256_maskz_loadu_epi8(mask, cost + d));
      __m512i s = _mm512_setzero_si512();
      for (int k = 0; k < NP; ++k) {
        const std::uint16_t* pk = prev[k] + d;
        const __m512i l0 = _mm512_maskz_loadu_epi16(mask, pk);
        const __m512i lp = _mm512_maskz_loadu_epi16(mask, pk + 1);
        const __m512i lm_k = lm[k];
        lm[k] = _mm512_maskz_loadu_epi16(next, pk + 31);  // before the store below
        __m512i t = _mm512_min_epu16(l0, _mm512_adds_epu16(_mm512_min_epu16(lm_k, lp), v_p1));
        t = _mm512_min_epu16(t, v_min_prev_p2[k]);
        const __m512i v = _mm512_add_epi16(_mm512_sub_epi16(t, v_min_prev[k]), c);
        _mm512_mask_storeu_epi16(out[k] + d, mask, v);
        v_min_new[k] = _mm512_mask_min_epu16(v_min_new[k], mask, v_min_new[k], v);
        s = _mm512_add_epi16(s, v);
      }
      _mm512_mask_storeu_epi16(sum + d, mask, s);
    }
    for (int k = 0; k < NP; ++k) out[k][dp + 1] = horizontal_min(v_min_new[k]);
  }
};

}  // namespace

void run_pass_avx512(int paths, bool forward, const Volume<std::uint8_t>& cost,
                     const cv::Mat& gray, const SgmConfig& config, RowMeeting& meeting) {
  run_pass_with<Avx512Kernel>(paths, forward, cost, gray, config, meeting);
}

#else

void run_pass_avx512(int, bool, const Volume<std::uint8_t>&, const cv::Mat&, const SgmConfig&,
                     RowMeeting&) {
  throw std::logic_error("SGM: the AVX-512 aggregation kernel is not compiled in");
}

#endif

}  // namespace planecell::stereo::detail

#if defined(PLANECELL_SGM_AVX512_KERNEL)
#pragma GCC pop_options
#endif
