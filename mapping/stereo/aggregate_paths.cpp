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
/// and meet in the middle of the image. Costs are uint16: L_r ≤ C_max + P2, so the 8-path sum
/// stays below 2^16 when P2 ≤ 7900 (checked by the caller).
#include <cstring>
#include <atomic>
#include <thread>

#include "mapping/stereo/sgm_detail.hpp"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace planecell::stereo::detail {
namespace {

constexpr std::uint16_t kMaxCost = 0xFFFF;

/// A row of L_r entries. Entry i: base(i)[-1] and base(i)[D_p] are +∞ sentinels (so d±1 never
/// wins at the ends), base(i)[0, D_p) holds L_r(·, d), base(i)[D_p + 1] holds min_k L_r(·, k).
class EntryRow {
 public:
  EntryRow(int entries, int dp)
      : dp_(dp), stride_(dp + 16), data_(static_cast<std::size_t>(entries) * (dp + 16), 0) {
    for (int i = 0; i < entries; ++i) {
      base(i)[-1] = kMaxCost;
      base(i)[dp_] = kMaxCost;
    }
  }
  std::uint16_t* base(int i) { return data_.data() + static_cast<std::size_t>(i) * stride_ + 8; }

 private:
  int dp_, stride_;
  std::vector<std::uint16_t> data_;
};

#if defined(__AVX2__)
inline std::uint16_t horizontal_min(__m256i v) {
  const __m128i m = _mm_min_epu16(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  return static_cast<std::uint16_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(m)));
}
#endif

/// One pixel of Eq. 2 for NP paths at once: out[k] = L_k(p, ·) from prev[k] = L_k(p − r_k, ·);
/// sum = Σ_k out[k]. AVX2: 16 disparities per vector; the portable loop computes the same values.
template <int NP>
inline void update_pixel(const std::uint8_t* cost, const std::uint16_t* const* prev,
                         std::uint16_t* const* out, const std::uint16_t* p2, std::uint16_t p1,
                         int dp, std::uint16_t* sum) {
#if defined(__AVX2__)
  const __m256i v_p1 = _mm256_set1_epi16(static_cast<short>(p1));
  __m256i v_min_prev[NP], v_min_prev_p2[NP], v_min_new[NP];
  for (int k = 0; k < NP; ++k) {
    const std::uint16_t m = prev[k][dp + 1];
    v_min_prev[k] = _mm256_set1_epi16(static_cast<short>(m));
    v_min_prev_p2[k] = _mm256_set1_epi16(static_cast<short>(m + p2[k]));
    v_min_new[k] = _mm256_set1_epi16(static_cast<short>(kMaxCost));
  }
  // prev[k] may equal out[k] (in-place row buffers): L(d − 1) comes from the previous block's
  // old values kept in a register, L(d + 1) from memory not yet overwritten.
  __m256i carry[NP];
  for (int k = 0; k < NP; ++k) carry[k] = _mm256_set1_epi16(static_cast<short>(kMaxCost));
  for (int d = 0; d < dp; d += 16) {
    const __m256i c =
        _mm256_cvtepu8_epi16(_mm_loadu_si128(reinterpret_cast<const __m128i*>(cost + d)));
    __m256i s = _mm256_setzero_si256();
    for (int k = 0; k < NP; ++k) {
      const std::uint16_t* pk = prev[k] + d;
      const __m256i l0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pk));
      const __m256i lp = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pk + 1));
      // lm = (carry[15], l0[0 … 14])
      const __m256i lm =
          _mm256_alignr_epi8(l0, _mm256_permute2x128_si256(carry[k], l0, 0x21), 14);
      carry[k] = l0;
      __m256i t = _mm256_min_epu16(l0, _mm256_adds_epu16(_mm256_min_epu16(lm, lp), v_p1));
      t = _mm256_min_epu16(t, v_min_prev_p2[k]);
      const __m256i v = _mm256_add_epi16(_mm256_sub_epi16(t, v_min_prev[k]), c);
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out[k] + d), v);
      v_min_new[k] = _mm256_min_epu16(v_min_new[k], v);
      s = _mm256_add_epi16(s, v);
    }
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(sum + d), s);
  }
  for (int k = 0; k < NP; ++k) out[k][dp + 1] = horizontal_min(v_min_new[k]);
#else
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
#endif
}

/// Hand-over of row partial sums between the two passes (see file comment). The first pass to
/// start a row claims it and writes its sum straight into the parked volume; the other pass sums
/// into its own row buffer and, at the end of the row, adds the parked sum and selects.
class RowMeeting {
 public:
  RowMeeting(int width, int height, int dp, const SgmConfig& config, cv::Mat& disparity,
             std::uint16_t* parked)
      : width_(width), dp_(dp), config_(config), disparity_(disparity), parked_(parked),
        state_(std::make_unique<std::atomic<int>[]>(static_cast<std::size_t>(height))) {
    for (int y = 0; y < height; ++y) state_[static_cast<std::size_t>(y)].store(kFree);
  }

  /// Where a pass accumulates row y: the parked row when it claims it, else `own`.
  std::uint16_t* start_row(int y, std::uint16_t* own) {
    int expected = kFree;
    if (state_[static_cast<std::size_t>(y)].compare_exchange_strong(expected, kClaimed))
      return parked_row(y);
    return own;
  }

