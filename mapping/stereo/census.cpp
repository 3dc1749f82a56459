/// Census transform T(.) of Eq. 1.
#include <opencv2/core.hpp>

#include "mapping/stereo/parallel_rows.hpp"
#include "mapping/stereo/sgm_detail.hpp"

namespace planecell::stereo::detail {
namespace {

/// acc[x] = (acc[x] << 1) | [q[x] < centre[x]] (restrict: uint8 pointers may otherwise alias,
/// which keeps the compiler from vectorising).
void shift_in(std::uint8_t* __restrict acc, const std::uint8_t* __restrict q,
              const std::uint8_t* __restrict centre, int width) {
  for (int x = 0; x < width; ++x)
    acc[x] = static_cast<std::uint8_t>((acc[x] << 1) | (q[x] < centre[x] ? 1 : 0));
}

/// out[x] = Σ_j plane_j[x] · 2^(8j): the byte planes interleaved into descriptors.
void interleave(const std::uint8_t* __restrict planes, int width, std::uint64_t* __restrict out) {
  for (int x = 0; x < width; ++x) {
    std::uint64_t t = 0;
    for (int j = 0; j < 8; ++j)
      t |= static_cast<std::uint64_t>(planes[static_cast<std::size_t>(j) * width + x]) << (8 * j);
    out[x] = t;
  }
}

}  // namespace

/// T(p) = ⊗_{q ∈ window(p) \ p} [I(q) < I(p)], one bit per window pixel (row-major order, the
/// first window pixel is the most significant of the n = w·h − 1 bits). Computed one byte of
/// the descriptor at a time: offset k sets bit n − 1 − k, i.e. bit (n − 1 − k) mod 8 of byte
/// plane (n − 1 − k) / 8, so each offset is a shift-in on a whole row of uint8 (32 or 64
/// pixels per vector), and the ≤ 8 planes are interleaved into the uint64 descriptors at the end.
CensusImage census_transform(const cv::Mat& gray, int window_w, int window_h, int threads) {
  CV_Assert(gray.type() == CV_8UC1);
  const int rx = window_w / 2, ry = window_h / 2;
  const int bits = window_w * window_h - 1;
  cv::Mat padded;
  cv::copyMakeBorder(gray, padded, ry, ry, rx, rx, cv::BORDER_REPLICATE);
  CensusImage census;
  census.width = gray.cols;
  census.height = gray.rows;
  census.bits.resize(static_cast<std::size_t>(gray.cols) * gray.rows);
  const int width = gray.cols;
  parallel_rows(gray.rows, threads, [&](int y_begin, int y_end) {
    std::vector<std::uint8_t> plane_data(static_cast<std::size_t>(8) * width);
    for (int y = y_begin; y < y_end; ++y) {
      std::fill(plane_data.begin(), plane_data.end(), std::uint8_t{0});
      const std::uint8_t* centre = padded.ptr<std::uint8_t>(y + ry) + rx;
      int k = 0;
      for (int dy = -ry; dy <= ry; ++dy) {
        const std::uint8_t* row = padded.ptr<std::uint8_t>(y + ry + dy) + rx;
        for (int dx = -rx; dx <= rx; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const int plane = (bits - 1 - k) / 8;
          shift_in(plane_data.data() + static_cast<std::size_t>(plane) * width, row + dx, centre,
                   width);
          ++k;
        }
      }
      interleave(plane_data.data(), width,
                 census.bits.data() + static_cast<std::size_t>(y) * width);
    }
  });
  return census;
}

}  // namespace planecell::stereo::detail
