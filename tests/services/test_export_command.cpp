/// `planecell export` end to end: a stored map of a floor and a wall cell as a PLY of
/// triangulated polygons and as JSON outlines; a negative tolerance is refused before anything
/// is written.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "io/map_store.hpp"
#include "support/expect_error.hpp"
#include "support/planecell_fixtures.hpp"
#include "support/test_data.hpp"

namespace planecell::services {
namespace {

namespace fs = std::filesystem;

class ExportCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    io::MapStore store(db_);
    map::GlobalMap map;
    const std::vector<Planecell> cells = {test::rect_cell(0, {0, 1.5f, 5}, {1, 0, 0}, {0, 0, 1}, 3),
                                          test::rect_cell(1, {-3, 0, 5}, {0, 1, 0}, {0, 0, 1}, 20)};
    const auto report = map.integrate(0, Pose::Identity(), cells);
    store.commit_frame(0, Pose::Identity(), report, map);
  }
  int run_export(const std::string& args, std::string* output) const {
    return test::run_command(test::planecell_binary() + " export " + db_.string() + " " + args,
                             output);
  }
  test::ScratchDir dir_;
  fs::path db_ = dir_ / "map.db";
};

TEST_F(ExportCommandTest, WritesTriangleFansOfTheCells) {
  const fs::path ply = dir_ / "map.ply";
  std::string out;
  ASSERT_EQ(run_export("-o " + ply.string() + " --color surface", &out), 0) << out;
  EXPECT_CONTAINS(out, "2 cells, 2 surfaces, 4 triangles");  // two per square
  std::ifstream in(ply, std::ios::binary);
  std::string magic;
  std::getline(in, magic);
  EXPECT_EQ(magic, "ply");
}

TEST_F(ExportCommandTest, WritesTheSurfacesOutlinesAsJson) {
  const fs::path json_path = dir_ / "outlines.json";
  std::string out;
  ASSERT_EQ(run_export("-o " + json_path.string() + " --outlines --tolerance 0.05", &out), 0)
      << out;
  EXPECT_CONTAINS(out, "2 surfaces as 2 rings of 8 vertices (tolerance 0.05 m)");
  std::ifstream in(json_path);
  const auto json = nlohmann::json::parse(in);
  EXPECT_EQ(json["format"], "planecell-outlines");
  EXPECT_DOUBLE_EQ(json["tolerance_m"].get<double>(), 0.05);
  EXPECT_EQ(json["surfaces"].size(), 2u);
}

TEST_F(ExportCommandTest, NegativeToleranceIsRefusedAndNothingIsWritten) {
  const fs::path json_path = dir_ / "outlines.json";
  std::string out;
  EXPECT_NE(run_export("-o " + json_path.string() + " --outlines --tolerance -0.1", &out), 0);
  EXPECT_CONTAINS(out, "--tolerance");
  EXPECT_FALSE(fs::exists(json_path));
}

}  // namespace
}  // namespace planecell::services
