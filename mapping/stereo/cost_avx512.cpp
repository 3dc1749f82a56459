/// Matching cost of Eq. 1 in AVX-512 (VPOPCNTDQ for the Hamming distance, VBMI for the byte
/// reordering): 64 disparities per step. Everything below the target pragma is compiled for
/// that target only and reached only after cost_row_avx512_supported() said the CPU runs it;
/// the headers keep the build's baseline target.
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <stdexcept>
#include <vector>

#include "mapping/stereo/sgm_detail.hpp"

#if defined(PLANECELL_SGM_AVX512_KERNEL)
#include <immintrin.h>
#pragma GCC push_options
#pragma GCC target("avx2,avx512f,avx512bw,avx512vl,avx512vpopcntdq,avx512vbmi")
// GCC 12's intrinsics start from _mm512_undefined_epi32() (a self-initialised variable), which
// -Wmaybe-uninitialized reports once inlined here: a false positive inside the system header.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace planecell::stereo::detail {

#if defined(PLANECELL_SGM_AVX512_KERNEL)

bool cost_row_avx512_supported() {
  return __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl") &&
         __builtin_cpu_supports("avx512vpopcntdq") && __builtin_cpu_supports("avx512vbmi");
}

namespace {

/// Lanes [0, n) of a 64-lane mask (n clamped to [0, 64]).
inline __mmask64 first_bytes(int n) {
  if (n >= 64) return ~__mmask64{0};
  if (n <= 0) return 0;
  return (__mmask64{1} << n) - 1;
}

/// round(λ_grad · min(|g_l − g_r|, cap)) of 32 disparities (gradient_cost), int16 lanes.
inline __m512i gradient_cost32(__m512i g_l, const std::int16_t* g_r, __m512i cap, __m512i lq4) {
  const __m512i diff = _mm512_abs_epi16(_mm512_sub_epi16(g_l, _mm512_loadu_si512(g_r)));
  const __m512i g = _mm512_min_epi16(diff, cap);
  return _mm512_srli_epi16(_mm512_add_epi16(_mm512_mullo_epi16(g, lq4), _mm512_set1_epi16(8)), 4);
}

}  // namespace

/// Per 64 disparities d0 … d0+63 of pixel x: eight vectors h_k of H = popcount(T_L(x) ⊕
/// T_R(x − d)) for d = d0 + 8k + i in 64-bit lanes i; the low bytes of h_2j and h_2j+1 are
/// gathered into bytes 16j … 16j+15 (d order) by one two-source VPERMT2B each and merged.
/// The gradient term is computed in int16 and packed with unsigned saturation, and the sum is
/// saturated at 255 (min(255, H + G) as in matching_cost). valid ≤ d < D gets the out-of-image
/// cost, d ≥ D the padding cost.
void cost_row_avx512(const CostInputs& in, const ReversedRightRow& right, int x_begin, int x_end,
                     std::uint8_t* out) {
  const int y = right.y;
  const int width = in.census_l->width, dp = in.dp, d_max = in.max_disparity;
  const std::uint64_t* census_l = in.census_l->bits.data() + static_cast<std::size_t>(y) * width;
  const std::int16_t* gl = in.gradient_l->ptr<std::int16_t>(y);
  const __m512i cap = _mm512_set1_epi16(static_cast<short>(in.grad_cap));
  const __m512i lq4 = _mm512_set1_epi16(static_cast<short>(in.lambda_q4));
  // Lanes without a match, per 64-lane block: out-of-image below D, padding from D on (only the
  // last block can hold padding: D_p − D < 16).
  const __m512i out_of_image = _mm512_set1_epi8(static_cast<char>(in.out_of_image));
  const int last_block = (dp - 1) / 64 * 64;
  const __m512i last_invalid = _mm512_mask_blend_epi8(
      first_bytes(d_max - last_block), _mm512_set1_epi8(static_cast<char>(in.padding)), out_of_image);
  // Byte 16j + i of the result: byte 0 of qword i of h_2j (i < 8) or of qword i − 8 of h_2j+1.
  alignas(64) std::uint8_t gather[64];
  for (int p = 0; p < 64; ++p) {
    const int i = p % 16;
    gather[p] = static_cast<std::uint8_t>(i < 8 ? 8 * i : 64 + 8 * (i - 8));
  }
  const __m512i low_bytes = _mm512_load_si512(gather);
  // packus_epi16 interleaves the two sources per 128-bit lane: qwords 0,2,4,6 hold the first.
  const __m512i unpack = _mm512_setr_epi64(0, 2, 4, 6, 1, 3, 5, 7);
  for (int x = x_begin; x < x_end; ++x) {
    std::uint8_t* c = out + static_cast<std::size_t>(x - x_begin) * dp;
    const int valid = std::min(d_max, x + 1);  // q = x − d ≥ 0
    const __m512i cl = _mm512_set1_epi64(static_cast<long long>(census_l[x]));
    const std::uint64_t* cr = right.census.data() + (width - 1 - x);
    const std::int16_t* g_r = right.gradient.data() + (width - 1 - x);
    const __m512i g_l = _mm512_set1_epi16(gl[x]);
    for (int d0 = 0; d0 < dp; d0 += 64) {
      const __mmask64 store = first_bytes(dp - d0);
      const __m512i invalid = d0 == last_block ? last_invalid : out_of_image;
      if (d0 >= valid) {
        _mm512_mask_storeu_epi8(c + d0, store, invalid);
        continue;
      }
      __m512i h[8];
      for (int k = 0; k < 8; ++k)
        h[k] = _mm512_popcnt_epi64(_mm512_xor_si512(cl, _mm512_loadu_si512(cr + d0 + 8 * k)));
      const __m512i r0 = _mm512_maskz_permutex2var_epi8(0xFFFFull, h[0], low_bytes, h[1]);
      const __m512i r1 = _mm512_maskz_permutex2var_epi8(0xFFFFull << 16, h[2], low_bytes, h[3]);
      const __m512i r2 = _mm512_maskz_permutex2var_epi8(0xFFFFull << 32, h[4], low_bytes, h[5]);
      const __m512i r3 = _mm512_maskz_permutex2var_epi8(0xFFFFull << 48, h[6], low_bytes, h[7]);
      const __m512i ham = _mm512_or_si512(_mm512_ternarylogic_epi64(r0, r1, r2, 0xFE), r3);
      const __m512i g0 = gradient_cost32(g_l, g_r + d0, cap, lq4);
      const __m512i g1 = gradient_cost32(g_l, g_r + d0 + 32, cap, lq4);
      const __m512i grad = _mm512_permutexvar_epi64(unpack, _mm512_packus_epi16(g0, g1));
      const __m512i cost = _mm512_adds_epu8(ham, grad);
      _mm512_mask_storeu_epi8(c + d0, store,
                              _mm512_mask_blend_epi8(first_bytes(valid - d0), invalid, cost));
    }
  }
}

#else

bool cost_row_avx512_supported() { return false; }

void cost_row_avx512(const CostInputs&, const ReversedRightRow&, int, int, std::uint8_t*) {
  throw std::logic_error("SGM: the AVX-512 cost kernel is not compiled in");
}

#endif

}  // namespace planecell::stereo::detail

#if defined(PLANECELL_SGM_AVX512_KERNEL)
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif
