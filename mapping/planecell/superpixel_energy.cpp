/// Superpixel energy E(S) = H(S) + λ_reg·R(S) + λ_depth·D(S) (paper Eq. 4) and its block costs
/// c1, c2 (paper §4.5), plus the state they read: colour bins, disparity integrals, segment stats.
#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "mapping/planecell/superpixel_state.hpp"

namespace planecell::extraction::detail {
namespace {

/// Lab (8-bit OpenCV scaling) → one of 5×5×5 bins. L is split uniformly; a and b, which rarely
/// leave [68, 188] in natural images, into 24-wide bins centred on the neutral value 128.
inline std::uint8_t lab_bin(std::uint8_t l, std::uint8_t a, std::uint8_t b) {
  const int lb = l * kEnergyBinsPerChannel / 256;
  const int ab = std::clamp((static_cast<int>(a) - 68) / 24, 0, kEnergyBinsPerChannel - 1);
  const int bb = std::clamp((static_cast<int>(b) - 68) / 24, 0, kEnergyBinsPerChannel - 1);
  return static_cast<std::uint8_t>((lb * kEnergyBinsPerChannel + ab) * kEnergyBinsPerChannel + bb);
}

}  // namespace

double SuperpixelState::mean_disparity(int u0, int v0, int u1, int v1, int* valid) const {
  const int stride = width + 1;
  auto at_count = [&](int u, int v) { return valid_count[v * stride + u]; };
  auto at_sum = [&](int u, int v) { return disparity_sum[v * stride + u]; };
  const int n = at_count(u1, v1) - at_count(u0, v1) - at_count(u1, v0) + at_count(u0, v0);
  *valid = n;
  if (n == 0) return 0.0;
  return (at_sum(u1, v1) - at_sum(u0, v1) - at_sum(u1, v0) + at_sum(u0, v0)) / n;
}

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
    for (int u = 0; u < s.width; ++u) out[u] = lab_bin(row[u][0], row[u][1], row[u][2]);
  }

  // Disparity and its integral images (for the block means d̄_b in O(1)).
  s.disparity.resize(n_pixels);
  const int stride = s.width + 1;
  s.disparity_sum.assign(static_cast<std::size_t>(stride) * (s.height + 1), 0.0);
  s.valid_count.assign(static_cast<std::size_t>(stride) * (s.height + 1), 0);
  for (int v = 0; v < s.height; ++v) {
    const float* row = disparity.ptr<float>(v);
    double row_sum = 0.0;
    int row_count = 0;
    for (int u = 0; u < s.width; ++u) {
      const float d = row[u];
      const bool ok = std::isfinite(d) && d > 0.0f;
      s.disparity[v * s.width + u] = ok ? d : std::numeric_limits<float>::quiet_NaN();
      if (ok) {
        row_sum += d;
        ++row_count;
      }
      s.disparity_sum[(v + 1) * stride + u + 1] = s.disparity_sum[v * stride + u + 1] + row_sum;
      s.valid_count[(v + 1) * stride + u + 1] = s.valid_count[v * stride + u + 1] + row_count;
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
    for (int u = 0; u < s.width; ++u) s.labels[v * s.width + u] = row_label + column[u];
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
    for (int u = 0; u < s.width; ++u) {
      const int i = v * s.width + u;
      const int l = s.labels[i];
      ++s.histogram[l * kEnergyBins + s.bins[i]];
      ++s.size[l];
      s.sum_u[l] += u;
      s.sum_v[l] += v;
    }
  }
}

double block_score(const SuperpixelState& s, int segment, const BlockData& b) {
  // c1: histogram intersection Σ_q min(h_S(q), h_b(q)) of the normalised histograms.
  const std::int32_t* h = s.histogram.data() + static_cast<std::size_t>(segment) * kEnergyBins;
  const double inv_segment = 1.0 / std::max(1, s.size[segment]);
  const double inv_block = 1.0 / b.pixels;
  double c1 = 0.0;
  for (int k = 0; k < b.distinct_bins; ++k)
    c1 += std::min(h[b.bin_ids[k]] * inv_segment, b.bin_counts[k] * inv_block);
  // c2: λ_reg·‖μ_S − b‖²/s² + λ_depth·min((θ_S(b) − d̄_b)², τ²)/τ².
  const double du = s.sum_u[segment] * inv_segment - b.centre_u;
  const double dv = s.sum_v[segment] * inv_segment - b.centre_v;
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
}

}  // namespace planecell::extraction::detail
