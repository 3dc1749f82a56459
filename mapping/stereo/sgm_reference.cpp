/// Scalar reference SGM: the textbook formulation with one full int32 L_r volume per path.
/// Shares only the scalar cost formulas (sgm_detail.hpp) with the fast path; used by the tests
/// to check the SIMD / row-buffer / two-thread implementation value for value.
#include <limits>
#include <opencv2/imgproc.hpp>

#include "mapping/stereo/sgm.hpp"
#include "mapping/stereo/sgm_detail.hpp"

namespace planecell::stereo {

cv::Mat compute_disparity_reference(const cv::Mat& left, const cv::Mat& right,
                                    const SgmConfig& c) {
  validate_sgm_input(left, right, c);
  cv::Mat gl = left, gr = right;
  if (left.channels() == 3) cv::cvtColor(left, gl, cv::COLOR_BGR2GRAY);
  if (right.channels() == 3) cv::cvtColor(right, gr, cv::COLOR_BGR2GRAY);
  const int W = gl.cols, H = gl.rows, D = c.max_disparity;
  // Like the fast path, disparities are searched up to D rounded up to 16; d ≥ D carry the
  // out-of-image cost and are never selected.
  const int DP = detail::padded_disparities(D);
  auto idx = [&](int x, int y, int d) { return (static_cast<std::size_t>(y) * W + x) * DP + d; };

  // Census: bit per window pixel, 1 when darker than the centre, clamped border.
  auto census = [&](const cv::Mat& g, int x, int y) {
    std::uint64_t bits = 0;
    const int rx = c.census_width / 2, ry = c.census_height / 2;
    for (int dy = -ry; dy <= ry; ++dy)
      for (int dx = -rx; dx <= rx; ++dx) {
        if (dx == 0 && dy == 0) continue;
        const int qx = std::clamp(x + dx, 0, W - 1), qy = std::clamp(y + dy, 0, H - 1);
        bits = (bits << 1) | (g.at<std::uint8_t>(qy, qx) < g.at<std::uint8_t>(y, x) ? 1u : 0u);
      }
    return bits;
  };
  const cv::Mat grad_l = detail::epipolar_gradient(gl), grad_r = detail::epipolar_gradient(gr);
  const int lq4 = detail::lambda_q4(c.lambda_grad);
  std::vector<int> C(static_cast<std::size_t>(W) * H * DP);
  std::vector<std::uint64_t> cen_l(static_cast<std::size_t>(W) * H), cen_r(cen_l.size());
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      cen_l[static_cast<std::size_t>(y) * W + x] = census(gl, x, y);
      cen_r[static_cast<std::size_t>(y) * W + x] = census(gr, x, y);
    }
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      for (int d = 0; d < DP; ++d)
        C[idx(x, y, d)] =
            d >= D       ? detail::largest_cost(c)
            : x - d < 0  ? detail::out_of_image_cost(c)
                : detail::matching_cost(cen_l[static_cast<std::size_t>(y) * W + x],
                                        cen_r[static_cast<std::size_t>(y) * W + x - d],
                                        grad_l.at<std::int16_t>(y, x),
                                        grad_r.at<std::int16_t>(y, x - d), c.grad_cap, lq4);

  // Eq. 2 along each path r; p − r is visited before p.
  const auto p2 = detail::p2_table(c);
  std::vector<std::pair<int, int>> dirs = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  if (c.paths == 8) dirs.insert(dirs.end(), {{1, 1}, {-1, -1}, {-1, 1}, {1, -1}});
  std::vector<int> S(C.size(), 0), L(C.size());
  for (const auto& [rx, ry] : dirs) {
    for (int i = 0; i < H; ++i) {
      const int y = ry >= 0 ? i : H - 1 - i;
      for (int j = 0; j < W; ++j) {
        const int x = rx >= 0 ? j : W - 1 - j;
        const int px = x - rx, py = y - ry;
        const bool has_pred = px >= 0 && px < W && py >= 0 && py < H;
        if (!has_pred) {
          for (int d = 0; d < DP; ++d) L[idx(x, y, d)] = C[idx(x, y, d)];
        } else {
          const int step = std::abs(gl.at<std::uint8_t>(y, x) - gl.at<std::uint8_t>(py, px));
          const int pen2 = p2[static_cast<std::size_t>(step)];
          int m = std::numeric_limits<int>::max();
          for (int d = 0; d < DP; ++d) m = std::min(m, L[idx(px, py, d)]);
          for (int d = 0; d < DP; ++d) {
            int best = L[idx(px, py, d)];
            if (d > 0) best = std::min(best, L[idx(px, py, d - 1)] + c.p1);
            if (d + 1 < DP) best = std::min(best, L[idx(px, py, d + 1)] + c.p1);
            best = std::min(best, m + pen2);
            L[idx(x, y, d)] = C[idx(x, y, d)] + best - m;
          }
        }
      }
    }
    for (std::size_t k = 0; k < S.size(); ++k) S[k] += L[k];
  }

  // Winner-take-all, uniqueness, sub-pixel and the right winners (from the same S); then the
  // image-wide filters (median, left-right check) shared with the fast path.
  detail::Winners winners(W, H);
  for (int y = 0; y < H; ++y) {
    for (int xr = 0; xr < W; ++xr) {
      int best = std::numeric_limits<int>::max(), d_right = 0;
      for (int d = 0; d < D && xr + d < W; ++d)
        if (S[idx(xr + d, y, d)] < best) best = S[idx(xr + d, y, d)], d_right = d;
      winners.right.at<std::uint16_t>(y, xr) = static_cast<std::uint16_t>(d_right);
    }
    for (int x = 0; x < W; ++x) {
      int best = std::numeric_limits<int>::max(), d_best = 0;
      for (int d = 0; d < D; ++d)
        if (S[idx(x, y, d)] < best) best = S[idx(x, y, d)], d_best = d;
      int second = 0xFFFF;
      for (int d = 0; d < D; ++d)
        if (std::abs(d - d_best) > 1) second = std::min(second, S[idx(x, y, d)]);
      winners.left.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(d_best);
      winners.disparity.at<float>(y, x) =
          !detail::is_unique(best, second, c.uniqueness_ratio)
              ? std::numeric_limits<float>::quiet_NaN()
          : (c.subpixel && d_best > 0 && d_best < D - 1)
              ? detail::subpixel_parabola(d_best, S[idx(x, y, d_best - 1)], best,
                                          S[idx(x, y, d_best + 1)])
              : static_cast<float>(d_best);
    }
  }
  cv::Mat disparity = detail::filter_winners(winners, c);
  detail::remove_speckles(disparity, c);
  return disparity;
}

}  // namespace planecell::stereo
