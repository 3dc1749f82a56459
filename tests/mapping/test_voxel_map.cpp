/// Voxel baseline: back-projection of a synthetic disparity plane, and occupied voxel counts and
/// colours of points at known positions.
#include <gtest/gtest.h>

#include <octomap/ColorOcTree.h>

#include <algorithm>
#include <cmath>
#include <tuple>
#include <sstream>

#include "core/error.hpp"
#include "mapping/voxel/voxel_map.hpp"

namespace planecell::voxel {
namespace {

/// Points on a grid filling the square x, y ∈ [0, 1) m at z = 5.05 m (the centre of a 10 cm voxel
/// layer), 2 cm apart, red for x < 0.5 and blue beyond.
ColouredPoints coloured_square() {
  ColouredPoints pts;
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 50; ++j) {
      const float x = 0.01f + 0.02f * i, y = 0.01f + 0.02f * j;
      pts.points_m.emplace_back(x, y, 5.05f);
      pts.rgb.push_back(x < 0.5f ? Rgb{200, 10, 10} : Rgb{10, 10, 200});
    }
  return pts;
}

class VoxelModes : public ::testing::TestWithParam<bool> {};

TEST_P(VoxelModes, PlanePointsOccupyTheExpectedVoxelsWithTheirColour) {
  VoxelConfig config;
  config.ray_casting = GetParam();
  VoxelMap map(config);
  const auto stats = map.insert(coloured_square());
  EXPECT_EQ(stats.points, 2500u);
  // 1 m × 1 m at 10 cm in a single layer: 10 × 10 voxels.
  EXPECT_EQ(stats.voxels, 100u);
  EXPECT_EQ(map.occupied_voxels(), 100u);
  const auto red = map.colour_at({0.25, 0.55, 5.05});
  ASSERT_TRUE(red.has_value());
  EXPECT_EQ(*red, (Rgb{200, 10, 10}));
  const auto blue = map.colour_at({0.95, 0.05, 5.05});
  ASSERT_TRUE(blue.has_value());
  EXPECT_EQ(*blue, (Rgb{10, 10, 200}));
  EXPECT_FALSE(map.colour_at({0.5, 0.5, 4.95}).has_value());  // layer below: empty
  const auto sizes = map.stats();
  EXPECT_EQ(sizes.occupied_voxels, 100u);
  EXPECT_EQ(sizes.memory_bytes, map.tree().memoryUsage());
  EXPECT_GT(sizes.ot_bytes, sizes.bt_bytes);  // .ot carries colour, .bt two bits per node
  EXPECT_GT(sizes.bt_bytes, 0u);
  // The occupied voxels' centres: ((i + ½)·10 cm, (j + ½)·10 cm, 5.05 m), i, j = 0..9.
  auto centres = map.occupied_centres();
  ASSERT_EQ(centres.size(), 100u);
  std::sort(centres.begin(), centres.end(), [](const auto& a, const auto& b) {
    return std::tie(a.x(), a.y()) < std::tie(b.x(), b.y());
  });
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      EXPECT_TRUE(centres[10 * i + j].isApprox(Eigen::Vector3d(0.05 + 0.1 * i, 0.05 + 0.1 * j, 5.05), 1e-6))
          << i << ", " << j << ": " << centres[10 * i + j].transpose();
}

/// .bt size of the tree as OctoMap itself writes it (prints a debug line on stderr).
std::size_t written_bt_bytes(const octomap::ColorOcTree& tree) {
  std::ostringstream bt;
  tree.writeBinaryConst(bt);
  return bt.str().size();
}

TEST_P(VoxelModes, StatsCountsTheBtSizeExactlyWithoutPrinting) {
  VoxelConfig config;
  config.ray_casting = GetParam();
  VoxelMap map(config);
  // 300 points on a helix of radius 1.5 m about the z axis, z from 2 m to 5 m: scattered voxels in
  // four octants, with free space carved along the rays in ray-casting mode.
  ColouredPoints pts;
  for (int i = 0; i < 300; ++i) {
    const float t = 0.07f * i;
    pts.points_m.emplace_back(1.5f * std::cos(t), 1.5f * std::sin(t), 2.0f + 0.01f * i);
    pts.rgb.push_back(Rgb{static_cast<std::uint8_t>(i % 256), 80, 160});
  }
  map.insert(pts);
  ::testing::internal::CaptureStderr();
  const auto sizes = map.stats();
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
  EXPECT_GT(sizes.occupied_voxels, 100u);
  EXPECT_EQ(sizes.bt_bytes, written_bt_bytes(map.tree()));
}

TEST(VoxelMapTest, EmptyMapBtSizeIsTheHeaderAlone) {
  VoxelMap map;
  EXPECT_EQ(map.stats().bt_bytes, written_bt_bytes(map.tree()));
}

INSTANTIATE_TEST_SUITE_P(Insertion, VoxelModes, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "RayCasting" : "PointsOnly"; });

