/// AVX-512BW kernels of the aggregation (Eq. 2): 64 disparities per vector with uint8 row
/// buffers when narrow_entries_fit (the default configuration), else 32 with uint16. Everything
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
// GCC 12's intrinsics start from _mm512_undefined_epi32() (a self-initialised variable), which
// -Wmaybe-uninitialized reports once inlined here: a false positive inside the system header.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
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
  using Entry = std::uint16_t;
  template <int NP, bool kAdd>
  static void update(const std::uint8_t* cost, const std::uint16_t* const* prev,
                     std::uint16_t* const* out, const std::uint16_t* p2, std::uint16_t p1, int dp,
                     std::uint16_t* sum, const std::uint16_t* base) {
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
      __m512i s = kAdd ? _mm512_maskz_loadu_epi16(mask, base + d) : _mm512_setzero_si512();
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

/// Lanes [0, n) of a 64-lane mask (n clamped to [0, 64]).
inline __mmask64 first_bytes(int n) {
  if (n >= 64) return ~__mmask64{0};
  if (n <= 0) return 0;
  return (__mmask64{1} << n) - 1;
}

/// min_d of each of the NP (2 or 4) uint8 vectors, written to out[k][dp + 1]: the four
/// reductions share their shuffles (halves, quarters, then bytes inside each 128-bit lane).
template <int NP>
inline void store_minima8(const __m512i* m, std::uint8_t* const* out, int dp) {
  const __m512i m2 = NP == 4 ? m[2] : m[0], m3 = NP == 4 ? m[3] : m[1];
  // t01 = [min(m0 halves) | min(m1 halves)], t23 likewise; then u's 128-bit lane k ⊇ path k.
  const __m512i t01 = _mm512_min_epu8(_mm512_shuffle_i64x2(m[0], m[1], 0x44),
                                      _mm512_shuffle_i64x2(m[0], m[1], 0xEE));
  const __m512i t23 =
      _mm512_min_epu8(_mm512_shuffle_i64x2(m2, m3, 0x44), _mm512_shuffle_i64x2(m2, m3, 0xEE));
  __m512i u = _mm512_min_epu8(_mm512_shuffle_i64x2(t01, t23, 0x88),
                              _mm512_shuffle_i64x2(t01, t23, 0xDD));
  u = _mm512_min_epu8(u, _mm512_bsrli_epi128(u, 8));
  u = _mm512_min_epu8(u, _mm512_bsrli_epi128(u, 4));
  u = _mm512_min_epu8(u, _mm512_bsrli_epi128(u, 2));
  u = _mm512_min_epu8(u, _mm512_bsrli_epi128(u, 1));
  alignas(64) std::uint8_t lanes[64];
  _mm512_store_si512(lanes, u);
  for (int k = 0; k < NP; ++k) out[k][dp + 1] = lanes[16 * k];
}

/// The same update with uint8 row buffers, 64 disparities per vector; only when
/// narrow_entries_fit (every L_r ≤ 255). Terms that would exceed 255 (the +∞ sentinels,
/// L'(d±1) + P1, m' + P2') saturate at 255 ≥ L'(d), so the minimum is unchanged. The sum of
/// the paths is formed in uint16 two paths at a time: bytes of L_a and L_b interleaved
/// (unpack) and added pairwise by VPMADDUBSW with weights 1 (L_a + L_b ≤ 510, no saturation);
/// the unpack order (per 128-bit lane: d 0–7 in one vector, 8–15 in the other) is undone by
/// one two-source qword permutation per 32 sums.
struct Avx512NarrowKernel {
  using Entry = std::uint8_t;
  template <int NP, bool kAdd>
  static void update(const std::uint8_t* cost, const std::uint8_t* const* prev,
                     std::uint8_t* const* out, const std::uint16_t* p2, std::uint16_t p1, int dp,
                     std::uint16_t* sum, const std::uint16_t* base) {
    const __m512i v_p1 = _mm512_set1_epi8(static_cast<char>(p1));
    const __m512i ones = _mm512_set1_epi8(1);
    const __m512i first_half = _mm512_setr_epi64(0, 1, 8, 9, 2, 3, 10, 11);
    const __m512i second_half = _mm512_setr_epi64(4, 5, 12, 13, 6, 7, 14, 15);
    __m512i v_min_prev[NP], v_min_prev_p2[NP], v_min_new[NP], lm[NP];
    const __mmask64 first = first_bytes(dp);
    for (int k = 0; k < NP; ++k) {
      const int m = prev[k][dp + 1];
      v_min_prev[k] = _mm512_set1_epi8(static_cast<char>(m));
      v_min_prev_p2[k] = _mm512_set1_epi8(static_cast<char>(std::min(255, m + p2[k])));
      v_min_new[k] = _mm512_set1_epi8(static_cast<char>(0xFF));
      lm[k] = _mm512_maskz_loadu_epi8(first, prev[k] - 1);
    }
    for (int d = 0; d < dp; d += 64) {
      const __mmask64 mask = first_bytes(dp - d);
      const __mmask64 next = first_bytes(dp - d - 64);
      const __m512i c = _mm512_maskz_loadu_epi8(mask, cost + d);
      __m512i v[NP];
      for (int k = 0; k < NP; ++k) {
        const std::uint8_t* pk = prev[k] + d;
        const __m512i l0 = _mm512_maskz_loadu_epi8(mask, pk);
        const __m512i lp = _mm512_maskz_loadu_epi8(mask, pk + 1);
        const __m512i lm_k = lm[k];
        lm[k] = _mm512_maskz_loadu_epi8(next, pk + 63);  // before the store below
        __m512i t = _mm512_min_epu8(l0, _mm512_adds_epu8(_mm512_min_epu8(lm_k, lp), v_p1));
        t = _mm512_min_epu8(t, v_min_prev_p2[k]);
        v[k] = _mm512_add_epi8(_mm512_sub_epi8(t, v_min_prev[k]), c);
        _mm512_mask_storeu_epi8(out[k] + d, mask, v[k]);
        v_min_new[k] = _mm512_mask_min_epu8(v_min_new[k], mask, v_min_new[k], v[k]);
      }
      __m512i lo = _mm512_maddubs_epi16(_mm512_unpacklo_epi8(v[0], v[1]), ones);
      __m512i hi = _mm512_maddubs_epi16(_mm512_unpackhi_epi8(v[0], v[1]), ones);
      if constexpr (NP == 4) {
        lo = _mm512_add_epi16(lo, _mm512_maddubs_epi16(_mm512_unpacklo_epi8(v[2], v[3]), ones));
        hi = _mm512_add_epi16(hi, _mm512_maddubs_epi16(_mm512_unpackhi_epi8(v[2], v[3]), ones));
      }
      __m512i s0 = _mm512_permutex2var_epi64(lo, first_half, hi);   // d … d + 31
      __m512i s1 = _mm512_permutex2var_epi64(lo, second_half, hi);  // d + 32 … d + 63
      const auto mask_lo = static_cast<__mmask32>(mask);
      const auto mask_hi = static_cast<__mmask32>(mask >> 32);
      if constexpr (kAdd) {
        s0 = _mm512_add_epi16(s0, _mm512_maskz_loadu_epi16(mask_lo, base + d));
        s1 = _mm512_add_epi16(s1, _mm512_maskz_loadu_epi16(mask_hi, base + d + 32));
      }
      if (!kAdd && dp % 64 == 0) {
        // The claiming pass writes the parked row (64-byte aligned when D_p is a multiple of
        // 64): streaming stores, as it is read back only by the other pass, many rows later
        // (RowMeeting::finish_row fences before publishing the row).
        _mm512_stream_si512(reinterpret_cast<__m512i*>(sum + d), s0);
        _mm512_stream_si512(reinterpret_cast<__m512i*>(sum + d + 32), s1);
      } else {
        _mm512_mask_storeu_epi16(sum + d, mask_lo, s0);
        _mm512_mask_storeu_epi16(sum + d + 32, mask_hi, s1);
      }
    }
    store_minima8<NP>(v_min_new, out, dp);
  }
};

}  // namespace

void run_pass_avx512(int paths, bool forward, const CostInputs& costs, CostRowFunction cost_row,
                     const cv::Mat& gray, const SgmConfig& config, RowMeeting& meeting) {
  if (narrow_entries_fit(config))
    run_pass_with<Avx512NarrowKernel>(paths, forward, costs, cost_row, gray, config, meeting);
  else
    run_pass_with<Avx512Kernel>(paths, forward, costs, cost_row, gray, config, meeting);
}

#else

void run_pass_avx512(int, bool, const CostInputs&, CostRowFunction, const cv::Mat&,
                     const SgmConfig&, RowMeeting&) {
  throw std::logic_error("SGM: the AVX-512 aggregation kernel is not compiled in");
}

#endif

}  // namespace planecell::stereo::detail

#if defined(PLANECELL_SGM_AVX512_KERNEL)
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif
