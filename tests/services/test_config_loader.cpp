/// services/config_loader: YAML over defaults, with clear errors for unknown or mistyped keys.
#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <string_view>

#include "core/error.hpp"
#include "services/config_loader.hpp"
#include "support/test_data.hpp"

namespace planecell::services {
namespace {

/// Asserts that applying `yaml` throws ConfigError whose message contains every `needle`.
void expect_config_error(const std::string& yaml, std::initializer_list<std::string> needles) {
  AppConfig config;
  try {
    apply_config_yaml(yaml, "test.yaml", config);
    ADD_FAILURE() << "accepted:\n" << yaml;
  } catch (const ConfigError& e) {
    for (const auto& needle : needles)
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
          << "message '" << e.what() << "' lacks '" << needle << "'";
  }
}

TEST(ConfigLoader, PartialOverrideKeepsEveryOtherDefault) {
  AppConfig loaded;
  apply_config_yaml("sgm:\n  max_disparity: 64\nsynth:\n  frames: 7\n  loop: true\n", "test.yaml",
                    loaded);
  AppConfig expected;
  ASSERT_NE(expected.sgm.max_disparity, 64);
  ASSERT_NE(expected.synth.frames, 7);
  expected.sgm.max_disparity = 64;
  expected.synth.frames = 7;
  expected.synth.loop = true;
  EXPECT_EQ(loaded.sgm.max_disparity, 64);
  EXPECT_EQ(loaded.synth.frames, 7);
  EXPECT_TRUE(loaded.synth.loop);
  // Every other key of every section still holds its built-in default.
  EXPECT_EQ(config_to_yaml(loaded), config_to_yaml(expected));
}

TEST(ConfigLoader, EmptyTextKeepsDefaults) {
  AppConfig loaded;
  apply_config_yaml("", "empty.yaml", loaded);
  EXPECT_EQ(config_to_yaml(loaded), config_to_yaml(AppConfig{}));
}

TEST(ConfigLoader, UnknownKeyIsNamed) {
  expect_config_error("sgm:\n  max_disparty: 64\n", {"max_disparty", "sgm", "test.yaml"});
}

TEST(ConfigLoader, UnknownSectionIsNamed) {
  expect_config_error("sgmm:\n  max_disparity: 64\n", {"sgmm", "test.yaml"});
}

TEST(ConfigLoader, WrongTypeIsNamed) {
  expect_config_error("sgm:\n  max_disparity: lots\n", {"max_disparity", "wrong type"});
  expect_config_error("voxel:\n  ray_casting: perhaps\n", {"ray_casting"});
  expect_config_error("synth:\n  frames: [1, 2]\n", {"frames"});
}

TEST(ConfigLoader, MalformedStructureIsRejected) {
  expect_config_error("sgm: 5\n", {"sgm"});
  expect_config_error("- a\n- b\n", {"test.yaml"});
  expect_config_error("sgm: {max_disparity: 64\n", {"test.yaml", "YAML"});
}

TEST(ConfigLoader, YamlRoundTripReproducesTheConfig) {
  AppConfig modified;
  modified.sgm.max_disparity = 96;
  modified.voxel.resolution_m = 0.25;
  modified.synth.seed = 12345;
  AppConfig loaded;
  apply_config_yaml(config_to_yaml(modified), "round-trip", loaded);
  EXPECT_EQ(loaded.sgm.max_disparity, 96);
  EXPECT_DOUBLE_EQ(loaded.voxel.resolution_m, 0.25);
  EXPECT_EQ(loaded.synth.seed, 12345u);
  EXPECT_EQ(config_to_yaml(loaded), config_to_yaml(modified));
}

TEST(ConfigLoader, YamlOfChosenSectionsHoldsThoseAlone) {
  AppConfig modified;
  modified.sgm.max_disparity = 96;
  modified.extraction.target_cells += 40;
  modified.map.neighbour_gap_m = 0.45;
  const std::array<std::string_view, 2> sections{"sgm", "extraction"};
  const std::string yaml = config_to_yaml(modified, sections);
  EXPECT_EQ(yaml.find("map:"), std::string::npos);
  EXPECT_EQ(yaml.find("voxel:"), std::string::npos);
  AppConfig loaded;
  apply_config_yaml(yaml, "two sections", loaded);
  EXPECT_EQ(loaded.sgm.max_disparity, 96);
  EXPECT_EQ(loaded.extraction.target_cells, modified.extraction.target_cells);
  EXPECT_EQ(loaded.map.neighbour_gap_m, AppConfig{}.map.neighbour_gap_m);  // not in the text
}

TEST(ConfigLoader, LoadsAFileAndNamesAMissingOne) {
  test::ScratchDir dir;
  const auto path = dir / "my.yaml";
  std::ofstream(path) << "voxel:\n  resolution_m: 0.2\n";
  const AppConfig loaded = load_config(path);
  EXPECT_DOUBLE_EQ(loaded.voxel.resolution_m, 0.2);
  try {
    load_config(dir / "absent.yaml");
    FAIL() << "missing file accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("absent.yaml"), std::string::npos) << e.what();
  }
}

/// The presets shipped in config/ load without an unknown or mistyped key, and they say what
/// their comments promise: the photometric planes are on for rendered frames only.
TEST(ConfigLoader, ShippedPresetsLoad) {
  const std::filesystem::path dir = std::filesystem::path(PLANECELL_SOURCE_DIR) / "config";
  for (const char* name : {"euroc.yaml", "kitti.yaml", "middlebury.yaml", "synthetic.yaml", "synthetic_refine.yaml"})
    EXPECT_NO_THROW(load_config(dir / name)) << name;
  EXPECT_EQ(load_config(dir / "synthetic.yaml").extraction.photometric_iterations, 5);
  EXPECT_EQ(load_config(dir / "kitti.yaml").extraction.photometric_iterations, 0);
  EXPECT_FALSE(load_config(dir / "synthetic.yaml").refine.enabled);
  const AppConfig refine = load_config(dir / "synthetic_refine.yaml");
  EXPECT_TRUE(refine.refine.enabled);
  EXPECT_EQ(refine.extraction.photometric_iterations, 5);
  EXPECT_EQ(refine.map.bridge_gap_m, 5.0);
  EXPECT_EQ(refine.map.bridge_min_area_m2, 0.0);  // bridges small surfaces too, as measured
  EXPECT_EQ(refine.map.bridge_max_cell_distance_m, 0.0);  // and without the cells' plane test
  EXPECT_EQ(load_config(dir / "synthetic.yaml").map.bridge_max_cell_distance_m, 0.12);
  EXPECT_EQ(refine.map.min_inlier_ratio, 0.0);  // keeps the weak fits the default map drops
  EXPECT_EQ(load_config(dir / "synthetic.yaml").map.min_inlier_ratio, MapConfig{}.min_inlier_ratio);
  // The default bridge: large surfaces only.
  EXPECT_EQ(load_config(dir / "synthetic.yaml").map.bridge_gap_m, MapConfig{}.bridge_gap_m);
  EXPECT_EQ(load_config(dir / "synthetic.yaml").map.bridge_min_area_m2, 20.0);
}

}  // namespace
}  // namespace planecell::services