TEST(VoxelMapTest, VoxelColourIsTheMeanOfItsPoints) {
  VoxelMap map;
  ColouredPoints pts;
  pts.points_m = {{0.02f, 0.02f, 0.02f}, {0.08f, 0.08f, 0.08f}};
  pts.rgb = {Rgb{100, 0, 50}, Rgb{200, 20, 51}};
  map.insert(pts);
  EXPECT_EQ(map.occupied_voxels(), 1u);
  EXPECT_EQ(*map.colour_at({0.05, 0.05, 0.05}), (Rgb{150, 10, 51}));  // 50.5 rounds to 51
}

TEST(VoxelMapTest, APrunedLeafListsTheCentresOfAllItsVoxels) {
  VoxelMap map;
  ColouredPoints pts;  // one point of one colour in each voxel of the 20 cm cube at the origin
  for (int i = 0; i < 8; ++i) {
    pts.points_m.emplace_back(0.05f + 0.1f * (i & 1), 0.05f + 0.1f * ((i >> 1) & 1), 0.05f + 0.1f * (i >> 2));
    pts.rgb.push_back(Rgb{90, 90, 90});
  }
  map.insert(pts);
  const_cast<octomap::ColorOcTree&>(map.tree()).prune();  // eight equal children: one 20 cm leaf
  std::size_t leaves = 0;
  for (auto it = map.tree().begin_leafs(); it != map.tree().end_leafs(); ++it) ++leaves;
  ASSERT_EQ(leaves, 1u);
  auto centres = map.occupied_centres();
  ASSERT_EQ(centres.size(), 8u);
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d want(pts.points_m[i].cast<double>());
    EXPECT_EQ(std::count_if(centres.begin(), centres.end(), [&](const auto& c) { return c.isApprox(want, 1e-6); }), 1)
        << want.transpose();
  }
}

TEST(VoxelMapTest, RejectsMismatchedInputAndBadConfig) {
  VoxelMap map;
  ColouredPoints pts;
  pts.points_m = {{0, 0, 1}};
  EXPECT_THROW(map.insert(pts), InputError);
  VoxelConfig bad;
  bad.resolution_m = 0.0;
  EXPECT_THROW(VoxelMap{bad}, ConfigError);
}

TEST(BackProject, FrontoParallelPlaneLandsAtItsDepthAndRespectsRange) {
  StereoCamera cam;
  cam.fx = cam.fy = 100.0;
  cam.cx = 20.0, cam.cy = 10.0;
  cam.baseline_m = 0.5;
  cam.width = 40, cam.height = 20;
  // Left half: d = 5 px → Z = 100·0.5/5 = 10 m; right half: d = 1 px → Z = 50 m (beyond 40 m).
  cv::Mat disparity(20, 40, CV_32F, cv::Scalar(5.0f));
  disparity.colRange(20, 40).setTo(1.0f);
  disparity.at<float>(0, 0) = std::numeric_limits<float>::quiet_NaN();
  cv::Mat image(20, 40, CV_8UC3, cv::Scalar(30, 60, 90));  // BGR
  Pose pose = Pose::Identity();
  pose.translation() = Eigen::Vector3d(1, 2, 3);
  const auto pts = back_project(disparity, image, cam, pose, 40.0);
  ASSERT_EQ(pts.points_m.size(), 20u * 20u - 1u);
  EXPECT_TRUE(pts.origin_m.isApprox(Eigen::Vector3f(1, 2, 3)));
  for (const auto& p : pts.points_m) EXPECT_NEAR(p.z(), 13.0f, 1e-4f);
  // Pixel (u, v) = (1, 0): X = (1 − 20)·10/100 = −1.9, Y = (0 − 10)·10/100 = −1 → + (1, 2, 3).
  EXPECT_TRUE(pts.points_m[0].isApprox(Eigen::Vector3f(-0.9f, 1.0f, 13.0f)));
  EXPECT_EQ(pts.rgb[0], (Rgb{90, 60, 30}));
  EXPECT_EQ(back_project(disparity, image, cam, pose, 40.0, 2).points_m.size(), 10u * 10u - 1u);
  EXPECT_THROW(back_project(disparity, cv::Mat(10, 10, CV_8UC3), cam, pose, 40.0), InputError);
  EXPECT_THROW(back_project(cv::Mat(20, 40, CV_8U), image, cam, pose, 40.0), InputError);
}

}  // namespace
}  // namespace planecell::voxel
