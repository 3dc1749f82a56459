#pragma once
/// One aggregation pass of Eq. 2 (see aggregate_paths.cpp for the maths and the two-pass scheme),
/// written once and instantiated per SIMD kernel: aggregate_paths.cpp (portable, AVX2) and
/// aggregate_avx512.cpp (AVX-512BW, compiled for that target only). Pass and EntryRow live in an
/// unnamed namespace, so every translation unit gets its own copy compiled for its own target.
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "core/config/sgm_config.hpp"
#include "mapping/stereo/sgm_detail.hpp"

namespace planecell::stereo::detail {

/// Hand-over of row partial sums between the two passes. The first pass to start a row claims it
/// and writes its sum straight into the parked volume; the other pass waits until that row is
/// parked (at most the time of one row, where the passes meet), adds its own paths to the
/// parked sum in place, and selects (select_row) on that row.
class RowMeeting {
 public:
  RowMeeting(int width, int height, int dp, const SgmConfig& config, Winners& winners,
             std::uint16_t* parked, SelectRowFunction select);
  struct Row {
    std::uint16_t* sum;         ///< where the pass writes its sum: the parked row
    const std::uint16_t* base;  ///< parked sum of the other pass to add (= sum), or nullptr
  };
  /// Where a pass accumulates row y.
  Row start_row(int y);
  /// Ends row y for a pass that summed into `row.sum`.
  void finish_row(int y, const Row& row);

 private:
  static constexpr int kFree = 0, kClaimed = 1, kParked = 2;
  std::uint16_t* parked_row(int y);
  int width_, dp_;
  const SgmConfig& config_;
  Winners& winners_;
  std::uint16_t* parked_;
  SelectRowFunction select_;
  std::unique_ptr<std::atomic<int>[]> state_;
};

/// Runs one pass (forward or backward) of `paths` / 2 paths with the AVX-512BW kernel.
/// Only call when aggregation_kernel_supported(AggregationKernel::avx512).
void run_pass_avx512(int paths, bool forward, const CostInputs& costs, CostRowFunction cost_row,
                     const cv::Mat& gray, const SgmConfig& config, RowMeeting& meeting);

namespace {

constexpr std::uint16_t kMaxCost = 0xFFFF;

/// n values of T, zero-initialised, 64-byte aligned (whole 512-bit vectors never straddle two
/// cache lines when the offsets are multiples of 64 bytes).
template <class T>
class AlignedArray {
 public:
  explicit AlignedArray(std::size_t n)
      : data_(static_cast<T*>(std::aligned_alloc(64, (n * sizeof(T) + 63) / 64 * 64))) {
    if (!data_) throw std::bad_alloc();
    std::fill(data_.get(), data_.get() + n, T{0});
  }
  T* data() { return data_.get(); }

 private:
  struct Free {
    void operator()(T* p) const noexcept { std::free(p); }
  };
  std::unique_ptr<T[], Free> data_;
};

/// A row of L_r entries of type T (uint16, or uint8 when narrow_entries_fit). Entry i:
/// base(i)[-1] and base(i)[D_p] are +∞ sentinels (the largest T, so d±1 never wins at the ends),
/// base(i)[0, D_p) holds L_r(·, d), base(i)[D_p + 1] holds min_k L_r(·, k).
/// base(i)[D_p + 2, D_p + 15] is padding that a 16-lane kernel may read (never use); the last
/// entry gets the same padding from the 16 extra values at the end. Every base(i) is 64-byte
/// aligned (the stride is rounded up to 64 bytes).
template <class T>
class EntryRow {
  static constexpr int kAlign = 64 / sizeof(T);  ///< values per 64 bytes

 public:
  EntryRow(int entries, int dp)
      : dp_(dp),
        stride_((dp + 16 + kAlign - 1) / kAlign * kAlign),
        data_(static_cast<std::size_t>(entries) * stride_ + kAlign + 16) {
    for (int i = 0; i < entries; ++i) {
      base(i)[-1] = std::numeric_limits<T>::max();
      base(i)[dp_] = std::numeric_limits<T>::max();
    }
  }
  T* base(int i) { return data_.data() + static_cast<std::size_t>(i) * stride_ + kAlign; }

