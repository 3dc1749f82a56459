/// libFuzzer target: the EuRoC readers. The first byte picks what the rest of the input is:
///   0 a camera sensor.yaml (read_euroc_camera), 1 a ground-truth .csv, 2 a TUM ground-truth .txt
///   (read_euroc_groundtruth), 3 cam0's sensor.yaml inside a sequence whose cam1 is valid
///   (open_euroc: rectification of arbitrary calibrations), 4 cam0's data.csv image list.
#include <string>

#include "fuzz_support.hpp"
#include "io/euroc.hpp"

namespace {

/// A valid EuRoC sensor.yaml (identity T_BS, 64×48, EuRoC cam0 intrinsics).
const std::string kSensorYaml =
    "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n  data: [1, 0, 0, 0, 0, 1, 0, "
    "0, 0, 0, 1, 0, 0, 0, 0, 1]\nrate_hz: 20\nresolution: [64, 48]\ncamera_model: pinhole\n"
    "intrinsics: [458.654, 457.296, 31.5, 23.5]\ndistortion_model: radial-tangential\n"
    "distortion_coefficients: [-0.28, 0.07, 0.0002, 1.7e-05]\n";
/// cam1: the same camera 0.11 m to the right.
const std::string kSensorYamlRight =
    "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n  data: [1, 0, 0, 0.11, 0, 1, "
    "0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\nrate_hz: 20\nresolution: [64, 48]\ncamera_model: pinhole\n"
    "intrinsics: [458.654, 457.296, 31.5, 23.5]\ndistortion_model: radial-tangential\n"
    "distortion_coefficients: [-0.28, 0.07, 0.0002, 1.7e-05]\n";
const std::string kImageList = "#timestamp [ns],filename\n1403715273262142976,1403715273262142976.png\n";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace planecell;
  if (size == 0) return 0;
  const auto body = std::span(data + 1, size - 1);
  fuzz::expect_only_planecell_errors([&] {
    switch (data[0] % 5) {
      case 0:
        (void)io::read_euroc_camera(fuzz::write_file("sensor.yaml", body));
        break;
      case 1:
        (void)io::read_euroc_groundtruth(fuzz::write_file("gt/data.csv", body));
        break;
      case 2:
        (void)io::read_euroc_groundtruth(fuzz::write_file("gt/groundtruth.txt", body));
        break;
      default: {
        const bool fuzz_yaml = data[0] % 5 == 3;
        const auto cam0_yaml = fuzz_yaml ? fuzz::write_file("seq/mav0/cam0/sensor.yaml", body)
                                         : fuzz::write_file("seq/mav0/cam0/sensor.yaml", kSensorYaml);
        (void)cam0_yaml;
        fuzz::write_file("seq/mav0/cam1/sensor.yaml", kSensorYamlRight);
        if (fuzz_yaml) fuzz::write_file("seq/mav0/cam0/data.csv", kImageList);
        else fuzz::write_file("seq/mav0/cam0/data.csv", body);
        fuzz::write_file("seq/mav0/cam1/data.csv", kImageList);
        (void)io::open_euroc(fuzz::scratch_dir() / "seq");
        break;
      }
    }
  });
  return 0;
}
