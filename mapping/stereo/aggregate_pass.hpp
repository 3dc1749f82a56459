#pragma once
/// One aggregation pass of Eq. 2 (see aggregate_paths.cpp for the maths and the two-pass scheme),
/// written once and instantiated per SIMD kernel: aggregate_paths.cpp (portable, AVX2) and
/// aggregate_avx512.cpp (AVX-512BW, compiled for that target only). Pass and EntryRow live in an
/// unnamed namespace, so every translation unit gets its own copy compiled for its own target.
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "core/config/sgm_config.hpp"
#include "mapping/stereo/sgm_detail.hpp"

namespace planecell::stereo::detail {

/// Hand-over of row partial sums between the two passes. The first pass to start a row claims it
/// and writes its sum straight into the parked volume; the other pass sums into its own row
/// buffer and, at the end of the row, adds the parked sum and selects (select_row).
class RowMeeting {
 public:
  RowMeeting(int width, int height, int dp, const SgmConfig& config, cv::Mat& disparity,
             std::uint16_t* parked);
  /// Where a pass accumulates row y: the parked row when it claims it, else `own`.
  std::uint16_t* start_row(int y, std::uint16_t* own);
  /// Ends row y for a pass that summed into `sum` (as returned by start_row).
  void finish_row(int y, std::uint16_t* sum);

 private:
  static constexpr int kFree = 0, kClaimed = 1, kParked = 2;
  std::uint16_t* parked_row(int y);
  int width_, dp_;
  const SgmConfig& config_;
  cv::Mat& disparity_;
  std::uint16_t* parked_;
  std::unique_ptr<std::atomic<int>[]> state_;
};

/// Runs one pass (forward or backward) of `paths` / 2 paths with the AVX-512BW kernel.
/// Only call when aggregation_kernel_supported(AggregationKernel::avx512).
void run_pass_avx512(int paths, bool forward, const Volume<std::uint8_t>& cost,
                     const cv::Mat& gray, const SgmConfig& config, RowMeeting& meeting);

namespace {

constexpr std::uint16_t kMaxCost = 0xFFFF;

/// A row of L_r entries. Entry i: base(i)[-1] and base(i)[D_p] are +∞ sentinels (so d±1 never
/// wins at the ends), base(i)[0, D_p) holds L_r(·, d), base(i)[D_p + 1] holds min_k L_r(·, k).
/// base(i)[D_p + 2, D_p + 15] is padding that a 16-lane kernel may read (never use); the last
/// entry gets the same padding from the 16 extra values at the end.
class EntryRow {
 public:
  EntryRow(int entries, int dp)
      : dp_(dp), stride_(dp + 16),
        data_(static_cast<std::size_t>(entries) * (dp + 16) + 16, 0) {
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

/// One aggregation pass (forward or backward) over all rows, NP paths. Kernel::update<NP>
/// computes one pixel: out[k] = L_k(p, ·) from prev[k] = L_k(p − r_k, ·) (prev[k] may equal
/// out[k]), out[k][D_p + 1] = min_d out[k][d], sum = Σ_k out[k].
template <int NP, class Kernel>
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

  /// All row buffers are updated in place. The diagonal path stores pixel (x, row i) at
  /// x − dir·i (+ offset), so its predecessor (x − dir, row i − 1) sits at the same index; the
  /// anti-diagonal reads x + dir, not yet overwritten in this row.
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
        Kernel::template update<NP>(row_cost + static_cast<std::size_t>(x) * dp_, prev, out,
                                    p2, p1_, dp_, sum + static_cast<std::size_t>(x) * dp_);
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

/// Constructs and runs one pass of `paths` / 2 paths with Kernel.
template <class Kernel>
void run_pass_with(int paths, bool forward, const Volume<std::uint8_t>& cost, const cv::Mat& gray,
                   const SgmConfig& config, RowMeeting& meeting) {
  if (paths == 4) Pass<2, Kernel>(forward, cost, gray, config, meeting).run();
  else Pass<4, Kernel>(forward, cost, gray, config, meeting).run();
}

}  // namespace
}  // namespace planecell::stereo::detail