 private:
  int dp_, stride_;
  AlignedArray<T> data_;
};

/// One aggregation pass (forward or backward) over all rows, NP paths. Each row's costs are
/// computed by `cost_row` into a row buffer just before the row is aggregated (computing them
/// in L1-sized chunks of 64 pixels between the pixel updates measured slower).
/// Kernel::update<NP, kAdd> computes one pixel: out[k] = L_k(p, ·) from prev[k] = L_k(p − r_k, ·)
/// (prev[k] may equal out[k]), out[k][D_p + 1] = min_d out[k][d], sum = Σ_k out[k] (+ base when
/// kAdd; base may equal sum: each block is read before it is written). Kernel::Entry is the type of
/// the row buffers' L_r values.
template <int NP, class Kernel>
class Pass {
  using Entry = typename Kernel::Entry;

 public:
  Pass(bool forward, const CostInputs& costs, CostRowFunction cost_row, const cv::Mat& gray,
       const SgmConfig& config, RowMeeting& meeting)
      : forward_(forward),
        costs_(costs),
        cost_row_(cost_row),
        gray_(gray),
        meeting_(meeting),
        width_(gray.cols),
        height_(gray.rows),
        dp_(padded_disparities(config.max_disparity)),
        p1_(static_cast<std::uint16_t>(config.p1)),
        p2_table_(p2_table(config)),
        singles_(2, dp_),
        vertical_(width_, dp_),
        diagonal_(NP == 4 ? width_ + height_ - 1 : 1, dp_),
        anti_(NP == 4 ? width_ : 1, dp_),
        row_cost_(static_cast<std::size_t>(width_) * dp_) {}

  /// All row buffers are updated in place. The diagonal path stores pixel (x, row i) at
  /// x − dir·i (+ offset), so its predecessor (x − dir, row i − 1) sits at the same index; the
  /// anti-diagonal reads x + dir, not yet overwritten in this row.
  void run() {
    for (int i = 0; i < height_; ++i) {
      const int y = forward_ ? i : height_ - 1 - i;
      right_row_.load(costs_, y);
      cost_row_(costs_, right_row_, 0, width_, row_cost_.data());
      const RowMeeting::Row row = meeting_.start_row(y);
      if (row.base != nullptr)
        aggregate_row<true>(i, y, row);
      else
        aggregate_row<false>(i, y, row);
      meeting_.finish_row(y, row);
    }
  }

 private:
  template <bool kAdd>
  void aggregate_row(int i, int y, const RowMeeting::Row& row) {
    const int dir = forward_ ? 1 : -1;
    Entry* zero = singles_.base(0);  // L = 0, min = 0: "no predecessor" → L_r = C
    Entry* horizontal = singles_.base(1);
    const int x_begin = forward_ ? 0 : width_ - 1;
    const int diag_offset = forward_ ? height_ - 1 : 0;
    const bool has_row_pred = i > 0;
    const std::uint8_t* g = gray_.ptr<std::uint8_t>(y);
    const std::uint8_t* g_pred = has_row_pred ? gray_.ptr<std::uint8_t>(y - dir) : g;
    const std::uint8_t* row_cost = row_cost_.data();
    for (int j = 0; j < width_; ++j) {
      const int x = x_begin + dir * j;
      const bool has_left = j > 0;            // x − dir inside
      const bool has_right = j + 1 < width_;  // x + dir inside
      const Entry* prev[4];
      Entry* out[4];
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
      const std::size_t at = static_cast<std::size_t>(x) * dp_;
      Kernel::template update<NP, kAdd>(row_cost + at, prev, out, p2, p1_, dp_, row.sum + at,
                                        kAdd ? row.base + at : nullptr);
    }
  }

  std::uint16_t p2_at(std::uint8_t a, std::uint8_t b) const {
    return p2_table_[static_cast<std::size_t>(std::abs(int{a} - int{b}))];
  }

  bool forward_;
  const CostInputs& costs_;
  CostRowFunction cost_row_;
  const cv::Mat& gray_;
  RowMeeting& meeting_;
  int width_, height_, dp_;
  std::uint16_t p1_;
  std::vector<std::uint16_t> p2_table_;
  EntryRow<Entry> singles_, vertical_, diagonal_, anti_;
  AlignedArray<std::uint8_t> row_cost_;
  ReversedRightRow right_row_;
};

/// Constructs and runs one pass of `paths` / 2 paths with Kernel.
template <class Kernel>
void run_pass_with(int paths, bool forward, const CostInputs& costs, CostRowFunction cost_row,
                   const cv::Mat& gray, const SgmConfig& config, RowMeeting& meeting) {
  if (paths == 4)
    Pass<2, Kernel>(forward, costs, cost_row, gray, config, meeting).run();
  else
    Pass<4, Kernel>(forward, costs, cost_row, gray, config, meeting).run();
}

}  // namespace
}  // namespace planecell::stereo::detail
