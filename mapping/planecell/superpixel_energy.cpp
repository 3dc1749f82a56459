/// Superpixel energy E(S) = H(S) + λ_reg·R(S) + λ_depth·D(S) (paper Eq. 4) and its block costs
/// c1, c2 (paper §4.5), plus the state they read: colour bins, disparities, segment statistics.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "mapping/planecell/superpixel_state.hpp"

namespace planecell::extraction::detail {
namespace {

/// Lab (8-bit OpenCV scaling) → one of 5×5×5 bins. L is split uniformly; a and b, which rarely
/// leave [68, 188] in natural images, into 24-wide bins centred on the neutral value 128:
///   bin = (⌊5L/256⌋·5 + q(a))·5 + q(b),  q(x) = clamp(⌊(x − 68)/24⌋, 0, 4),
/// read from two 256-entry tables (L part premultiplied by 25, a part by 5).
struct LabBinTables {
  std::array<std::uint8_t, 256> l25{}, a5{}, b1{};
};

constexpr LabBinTables make_lab_bin_tables() {
  LabBinTables t;
  constexpr int n = kEnergyBinsPerChannel;
  for (int x = 0; x < 256; ++x) {
    const int q = std::clamp((x - 68) / 24, 0, n - 1);
    t.l25[x] = static_cast<std::uint8_t>(x * n / 256 * n * n);
    t.a5[x] = static_cast<std::uint8_t>(q * n);
    t.b1[x] = static_cast<std::uint8_t>(q);
  }
  return t;
}

constexpr LabBinTables kLabBins = make_lab_bin_tables();

}  // namespace

SuperpixelState make_initial_state(const cv::Mat& bgr, const cv::Mat& disparity,
                                   const ExtractionConfig& config) {
  SuperpixelState s;
  s.width = bgr.cols;
  s.height = bgr.rows;
  const int n_pixels = s.width * s.height;
  s.cell_size_px = std::max(
      1, static_cast<int>(std::floor(std::sqrt(static_cast<double>(n_pixels) /
                                               std::max(1, config.target_cells)))));

  // Colour bins of the colour term H(S).
  cv::Mat lab;
  cv::cvtColor(bgr, lab, cv::COLOR_BGR2Lab);
  s.bins.resize(n_pixels);
  for (int v = 0; v < s.height; ++v) {
    const auto* row = lab.ptr<cv::Vec3b>(v);
    std::uint8_t* out = s.bins.data() + v * s.width;
    for (int u = 0; u < s.width; ++u)
      out[u] = static_cast<std::uint8_t>(kLabBins.l25[row[u][0]] + kLabBins.a5[row[u][1]] +
                                         kLabBins.b1[row[u][2]]);
  }

  // Disparity (NaN where unmatched).
  s.disparity.resize(n_pixels);
  for (int v = 0; v < s.height; ++v) {
    const float* row = disparity.ptr<float>(v);
    float* out = s.disparity.data() + static_cast<std::size_t>(v) * s.width;
    for (int u = 0; u < s.width; ++u) {
      const float d = row[u];
      out[u] = std::isfinite(d) && d > 0.0f ? d : std::numeric_limits<float>::quiet_NaN();
    }
  }

  // Initial grid of ⌊W/s⌋ × ⌊H/s⌋ cells, borders snapped to the level-1 block grid.
  const int cs = s.cell_size_px;
  const int nx = std::max(1, s.width / cs);
  const int ny = std::max(1, s.height / cs);
  const int snap = config.block_levels > 0 ? block_size(cs, config.block_levels, 1) : 1;
  auto borders = [snap](int extent, int n) {
    std::vector<int> index(extent);
    int cell = 0;
    for (int i = 0; i < n; ++i) {
      const int end = i + 1 == n ? extent
                                 : static_cast<int>(std::lround(static_cast<double>(i + 1) *
                                                                extent / n / snap)) * snap;
      while (cell < std::min(end, extent)) index[cell++] = i;
    }
    while (cell < extent) index[cell++] = n - 1;
    return index;
  };
  const std::vector<int> column = borders(s.width, nx), row = borders(s.height, ny);
  s.labels.resize(n_pixels);
  for (int v = 0; v < s.height; ++v) {
    const int row_label = row[v] * nx;
    std::int32_t* out = s.labels.data() + static_cast<std::size_t>(v) * s.width;
    for (int u = 0; u < s.width; ++u) out[u] = row_label + column[u];
  }
  s.num_segments = nx * ny;
  s.planes.assign(s.num_segments, DisparityPlane{});
  s.has_plane.assign(s.num_segments, 0);
  s.weights.reg_per_px2 = config.lambda_reg / (static_cast<double>(cs) * cs);
  s.weights.depth = config.lambda_depth;
  s.weights.depth_truncation_px = std::max(1e-3, config.depth_truncation_px);
  recompute_statistics(s);
  return s;
}

void recompute_statistics(SuperpixelState& s) {
  s.histogram.assign(static_cast<std::size_t>(s.num_segments) * kEnergyBins, 0);
  s.size.assign(s.num_segments, 0);
  s.sum_u.assign(s.num_segments, 0.0);
  s.sum_v.assign(s.num_segments, 0.0);
  for (int v = 0; v < s.height; ++v) {
    const std::int32_t* row = s.labels.data() + static_cast<std::size_t>(v) * s.width;
    const std::uint8_t* bins = s.bins.data() + static_cast<std::size_t>(v) * s.width;
    for (int u = 0; u < s.width; ++u)
      ++s.histogram[static_cast<std::size_t>(row[u]) * kEnergyBins + bins[u]];
    int u = 0;
    while (u < s.width) {  // one run of equal labels at a time: Σu over [u0, u) in closed form
      const int u0 = u;
      const int l = row[u];
      while (u < s.width && row[u] == l) ++u;
      const long long n = u - u0;
      s.size[l] += static_cast<std::int32_t>(n);
      s.sum_u[l] += static_cast<double>(n * (u0 + u - 1) / 2);  // integers: exact in double
      s.sum_v[l] += static_cast<double>(n * v);
    }
  }
  s.centre.resize(s.num_segments);
  for (int l = 0; l < s.num_segments; ++l) s.refresh_centre(l);
}

double block_score(const SuperpixelState& s, int segment, const BlockData& b) {
  // c1: histogram intersection Σ_q min(h_S(q), h_b(q)) of the normalised histograms.
  const std::int32_t* h = s.histogram.data() + static_cast<std::size_t>(segment) * kEnergyBins;
  const SegmentCentre& centre = s.centre[segment];
  const double inv_segment = centre.inv_size;
  const double inv_block = 1.0 / b.pixels;
  double c1 = 0.0;
  for (int k = 0; k < b.distinct_bins; ++k)
    c1 += std::min(h[b.bin_ids[k]] * inv_segment, b.bin_counts[k] * inv_block);
  // c2: λ_reg·‖μ_S − b‖²/s² + λ_depth·min((θ_S(b) − d̄_b)², τ²)/τ².
  const double du = centre.mean_u - b.centre_u;
  const double dv = centre.mean_v - b.centre_v;
  double c2 = s.weights.reg_per_px2 * (du * du + dv * dv);
  if (s.weights.depth_enabled && b.has_disparity) {
    const double tau = s.weights.depth_truncation_px;
    if (s.has_plane[segment]) {
      const double r = s.planes[segment].at(b.centre_u, b.centre_v) - b.mean_disparity;
      c2 += s.weights.depth * std::min(r * r, tau * tau) / (tau * tau);
    } else {
      c2 += 0.5 * s.weights.depth;  // no plane yet: a neutral, half-saturated residual
    }
  }
  return c1 - c2;
}

void move_block(SuperpixelState& s, int u0, int v0, int u1, int v1, int from, int to) {
  std::int32_t* h_from = s.histogram.data() + static_cast<std::size_t>(from) * kEnergyBins;
  std::int32_t* h_to = s.histogram.data() + static_cast<std::size_t>(to) * kEnergyBins;
  double su = 0.0, sv = 0.0;
  for (int v = v0; v < v1; ++v) {
    for (int u = u0; u < u1; ++u) {
      const int i = v * s.width + u;
      s.labels[i] = to;
      --h_from[s.bins[i]];
      ++h_to[s.bins[i]];
      su += u;
      sv += v;
    }
  }
  const int n = (u1 - u0) * (v1 - v0);
  s.size[from] -= n;
  s.size[to] += n;
  s.sum_u[from] -= su;
  s.sum_u[to] += su;
  s.sum_v[from] -= sv;
  s.sum_v[to] += sv;
  s.refresh_centre(from);
  s.refresh_centre(to);
}

}  // namespace planecell::extraction::detail
