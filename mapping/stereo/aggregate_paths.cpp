/// Semi-global aggregation (paper Eq. 2) over 8 (or 4) paths with row buffers.
///
/// L_r(p, d) = C(p, d) + min(L_r(p−r, d), L_r(p−r, d±1) + P1, min_k L_r(p−r, k) + P2') − min_k L_r(p−r, k)
/// S(p, d) = Σ_r L_r(p, d);  d(p) = argmin_d S(p, d).
///
/// Two passes: forward (rows top→down, x left→right: paths from the left, top-left, top and
/// top-right) and backward (the four opposite paths). Each pass keeps only one row of L_r per
/// path (in place) and the sum of its paths for the current row; the first pass to finish a row
/// parks that partial sum in a [y][x][d] uint16 volume, the second adds its own and runs the
/// winner-take-all for that row (select_row). With two threads the passes run concurrently
/// and meet in the middle of the image. The per-pixel update has three kernels computing the
/// same integers: portable C++, AVX2 (16 disparities per vector) and AVX-512BW (32, in
/// aggregate_avx512.cpp), chosen at run time (best_aggregation_kernel). Costs are uint16:
/// L_r ≤ C_max + P2, so the 8-path sum stays below 2^16 when P2 ≤ 7900 (checked by the caller).
#include <stdexcept>
#include <thread>

#include "mapping/stereo/aggregate_pass.hpp"
#include "mapping/stereo/sgm_detail.hpp"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace planecell::stereo::detail {
namespace {

/// Portable kernel: the reference loop of Eq. 2 for one pixel and NP paths.
struct PortableKernel {
  template <int NP>
  static void update(const std::uint8_t* cost, const std::uint16_t* const* prev,
                     std::uint16_t* const* out, const std::uint16_t* p2, std::uint16_t p1, int dp,
                     std::uint16_t* sum) {
    for (int d = 0; d < dp; ++d) sum[d] = 0;
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
  template <int NP>
  static void update(const std::uint8_t* cost, const std::uint16_t* const* prev,
                     std::uint16_t* const* out, const std::uint16_t* p2, std::uint16_t p1, int dp,
                     std::uint16_t* sum) {
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
      __m256i s = _mm256_setzero_si256();
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
#endif

using PassFunction = void (*)(int, bool, const Volume<std::uint8_t>&, const cv::Mat&,
                              const SgmConfig&, RowMeeting&);

/// Forward and backward pass, concurrently when config.threads ≥ 2.
void run_passes(PassFunction pass, const Volume<std::uint8_t>& cost, const cv::Mat& gray,
                const SgmConfig& config, RowMeeting& meeting) {
  if (config.threads >= 2) {
    std::thread worker([&] { pass(config.paths, false, cost, gray, config, meeting); });
    pass(config.paths, true, cost, gray, config, meeting);
    worker.join();
  } else {
    pass(config.paths, true, cost, gray, config, meeting);
    pass(config.paths, false, cost, gray, config, meeting);
  }
}

}  // namespace

RowMeeting::RowMeeting(int width, int height, int dp, const SgmConfig& config,
                       cv::Mat& disparity, std::uint16_t* parked)
    : width_(width), dp_(dp), config_(config), disparity_(disparity), parked_(parked),
      state_(std::make_unique<std::atomic<int>[]>(static_cast<std::size_t>(height))) {
  for (int y = 0; y < height; ++y) state_[static_cast<std::size_t>(y)].store(kFree);
}

std::uint16_t* RowMeeting::start_row(int y, std::uint16_t* own) {
  int expected = kFree;
  if (state_[static_cast<std::size_t>(y)].compare_exchange_strong(expected, kClaimed))
    return parked_row(y);
  return own;
}

void RowMeeting::finish_row(int y, std::uint16_t* sum) {
  std::uint16_t* parked = parked_row(y);
  auto& state = state_[static_cast<std::size_t>(y)];
  if (sum == parked) {
    state.store(kParked, std::memory_order_release);
    return;
  }
  while (state.load(std::memory_order_acquire) != kParked) std::this_thread::yield();
  const std::size_t row_len = static_cast<std::size_t>(width_) * dp_;
  for (std::size_t i = 0; i < row_len; ++i)
    sum[i] = static_cast<std::uint16_t>(sum[i] + parked[i]);
  select_row(sum, width_, config_, disparity_.ptr<float>(y));
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

cv::Mat aggregate_and_select(const Volume<std::uint8_t>& cost, const cv::Mat& gray_left,
                             const SgmConfig& config, Volume<std::uint16_t>& parked,
                             AggregationKernel kernel) {
  CV_Assert(gray_left.type() == CV_8UC1);
  if (!aggregation_kernel_supported(kernel))
    throw std::invalid_argument("SGM: aggregation kernel not supported on this CPU/build");
  const int dp = padded_disparities(config.max_disparity);
  CV_Assert(parked.size >= static_cast<std::size_t>(gray_left.cols) * gray_left.rows * dp);
  cv::Mat disparity(gray_left.size(), CV_32F);
  RowMeeting meeting(gray_left.cols, gray_left.rows, dp, config, disparity, parked.get());
  // 8 paths: each pass aggregates 4 (horizontal, vertical, diagonal, anti-diagonal);
  // 4 paths: each pass aggregates horizontal + vertical.
  PassFunction pass = &run_pass_with<PortableKernel>;
#if defined(__AVX2__)
  if (kernel == AggregationKernel::avx2) pass = &run_pass_with<Avx2Kernel>;
#endif
  if (kernel == AggregationKernel::avx512) pass = &run_pass_avx512;
  run_passes(pass, cost, gray_left, config, meeting);
  return disparity;
}

}  // namespace planecell::stereo::detail
