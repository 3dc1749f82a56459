/// libFuzzer target: bytes → temp .pfm → io::read_pfm (and the extension dispatch read_disparity).
#include <cmath>
#include <opencv2/core.hpp>

#include "fuzz_support.hpp"
#include "io/disparity_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace planecell;
  const auto path = fuzz::write_file("input.pfm", std::span(data, size));
  fuzz::expect_only_planecell_errors([&] {
    const cv::Mat d = io::read_disparity(path);
    // A decoded map is CV_32F with positive finite values or NaN (the reader's contract).
    if (d.type() != CV_32F || d.empty()) __builtin_trap();
    for (int r = 0; r < d.rows; ++r)
      for (int c = 0; c < d.cols; ++c) {
        const float v = d.at<float>(r, c);
        if (!(std::isnan(v) || (std::isfinite(v) && v > 0.0f))) __builtin_trap();
      }
  });
  return 0;
}
