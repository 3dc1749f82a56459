/// `planecell info` end to end: summaries of a KITTI-layout folder and a disparity map.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <opencv2/core.hpp>

#include "support/expect_error.hpp"
#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "io/map_store.hpp"
#include "support/planecell_fixtures.hpp"
#include "support/test_data.hpp"

namespace planecell::services {
namespace {

namespace fs = std::filesystem;


int run_info(const std::string& args, std::string* output) {
  return test::run_command(test::planecell_binary() + " info " + args, output);
}

TEST(InfoCommand, SummarisesAKittiLayoutFolder) {
  test::ScratchDir dir;
  const fs::path seq = dir / "seq";
  for (const char* name : {"000000.png", "000001.png"}) {
    io::write_image(seq / "image_2" / name, cv::Mat(6, 8, CV_8UC3, cv::Scalar(1, 2, 3)));
    io::write_image(seq / "image_3" / name, cv::Mat(6, 8, CV_8UC3, cv::Scalar(1, 2, 3)));
    io::write_kitti_disparity(seq / "disp_occ_0" / name, cv::Mat(6, 8, CV_32F, cv::Scalar(4.0f)));
  }
  std::ofstream(seq / "calib.txt")
      << "P0: 700 0 4 0 0 700 3 0 0 0 1 0\nP1: 700 0 4 -350 0 700 3 0 0 0 1 0\n"
      << "P2: 700 0 4 0 0 700 3 0 0 0 1 0\nP3: 700 0 4 -350 0 700 3 0 0 0 1 0\n";
  std::ofstream(seq / "times.txt") << "0.5\n2.0\n";
  fs::create_directories(seq / "poses");
  // Second pose 5 m away from the first (3-4-5 triangle).
  std::ofstream(seq / "poses" / "seq.txt") << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 3 0 1 0 4 0 0 1 0\n";
  std::string out;
  ASSERT_EQ(run_info(seq.string(), &out), 0) << out;
  EXPECT_CONTAINS(out, "image_2/ + image_3/ (colour)");
  EXPECT_CONTAINS(out, "2 left, 2 right");
  EXPECT_CONTAINS(out, "8 x 6 px");
  EXPECT_CONTAINS(out, "fx 700.000");
  EXPECT_CONTAINS(out, "baseline 0.5000 m");
  EXPECT_CONTAINS(out, "span 1.500 s");
  EXPECT_CONTAINS(out, "path length 5.0 m");
  EXPECT_CONTAINS(out, "disp_occ_0/ (2 files)");
  EXPECT_CONTAINS(out, "surface_0/ missing");
}

TEST(InfoCommand, SummarisesAMapStoreWithItsRefinedFrames) {
  test::ScratchDir dir;
  const fs::path db = dir / "map.db";
  {
    io::MapStore store(db);
    map::GlobalMap map;
    const auto cell = test::rect_cell(0, {0, 1.5f, 5}, {1, 0, 0}, {0, 0, 1}, 3);
    const auto first = map.integrate(0, Pose::Identity(), std::vector<Planecell>{cell});
    store.commit_frame(0, Pose::Identity(), first, map);  // used as given
    Pose refined = Pose::Identity();
    refined.translation() = Eigen::Vector3d(0, 0, 1);
    Pose odometry = refined;
    odometry.translation() += Eigen::Vector3d(0.03, 0, 0.04);  // 5 cm off
    const auto second = map.integrate(1, refined, std::vector<Planecell>{cell});
    store.commit_frame(1, refined, second, map, odometry);
  }
  std::string out;
  ASSERT_EQ(run_info(db.string(), &out), 0) << out;
  EXPECT_CONTAINS(out, "2 committed");
  EXPECT_CONTAINS(out, "surfaces:     1 (0 dormant), ");  // seen in the last frame: awake
  EXPECT_CONTAINS(out, "1 of 2 frames refined");
  EXPECT_CONTAINS(out, "mean 0.050 m, max 0.050 m / 0.000 deg");
  // The 1 m cell spans x 0…1, y 1.5, z 5…6; the camera moved from the origin to z = 1.
  EXPECT_CONTAINS(out, "extent:       x 0.0 … 1.0, y 1.5 … 1.5, z 5.0 … 6.0 m (world frame)");
  EXPECT_CONTAINS(out, "trajectory:   frames 0 … 1, 1.00 m driven");
  // One 1 m cell of 4 float vertices (48 B), its surface's one footprint tile (136 B).
  EXPECT_CONTAINS(out, "vertices 0.0, surfaces");
  EXPECT_CONTAINS(out, "footprints 0.1, index");
  // Two frames fit every table in its root page (2 KiB, the page size of a new store); the
  // R*Tree is three tables.
  EXPECT_CONTAINS(out, "(cells 2.0, cell-bounds R*Tree 6.0, surfaces 2.0, frames 2.0, merges 2.0");
}

TEST(InfoCommand, SummarisesADisparityMap) {
  test::ScratchDir dir;
  cv::Mat d(2, 2, CV_32F);
  d.at<float>(0, 0) = 2.0f;
  d.at<float>(0, 1) = 4.0f;
  d.at<float>(1, 0) = 6.0f;
  d.at<float>(1, 1) = std::numeric_limits<float>::quiet_NaN();
  io::write_kitti_disparity(dir / "d.png", d);
  io::write_pfm(dir / "d.pfm", d);
  for (const char* name : {"d.png", "d.pfm"}) {
    std::string out;
    ASSERT_EQ(run_info((dir / name).string(), &out), 0) << out;
    EXPECT_CONTAINS(out, "2 x 2 px");
    EXPECT_CONTAINS(out, "75.00 %");
    EXPECT_CONTAINS(out, "min 2.00  max 6.00  mean 4.00");
  }
}

TEST(InfoCommand, UnknownAndMissingPathsFailWithANamedError) {
  test::ScratchDir dir;
  std::ofstream(dir / "notes.md") << "hello";
  std::string out;
  EXPECT_EQ(run_info((dir / "notes.md").string(), &out), 1);
  EXPECT_CONTAINS(out, "notes.md");
  EXPECT_EQ(run_info((dir / "absent").string(), &out), 1);
  EXPECT_CONTAINS(out, "does not exist");
  EXPECT_EQ(run_info("--help", &out), 0);
  EXPECT_CONTAINS(out, "Examples");
}

}  // namespace
}  // namespace planecell::services
