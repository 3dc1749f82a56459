/// Map completeness: GT points back-projected by hand-computed geometry, scored against a map
/// holding one known planecell at hand-computed distances.
#include <gtest/gtest.h>

#include <limits>
#include <vector>

#include "core/error.hpp"
#include "services/eval/map_completeness.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::services::eval {
namespace {

TEST(MapCompleteness, GtPointsAreBackProjectedOnTheGridAndMovedByThePose) {
  const StereoCamera camera{.fx = 100.0, .fy = 100.0, .cx = 2.0, .cy = 2.0, .baseline_m = 0.5};
  cv::Mat disparity(4, 4, CV_32F, cv::Scalar(0.0f));
  // Stride 2 samples (u, v) = (1, 1), (3, 1), (1, 3), (3, 3); Z = f·B/d = 50/d.
  disparity.at<float>(1, 1) = 10.0f;  // Z = 5 m
  disparity.at<float>(1, 3) = 2.0f;   // Z = 25 m: beyond the 20 m range
  disparity.at<float>(3, 1) = 0.0f;   // no GT
  disparity.at<float>(3, 3) = 5.0f;   // Z = 10 m
  disparity.at<float>(0, 0) = 10.0f;  // off the grid
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(10.0, 0.0, 0.0);
  const auto points = gt_points_world(disparity, camera, T, 2, 20.0);
  ASSERT_EQ(points.size(), 2u);
  // (u − c_x)·Z/f_x: (1 − 2)·5/100 = −0.05; (3 − 2)·10/100 = 0.1; then + 10 m along x.
  EXPECT_TRUE(points[0].isApprox(Eigen::Vector3d(9.95, -0.05, 5.0), 1e-12));
  EXPECT_TRUE(points[1].isApprox(Eigen::Vector3d(10.1, 0.1, 10.0), 1e-12));
}

TEST(MapCompleteness, BadInputsAreClearErrors) {
  const StereoCamera camera;
  EXPECT_THROW(gt_points_world(cv::Mat(4, 4, CV_16U), camera, Pose::Identity(), 2, 20.0), InputError);
  EXPECT_THROW(gt_points_world(cv::Mat(4, 4, CV_32F), camera, Pose::Identity(), 0, 20.0), InputError);
  Pose nan = Pose::Identity();
  nan.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(gt_points_world(cv::Mat(4, 4, CV_32F), camera, nan, 2, 20.0), InputError);
}

TEST(MapCompleteness, SharesCountPointsByTheirDistanceToTheNearestStoredCell) {
  map::GlobalMap map;
  // One 1 m × 1 m cell on the plane z = 5, x, y ∈ [0, 1], seen from the origin.
  const std::vector<Planecell> cells = {
      test::rect_cell(0, {0, 0, 5}, Eigen::Vector3f::UnitX(), Eigen::Vector3f::UnitY(), 0)};
  map.integrate(0, Pose::Identity(), cells);
  ASSERT_EQ(map.cells().size(), 1u);
  const std::vector<Eigen::Vector3d> points = {
      {0.5, 0.5, 5.05},  // 5 cm in front of the polygon
      {0.5, 0.5, 4.85},  // 15 cm
      {1.3, 0.5, 5.0},   // in the plane, 30 cm beyond the polygon's edge x = 1
      {0.5, 0.5, 6.0},   // 1 m: held by nothing
  };
  const MapCompleteness c = map_completeness(map, points);
  EXPECT_EQ(c.points, 4u);
  EXPECT_DOUBLE_EQ(c.within[0], 0.25);
  EXPECT_DOUBLE_EQ(c.within[1], 0.50);
  EXPECT_DOUBLE_EQ(c.within[2], 0.75);
  const MapCompleteness none = map_completeness(map, {});
  EXPECT_EQ(none.points, 0u);
  EXPECT_EQ(none.within[2], 0.0);
}

}  // namespace
}  // namespace planecell::services::eval
