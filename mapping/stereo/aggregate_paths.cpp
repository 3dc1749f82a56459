/// Semi-global aggregation (paper Eq. 2) over 8 (or 4) paths with row buffers.
///
/// L_r(p, d) = C(p, d) + min(L_r(p−r, d), L_r(p−r, d±1) + P1, min_k L_r(p−r, k) + P2') − min_k L_r(p−r, k)
/// S(p, d) = Σ_r L_r(p, d);  d(p) = argmin_d S(p, d).
///
/// Two passes: forward (rows top→down, x left→right: paths from the left, top-left, top and
/// top-right) and backward (the four opposite paths). Each pass computes the cost row C(·, y, ·)
/// it needs (cost_row: no W·H·D cost volume), keeps only one row of L_r per path (in place), and
/// sums its paths for the current row: the first pass to reach a row writes that partial sum
/// into a [y][x][d] uint16 "parked" volume, the second adds its own paths to it in place and
/// runs the winner-take-all for that row (select_row; the median and left-right check follow
/// on the whole image, filter_winners). With two threads the passes run
/// concurrently and meet in the middle of the image. The per-pixel update has kernels
/// computing the same integers: portable C++, AVX2 (16 disparities per vector with uint16 row
/// buffers, or 32 with uint8 ones when narrow_entries_fit and D_p is a multiple of 32) and
/// AVX-512BW (aggregate_avx512.cpp: 32 per vector with uint16 row buffers, or 64 with uint8
/// ones when narrow_entries_fit), chosen at run time (best_aggregation_kernel). Sums are uint16:
/// L_r ≤ C_max + P2, so the 8-path sum stays below 2^16 when P2 ≤ 7900 (checked by the caller).
#include <stdexcept>
#include <thread>

#include "mapping/stereo/aggregate_pass.hpp"
#include "mapping/stereo/sgm_detail.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace planecell::stereo::detail {
namespace {

/// Portable kernel: the reference loop of Eq. 2 for one pixel and NP paths.
struct PortableKernel {
  using Entry = std::uint16_t;
  template <int NP, bool kAdd>
  static void update(const std::uint8_t* cost, const std::uint16_t* const* prev,
                     std::uint16_t* const* out, const std::uint16_t* p2, std::uint16_t p1, int dp,
                     std::uint16_t* sum, const std::uint16_t* base) {
    for (int d = 0; d < dp; ++d) sum[d] = kAdd ? base[d] : 0;
    for (int k = 0; k < NP; ++k) {
      const std::uint16_t* pk = prev[k];
      const int m = pk[dp + 1];
      int min_new = kMaxCost;
      int old_left = kMaxCost;  // L(d − 1) before overwriting (prev may equal out)
      for (int d = 0; d < dp; ++d) {
        const int old = pk[d];
        const int t = std::min({old, std::min(old_left, static_cast<int>(pk[d + 1])) + p1,
                                m + static_cast<int>(p2[k])});
        old_left = old;
        const int v = t - m + cost[d];
        out[k][d] = static_cast<std::uint16_t>(v);
        min_new = std::min(min_new, v);
        sum[d] = static_cast<std::uint16_t>(sum[d] + v);
      }
      out[k][dp + 1] = static_cast<std::uint16_t>(min_new);
    }
  }
};

#if defined(__AVX2__)
inline std::uint16_t horizontal_min(__m256i v) {
  const __m128i m = _mm_min_epu16(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  return static_cast<std::uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(m)));
}

/// AVX2 kernel: 16 disparities per vector, same values as PortableKernel.
struct Avx2Kernel {
  using Entry = std::uint16_t;
  template <int NP, bool kAdd>
  static void update(const std::uint8_t* cost, const std::uint16_t* const* prev,
                     std::uint16_t* const* out, const std::uint16_t* p2, std::uint16_t p1, int dp,
                     std::uint16_t* sum, const std::uint16_t* base) {
    const __m256i v_p1 = _mm256_set1_epi16(static_cast<short>(p1));
    __m256i v_min_prev[NP], v_min_prev_p2[NP], v_min_new[NP];
    for (int k = 0; k < NP; ++k) {
      const std::uint16_t m = prev[k][dp + 1];
      v_min_prev[k] = _mm256_set1_epi16(static_cast<short>(m));
      v_min_prev_p2[k] = _mm256_set1_epi16(static_cast<short>(m + p2[k]));
      v_min_new[k] = _mm256_set1_epi16(static_cast<short>(kMaxCost));
    }
    // prev[k] may equal out[k] (in-place row buffers): L(d − 1) of the next block is loaded
    // before this block is stored (base[−1] is the +∞ sentinel for d = 0), L(d + 1) comes from
    // memory not yet overwritten.
    __m256i lm[NP];
    for (int k = 0; k < NP; ++k)
      lm[k] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(prev[k] - 1));
    for (int d = 0; d < dp; d += 16) {
      const __m256i c =
          _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(cost + d)));
      __m256i s = kAdd ? _mm256_loadu_si256(reinterpret_cast<const __m256i*>(base + d))
                       : _mm256_setzero_si256();
      for (int k = 0; k < NP; ++k) {
        const std::uint16_t* pk = prev[k] + d;
        const __m256i l0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pk));
        const __m256i lp = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pk + 1));
        const __m256i lm_k = lm[k];
        // Next block's L(d − 1) (within the entry's padding after the last block).
        lm[k] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pk + 15));
        __m256i t = _mm256_min_epu16(l0, _mm256_adds_epu16(_mm256_min_epu16(lm_k, lp), v_p1));
        t = _mm256_min_epu16(t, v_min_prev_p2[k]);
        const __m256i v = _mm256_add_epi16(_mm256_sub_epi16(t, v_min_prev[k]), c);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out[k] + d), v);
        v_min_new[k] = _mm256_min_epu16(v_min_new[k], v);
        s = _mm256_add_epi16(s, v);
      }
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(sum + d), s);
    }
    for (int k = 0; k < NP; ++k) out[k][dp + 1] = horizontal_min(v_min_new[k]);
  }
};