  /// Ends row y for a pass that summed into `sum` (as returned by start_row).
  void finish_row(int y, std::uint16_t* sum) {
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

 private:
  static constexpr int kFree = 0, kClaimed = 1, kParked = 2;
  std::uint16_t* parked_row(int y) {
    return parked_ + static_cast<std::size_t>(y) * width_ * dp_;
  }
  int width_, dp_;
  const SgmConfig& config_;
  cv::Mat& disparity_;
  std::uint16_t* parked_;
  std::unique_ptr<std::atomic<int>[]> state_;
};

/// One aggregation pass (forward or backward) over all rows, NP paths.
template <int NP>
class Pass {
 public:
  Pass(bool forward, const Volume<std::uint8_t>& cost, const cv::Mat& gray,
       const SgmConfig& config, RowMeeting& meeting)
      : forward_(forward), cost_(cost), gray_(gray), meeting_(meeting),
        width_(gray.cols), height_(gray.rows), dp_(padded_disparities(config.max_disparity)),
        p1_(static_cast<std::uint16_t>(config.p1)), p2_table_(p2_table(config)),
        singles_(2, dp_), vertical_(width_, dp_),
        diagonal_(NP == 4 ? width_ + height_ - 1 : 1, dp_), anti_(NP == 4 ? width_ : 1, dp_),
        row_sum_(static_cast<std::size_t>(width_) * dp_) {}

  /// All row buffers are updated in place (update_pixel allows prev == out). The diagonal path
  /// stores pixel (x, row i) at x − dir·i (+ offset), so its predecessor (x − dir, row i − 1)
  /// sits at the same index; the anti-diagonal reads x + dir, not yet overwritten in this row.
  void run() {
    const int dir = forward_ ? 1 : -1;
    std::uint16_t* zero = singles_.base(0);  // L = 0, min = 0: "no predecessor" → L_r = C
    std::uint16_t* horizontal = singles_.base(1);
    const int x_begin = forward_ ? 0 : width_ - 1;
    const int diag_offset = forward_ ? height_ - 1 : 0;
    for (int i = 0; i < height_; ++i) {
      const int y = forward_ ? i : height_ - 1 - i;
      const bool has_row_pred = i > 0;
      const std::uint8_t* g = gray_.ptr<std::uint8_t>(y);
      const std::uint8_t* g_pred = has_row_pred ? gray_.ptr<std::uint8_t>(y - dir) : g;
      const std::uint8_t* row_cost = cost_.get() + static_cast<std::size_t>(y) * width_ * dp_;
      std::uint16_t* sum = meeting_.start_row(y, row_sum_.data());
      for (int j = 0; j < width_; ++j) {
        const int x = x_begin + dir * j;
        const bool has_left = j > 0;            // x − dir inside
        const bool has_right = j + 1 < width_;  // x + dir inside
        const std::uint16_t* prev[4];
        std::uint16_t* out[4];
        std::uint16_t p2[4];
        prev[0] = has_left ? horizontal : zero;
        out[0] = horizontal;
        p2[0] = p2_at(g[x], has_left ? g[x - dir] : g[x]);
        out[1] = vertical_.base(x);
        prev[1] = has_row_pred ? out[1] : zero;
        p2[1] = p2_at(g[x], g_pred[x]);
        if constexpr (NP == 4) {
          out[2] = diagonal_.base(x - dir * i + diag_offset);
          prev[2] = (has_row_pred && has_left) ? out[2] : zero;
          p2[2] = p2_at(g[x], has_left ? g_pred[x - dir] : g[x]);
          prev[3] = (has_row_pred && has_right) ? anti_.base(x + dir) : zero;
          out[3] = anti_.base(x);
          p2[3] = p2_at(g[x], has_right ? g_pred[x + dir] : g[x]);
        }
        update_pixel<NP>(row_cost + static_cast<std::size_t>(x) * dp_, prev, out, p2, p1_, dp_,
                         sum + static_cast<std::size_t>(x) * dp_);
      }
      meeting_.finish_row(y, sum);
    }
  }

 private:
  std::uint16_t p2_at(std::uint8_t a, std::uint8_t b) const {
    return p2_table_[static_cast<std::size_t>(std::abs(int{a} - int{b}))];
  }

  bool forward_;
  const Volume<std::uint8_t>& cost_;
  const cv::Mat& gray_;
  RowMeeting& meeting_;
  int width_, height_, dp_;
  std::uint16_t p1_;
  std::vector<std::uint16_t> p2_table_;
  EntryRow singles_, vertical_, diagonal_, anti_;
  std::vector<std::uint16_t> row_sum_;
};

template <int NP>
void run_passes(const Volume<std::uint8_t>& cost, const cv::Mat& gray, const SgmConfig& config,
                RowMeeting& meeting) {
  Pass<NP> forward(true, cost, gray, config, meeting);
  Pass<NP> backward(false, cost, gray, config, meeting);
  if (config.threads >= 2) {
    std::thread worker([&backward] { backward.run(); });
    forward.run();
    worker.join();
  } else {
    forward.run();
    backward.run();
  }
}

}  // namespace

cv::Mat aggregate_and_select(const Volume<std::uint8_t>& cost, const cv::Mat& gray_left,
                             const SgmConfig& config, Volume<std::uint16_t>& parked) {
  CV_Assert(gray_left.type() == CV_8UC1);
  const int dp = padded_disparities(config.max_disparity);
  CV_Assert(parked.size >= static_cast<std::size_t>(gray_left.cols) * gray_left.rows * dp);
  cv::Mat disparity(gray_left.size(), CV_32F);
  RowMeeting meeting(gray_left.cols, gray_left.rows, dp, config, disparity, parked.get());
  // 8 paths: each pass aggregates 4 (horizontal, vertical, diagonal, anti-diagonal);
  // 4 paths: each pass aggregates horizontal + vertical.
  if (config.paths == 4) run_passes<2>(cost, gray_left, config, meeting);
  else run_passes<4>(cost, gray_left, config, meeting);
  return disparity;
}

}  // namespace planecell::stereo::detail
