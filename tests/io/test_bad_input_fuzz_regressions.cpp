/// Inputs found by the libFuzzer targets (tests/fuzz, scripts/fuzz.sh) and the crash-recovery
/// work that escaped the readers as something other than the documented InputError/StorageError,
/// kept as plain regression tests with the crashing bytes inline (fuzz selector byte removed).
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "io/euroc.hpp"
#include "io/map_store.hpp"
#include "support/expect_error.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

using test::input_error_of;

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

/// fuzz_euroc crash-66e30fa8: `distortion_model` given as a list escaped read_euroc_camera as
/// YAML::TypedBadConversion<std::string> (an uncaught exception: the CLI exited with the wrong
/// code, the daemon would have died).
TEST(FuzzRegression, EurocSensorYamlWithAListAsDistortionModel) {
  test::ScratchDir dir;
  write_text(dir / "sensor.yaml",
             "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n"
             "  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,\n"
             "         0.9995)4498016, 0.0149672133247, 0.025715529948, -0.064676986768,\n"
             "    A    -0.0257744366974, 0.00375618835797, 0.999660727178, 0./0981073058949,\n"
             "         0.0, 0.0, 0.0, 1.0]\nrate_hz: 20\nresolution: [65, 48]\n"
             "camera_model: pinhole\nintrinsics: [458.654, 457.296, 31.5, 23.5] #fu, fv, cu, cv\n"
             "distortion_model: [458.654, 457.296, 31.5, 23.5] #fu,cients: [340811, 0.07395907, "
             "0.00019359, 1.76187114e-05]\n");
  const std::string message = input_error_of([&] { (void)read_euroc_camera(dir / "sensor.yaml"); });
  EXPECT_CONTAINS(message, "sensor.yaml");
  EXPECT_CONTAINS(message, "'distortion_model' must be a name");
  // The same for camera_model given as a mapping.
  write_text(dir / "model.yaml", "camera_model: {a: b}\n");
  EXPECT_CONTAINS(input_error_of([&] { (void)read_euroc_camera(dir / "model.yaml"); }),
                  "'camera_model' must be a name");
}

/// Found reviewing fuzz_euroc's surface: a resolution of 1e300 was cast to int (undefined
/// behaviour); now refused as a number outside [1, 65535].
TEST(FuzzRegression, EurocSensorYamlWithAHugeResolution) {
  test::ScratchDir dir;
  write_text(dir / "sensor.yaml",
             "T_BS:\n  data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n"
             "resolution: [1e300, 48]\ncamera_model: pinhole\n"
             "intrinsics: [458.654, 457.296, 31.5, 23.5]\ndistortion_model: radial-tangential\n"
             "distortion_coefficients: [-0.28, 0.07, 0.0002, 1.7e-05]\n");
  EXPECT_CONTAINS(input_error_of([&] { (void)read_euroc_camera(dir / "sensor.yaml"); }),
                  "resolution must be within [1, 65535]");
}

/// Found writing the crash-recovery test (tests/services/test_crash_recovery.cpp): a replay
/// killed between the creation of the store file and the commit of its schema left an empty file
/// that every later open refused as "not an SQLite database". A store is now created as
/// `<path>.creating` and renamed into place; a stale half-created one (and its WAL) is replaced.
TEST(FuzzRegression, StaleHalfCreatedStoreIsReplacedNotAdopted) {
  test::ScratchDir dir;
  const auto path = dir / "map.db";
  write_text(dir / "map.db.creating", "half a database");
  write_text(dir / "map.db.creating-wal", "stale log");
  {
    MapStore store(path);
    EXPECT_EQ(store.frame_count(), 0u);
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "map.db.creating"));
  EXPECT_FALSE(std::filesystem::exists(dir / "map.db.creating-wal"));
  const MapStore reopened(path);  // the created file is a valid, empty planecell map
  EXPECT_EQ(reopened.frame_count(), 0u);
}

}  // namespace
}  // namespace planecell::io