inline std::uint8_t horizontal_min8(__m256i v) {
  const __m128i m = _mm_min_epu8(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  const __m128i w = _mm_min_epu16(_mm_and_si128(m, _mm_set1_epi16(0x00FF)), _mm_srli_epi16(m, 8));
  return static_cast<std::uint8_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(w)));
}

/// AVX2 kernel with uint8 row buffers (32 disparities per vector), same values as
/// PortableKernel; only when narrow_entries_fit and D_p is a multiple of 32. Saturating terms
/// as in the AVX-512 uint8 kernel (aggregate_avx512.cpp); the path sums are formed two paths
/// at a time with VPMADDUBSW (weights 1) and put back in disparity order by VPERM2I128.
struct Avx2NarrowKernel {
  using Entry = std::uint8_t;
  template <int NP, bool kAdd>
  static void update(const std::uint8_t* cost, const std::uint8_t* const* prev,
                     std::uint8_t* const* out, const std::uint16_t* p2, std::uint16_t p1, int dp,
                     std::uint16_t* sum, const std::uint16_t* base) {
    const __m256i v_p1 = _mm256_set1_epi8(static_cast<char>(p1));
    const __m256i ones = _mm256_set1_epi8(1);
    __m256i v_min_prev[NP], v_min_prev_p2[NP], v_min_new[NP], lm[NP];
    for (int k = 0; k < NP; ++k) {
      const int m = prev[k][dp + 1];
      v_min_prev[k] = _mm256_set1_epi8(static_cast<char>(m));
      v_min_prev_p2[k] = _mm256_set1_epi8(static_cast<char>(std::min(255, m + p2[k])));
      v_min_new[k] = _mm256_set1_epi8(static_cast<char>(0xFF));
      lm[k] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(prev[k] - 1));
    }
    for (int d = 0; d < dp; d += 32) {
      const __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cost + d));
      __m256i v[NP];
      for (int k = 0; k < NP; ++k) {
        const std::uint8_t* pk = prev[k] + d;
        const __m256i l0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pk));
        const __m256i lp = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pk + 1));
        const __m256i lm_k = lm[k];
        // Next block's L(d − 1), before the store (within the entry's padding at the end).
        lm[k] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pk + 31));
        __m256i t = _mm256_min_epu8(l0, _mm256_adds_epu8(_mm256_min_epu8(lm_k, lp), v_p1));
        t = _mm256_min_epu8(t, v_min_prev_p2[k]);
        v[k] = _mm256_add_epi8(_mm256_sub_epi8(t, v_min_prev[k]), c);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out[k] + d), v[k]);
        v_min_new[k] = _mm256_min_epu8(v_min_new[k], v[k]);
      }
      __m256i lo = _mm256_maddubs_epi16(_mm256_unpacklo_epi8(v[0], v[1]), ones);
      __m256i hi = _mm256_maddubs_epi16(_mm256_unpackhi_epi8(v[0], v[1]), ones);
      if constexpr (NP == 4) {
        lo = _mm256_add_epi16(lo, _mm256_maddubs_epi16(_mm256_unpacklo_epi8(v[2], v[3]), ones));
        hi = _mm256_add_epi16(hi, _mm256_maddubs_epi16(_mm256_unpackhi_epi8(v[2], v[3]), ones));
      }
      // lo: d 0–7 | 16–23, hi: d 8–15 | 24–31 (per 128-bit lane).
      __m256i s0 = _mm256_permute2x128_si256(lo, hi, 0x20);
      __m256i s1 = _mm256_permute2x128_si256(lo, hi, 0x31);
      if constexpr (kAdd) {
        s0 = _mm256_add_epi16(s0, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(base + d)));
        s1 = _mm256_add_epi16(
            s1, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(base + d + 16)));
      }
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(sum + d), s0);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(sum + d + 16), s1);
    }
    for (int k = 0; k < NP; ++k) out[k][dp + 1] = horizontal_min8(v_min_new[k]);
  }
};
#endif

