#pragma once
/// Winner-take-all on one row of the aggregated cost (select_row, see sgm_detail.hpp), written
/// once and instantiated per SIMD kernel: postprocess.cpp (portable / AVX2) and
/// select_avx512.cpp (AVX-512BW, included there below its target pragma). The kernel supplies
/// its three vector primitives as template arguments; the template lives in an unnamed
/// namespace, so every translation unit compiles its own copy for its own target.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/config/sgm_config.hpp"
#include "mapping/stereo/sgm_detail.hpp"

namespace planecell::stereo::detail {
namespace {

/// RightWinners(S, width, D_p, keys) fills keys[W − 1 − x_r] = min_d (S(x_r + d, d)·2^16 + d)
/// (keys holds width + D_p + key_padding entries); MinCost(s, D_p) = min_d s[d];
/// FirstIndexOf(s, D_p, v) = first d with s[d] == v.
template <auto RightWinners, auto MinCost, auto FirstIndexOf, int key_padding>
void select_row_with(std::uint16_t* S, int width, const SgmConfig& config, const WinnerRow& out) {
  constexpr std::uint16_t kMax = 0xFFFF;
  const int d_max = config.max_disparity;
  const int dp = padded_disparities(d_max);
  if (d_max < dp)
    for (int x = 0; x < width; ++x)
      std::fill(S + static_cast<std::size_t>(x) * dp + d_max,
                S + static_cast<std::size_t>(x + 1) * dp, kMax);
  if (config.lr_check) {
    thread_local std::vector<std::uint32_t> keys;
    keys.resize(static_cast<std::size_t>(width + dp + key_padding));
    RightWinners(S, width, dp, keys.data());
    for (int x_r = 0; x_r < width; ++x_r)
      out.right[x_r] = static_cast<std::uint16_t>(keys[static_cast<std::size_t>(width - 1 - x_r)]);
  }
  for (int x = 0; x < width; ++x) {
    std::uint16_t* s = S + static_cast<std::size_t>(x) * dp;
    const std::uint16_t best = MinCost(s, dp);
    const int d = FirstIndexOf(s, dp, best);
    out.left[x] = static_cast<std::uint16_t>(d);
    bool unique = true;
    if (config.uniqueness_ratio > 0) {
      // Second best outside d−1 … d+1: hide the three, take the minimum, restore. (With ratio 0
      // the test is second ≥ best, always true: skipped.)
      const int lo = std::max(0, d - 1), hi = std::min(d_max - 1, d + 1);
      std::uint16_t saved[3];
      for (int k = lo; k <= hi; ++k) saved[k - lo] = s[k], s[k] = kMax;
      const std::uint16_t second = MinCost(s, dp);
      for (int k = lo; k <= hi; ++k) s[k] = saved[k - lo];
      unique = is_unique(best, second, config.uniqueness_ratio);
    }
    if (!unique) {
      out.disparity[x] = std::numeric_limits<float>::quiet_NaN();
    } else if (config.subpixel && d > 0 && d < d_max - 1) {
      out.disparity[x] = subpixel_parabola(d, s[d - 1], s[d], s[d + 1]);
    } else {
      out.disparity[x] = static_cast<float>(d);
    }
  }
}

}  // namespace
}  // namespace planecell::stereo::detail
