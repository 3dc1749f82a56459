/// libFuzzer target: the KITTI odometry text parsers. The first byte picks the parser (calib.txt
/// + stereo_camera_from_kitti, poses, times.txt); the rest is the file.
#include "fuzz_support.hpp"
#include "io/kitti_odometry.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace planecell;
  if (size == 0) return 0;
  const auto body = std::span(data + 1, size - 1);
  fuzz::expect_only_planecell_errors([&] {
    switch (data[0] % 3) {
      case 0: {
        const auto calib = io::read_kitti_calibration(fuzz::write_file("calib.txt", body));
        for (int left : {0, 2}) (void)io::stereo_camera_from_kitti(calib, left, 64, 32);
        break;
      }
      case 1:
        (void)io::read_kitti_poses(fuzz::write_file("poses.txt", body));
        break;
      default:
        (void)io::read_kitti_times(fuzz::write_file("times.txt", body));
        break;
    }
  });
  return 0;
}
