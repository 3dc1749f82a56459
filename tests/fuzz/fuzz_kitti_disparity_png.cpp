/// libFuzzer target: bytes → temp .png → io::read_kitti_disparity (16-bit KITTI disparity PNG).
#include <opencv2/core.hpp>

#include "fuzz_support.hpp"
#include "io/disparity_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace planecell;
  const auto path = fuzz::write_file("input.png", std::span(data, size));
  fuzz::expect_only_planecell_errors([&] {
    const cv::Mat d = io::read_kitti_disparity(path);
    if (d.type() != CV_32F || d.empty()) __builtin_trap();
  });
  return 0;
}
