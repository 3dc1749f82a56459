/// Census transform T(.) of Eq. 1.
#include <opencv2/core.hpp>

#include "mapping/stereo/parallel_rows.hpp"
#include "mapping/stereo/sgm_detail.hpp"

namespace planecell::stereo::detail {

/// T(p) = ⊗_{q ∈ window(p) \ p} [I(q) < I(p)], one bit per window pixel (row-major order).
/// Computed offset by offset over whole rows so that the inner loop vectorises.
CensusImage census_transform(const cv::Mat& gray, int window_w, int window_h, int threads) {
  CV_Assert(gray.type() == CV_8UC1);
  const int rx = window_w / 2, ry = window_h / 2;
  cv::Mat padded;
  cv::copyMakeBorder(gray, padded, ry, ry, rx, rx, cv::BORDER_REPLICATE);
  CensusImage census;
  census.width = gray.cols;
  census.height = gray.rows;
  census.bits.assign(static_cast<std::size_t>(gray.cols) * gray.rows, 0);
  const int width = gray.cols;
  parallel_rows(gray.rows, threads, [&](int y_begin, int y_end) {
    for (int y = y_begin; y < y_end; ++y) {
      std::uint64_t* out = census.bits.data() + static_cast<std::size_t>(y) * width;
      const std::uint8_t* centre = padded.ptr<std::uint8_t>(y + ry) + rx;
      for (int dy = -ry; dy <= ry; ++dy) {
        const std::uint8_t* row = padded.ptr<std::uint8_t>(y + ry + dy) + rx;
        for (int dx = -rx; dx <= rx; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const std::uint8_t* q = row + dx;
          for (int x = 0; x < width; ++x)
            out[x] = (out[x] << 1) | static_cast<std::uint64_t>(q[x] < centre[x]);
        }
      }
    }
  });
  return census;
}

}  // namespace planecell::stereo::detail