using PassFunction = void (*)(int, bool, const CostInputs&, CostRowFunction, const cv::Mat&,
                              const SgmConfig&, RowMeeting&);

/// Forward and backward pass, concurrently when config.threads ≥ 2.
void run_passes(PassFunction pass, const CostInputs& costs, CostRowFunction cost_row,
                const cv::Mat& gray, const SgmConfig& config, RowMeeting& meeting) {
  if (config.threads >= 2) {
    std::thread worker([&] { pass(config.paths, false, costs, cost_row, gray, config, meeting); });
    pass(config.paths, true, costs, cost_row, gray, config, meeting);
    worker.join();
  } else {
    pass(config.paths, true, costs, cost_row, gray, config, meeting);
    pass(config.paths, false, costs, cost_row, gray, config, meeting);
  }
}

}  // namespace

RowMeeting::RowMeeting(int width, int height, int dp, const SgmConfig& config,
                       Winners& winners, std::uint16_t* parked, SelectRowFunction select)
    : width_(width), dp_(dp), config_(config), winners_(winners), parked_(parked),
      select_(select),
      state_(std::make_unique<std::atomic<int>[]>(static_cast<std::size_t>(height))) {
  for (int y = 0; y < height; ++y) state_[static_cast<std::size_t>(y)].store(kFree);
}

RowMeeting::Row RowMeeting::start_row(int y) {
  auto& state = state_[static_cast<std::size_t>(y)];
  int expected = kFree;
  if (state.compare_exchange_strong(expected, kClaimed)) return {parked_row(y), nullptr};
  while (state.load(std::memory_order_acquire) != kParked) std::this_thread::yield();
  return {parked_row(y), parked_row(y)};  // summed in place: S = parked + own paths
}

void RowMeeting::finish_row(int y, const Row& row) {
  if (row.base == nullptr) {
#if defined(__x86_64__)
    _mm_sfence();  // the AVX-512 kernel parks with streaming stores, not ordered by release
#endif
    state_[static_cast<std::size_t>(y)].store(kParked, std::memory_order_release);
    return;
  }
  select_(row.sum, width_, config_, winners_.row(y));
}

std::uint16_t* RowMeeting::parked_row(int y) {
  return parked_ + static_cast<std::size_t>(y) * width_ * dp_;
}

bool aggregation_kernel_supported(AggregationKernel kernel) {
  switch (kernel) {
    case AggregationKernel::portable:
      return true;
    case AggregationKernel::avx2:
#if defined(__AVX2__)
      return true;
#else
      return false;
#endif
    case AggregationKernel::avx512:
#if defined(PLANECELL_SGM_AVX512_KERNEL)
      return __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl");
#else
      return false;
#endif
  }
  return false;
}

AggregationKernel best_aggregation_kernel() {
  for (const auto kernel : {AggregationKernel::avx512, AggregationKernel::avx2})
    if (aggregation_kernel_supported(kernel)) return kernel;
  return AggregationKernel::portable;
}

cv::Mat aggregate_and_select(const CostInputs& costs, CostRowFunction cost_row,
                             const cv::Mat& gray_left, const SgmConfig& config,
                             Volume<std::uint16_t>& parked, AggregationKernel kernel) {
  CV_Assert(gray_left.type() == CV_8UC1);
  if (!aggregation_kernel_supported(kernel))
    throw std::invalid_argument("SGM: aggregation kernel not supported on this CPU/build");
  const int dp = padded_disparities(config.max_disparity);
  CV_Assert(parked.size >= static_cast<std::size_t>(gray_left.cols) * gray_left.rows * dp);
  Winners winners(gray_left.cols, gray_left.rows);
  RowMeeting meeting(gray_left.cols, gray_left.rows, dp, config, winners, parked.get(),
                     kernel == AggregationKernel::avx512 ? &select_row_avx512 : &select_row);
  // 8 paths: each pass aggregates 4 (horizontal, vertical, diagonal, anti-diagonal);
  // 4 paths: each pass aggregates horizontal + vertical.
  PassFunction pass = &run_pass_with<PortableKernel>;
#if defined(__AVX2__)
  if (kernel == AggregationKernel::avx2)
    pass = narrow_entries_fit(config) && dp % 32 == 0 ? &run_pass_with<Avx2NarrowKernel>
                                                      : &run_pass_with<Avx2Kernel>;
#endif
  if (kernel == AggregationKernel::avx512) pass = &run_pass_avx512;
  run_passes(pass, costs, cost_row, gray_left, config, meeting);
  return filter_winners(winners, config);
}

}  // namespace planecell::stereo::detail
