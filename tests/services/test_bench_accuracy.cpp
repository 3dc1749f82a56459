/// The reconstruction-accuracy curve (paper Fig. "Reconstruction accuracy", Table 1) and the voxel
/// baseline's version of it, against distances computed independently from back-projected points.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "core/stereo_camera.hpp"
#include "mapping/voxel/voxel_map.hpp"
#include "services/bench/voxel_accuracy.hpp"
#include "services/eval/stereo_metrics.hpp"

namespace planecell::services {
namespace {

constexpr float kNoDisparity = std::numeric_limits<float>::quiet_NaN();

StereoCamera small_camera() {
  StereoCamera c;
  c.fx = c.fy = 200.0;
  c.cx = 40.0;
  c.cy = 30.0;
  c.baseline_m = 0.5;
  c.width = 80;
  c.height = 60;
  return c;
}

/// A slanted GT plane d = 8 + 0.1·u + 0.05·v (1.4–8.4 m away at f·B = 100), unknown in row 0.
cv::Mat slanted_gt() {
  cv::Mat gt(60, 80, CV_32F);
  for (int v = 0; v < gt.rows; ++v)
    for (int u = 0; u < gt.cols; ++u)
      gt.at<float>(v, u) = v == 0 ? 0.0f : 8.0f + 0.1f * u + 0.05f * v;
  return gt;
}

TEST(AccuracyCurve, PerfectDisparityIsWithinEveryDistance) {
  const cv::Mat gt = slanted_gt();
  const auto curve = eval::point_accuracy_curve(gt, gt, small_camera());
  EXPECT_EQ(curve.gt_pixels(), 59 * 80);
  EXPECT_DOUBLE_EQ(curve.density_pct(), 100.0);
  for (int k = 0; k <= curve.steps(); ++k)
    EXPECT_DOUBLE_EQ(curve.within_pct(k), 100.0) << "x = " << curve.threshold_m(k);
}

TEST(AccuracyCurve, CountsMatchADirectDistanceTestAtEveryThreshold) {
  // Estimate = GT + a pixel-dependent error in −1..+1 px, a few missing pixels.
  const StereoCamera camera = small_camera();
  const cv::Mat gt = slanted_gt();
  cv::Mat est = gt.clone();
  for (int v = 0; v < est.rows; ++v)
    for (int u = 0; u < est.cols; ++u) {
      est.at<float>(v, u) += static_cast<float>(std::sin(0.37 * u + 0.91 * v));
      if ((u * 7 + v * 3) % 23 == 0) est.at<float>(v, u) = kNoDisparity;
    }
  const auto curve = eval::point_accuracy_curve(est, gt, camera);
  // Independently: the two 3D points of each GT pixel, their Euclidean distance.
  std::vector<double> distances;
  long missing = 0;
  for (int v = 1; v < gt.rows; ++v)
    for (int u = 0; u < gt.cols; ++u) {
      if (std::isnan(est.at<float>(v, u))) {
        ++missing;
        continue;
      }
      distances.push_back((camera.back_project(u, v, est.at<float>(v, u)) -
                           camera.back_project(u, v, gt.at<float>(v, u)))
                              .norm());
    }
  EXPECT_EQ(curve.gt_pixels(), static_cast<long>(distances.size()) + missing);
  EXPECT_EQ(curve.with_point(), static_cast<long>(distances.size()));
  for (int k = 0; k <= curve.steps(); ++k) {
    long expected = 0;
    for (double d : distances) expected += d <= curve.threshold_m(k) + 1e-12;
    EXPECT_NEAR(curve.within(k), expected, 1)
        << "x = " << curve.threshold_m(k);  // ±1 at a float tie
  }
  // Not degenerate: the curve rises through the range.
  EXPECT_LT(curve.within_pct(10), 50.0);
  EXPECT_GT(curve.within_pct(100), curve.within_pct(10));
  // Table 1 (evaluate_points) and the curve agree at 10/20/50/100 cm exactly.
  const eval::PointErrors table = eval::evaluate_points(est, gt, camera);
  ASSERT_EQ(table.gt_pixels, curve.gt_pixels());
  for (std::size_t k = 0; k < eval::kPointRadiiM.size(); ++k)
    EXPECT_EQ(table.within[k],
              curve.within(static_cast<int>(std::lround(eval::kPointRadiiM[k] * 100))));
}

TEST(AccuracyCurve, PoolsFramesAndRejectsOtherGrids) {
  eval::AccuracyCurve a, b;
  a.add(0.05);
  a.add(NAN);
  b.add(0.5);
  b.add(2.0);  // has a point, beyond the curve's 1 m
  a += b;
  EXPECT_EQ(a.gt_pixels(), 4);
  EXPECT_EQ(a.with_point(), 3);
  EXPECT_EQ(a.within(4), 0);  // x = 4 cm
  EXPECT_EQ(a.within(5), 1);  // x = 5 cm: 0.05 ≤ 0.05
  EXPECT_EQ(a.within(50), 2);
  EXPECT_EQ(a.within(100), 2);
  EXPECT_DOUBLE_EQ(a.density_pct(), 75.0);
  eval::AccuracyCurve coarse(1.0, 10);
  EXPECT_THROW(a += coarse, ConfigError);
  EXPECT_THROW(eval::AccuracyCurve(0.0, 10), ConfigError);
}

/// A voxel map holding exactly the points of `disparity` (as the bench's voxel stage inserts them).
std::unique_ptr<voxel::VoxelMap> voxel_map_of(const cv::Mat& disparity, const StereoCamera& camera,
                                              const Pose& pose, double max_range_m) {
  auto map = std::make_unique<voxel::VoxelMap>(VoxelConfig{});
  const cv::Mat image(disparity.size(), CV_8UC3, cv::Scalar(80, 120, 160));
  map->insert(voxel::back_project(disparity, image, camera, pose, max_range_m));
  return map;
}

TEST(VoxelAccuracy, DistanceIsFromTheVoxelCentreAndFarPointsAreMissing) {
  const StereoCamera camera = small_camera();
  cv::Mat gt = slanted_gt();
  gt(cv::Rect(60, 1, 20, 59)).setTo(2.0f);  // Z = 50 m: beyond the 40 m range, never inserted
  Pose pose = Pose::Identity();
  pose.translate(Eigen::Vector3d(3.0, -1.2, 7.0));
  pose.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()));
  const double range_m = 40.0, res = 0.1;
  const auto voxels = voxel_map_of(gt, camera, pose, range_m);
  const auto curve = bench::voxel_accuracy_curve(gt, gt, camera, pose, *voxels, range_m);
  EXPECT_EQ(curve.gt_pixels(), 59 * 80);
  EXPECT_EQ(curve.with_point(), 59 * 60);  // the far columns have no voxel
  // Every in-range pixel's voxel centre is within half a voxel diagonal of its (exact) point.
  const int half_diagonal = static_cast<int>(std::ceil(std::sqrt(3.0) / 2 * res * 100));  // 9 cm
  EXPECT_EQ(curve.within(half_diagonal), 59 * 60);
  EXPECT_LT(curve.within(2), curve.within(half_diagonal));  // not all points sit at centres
  // One pixel by hand: centre of its 10 cm world voxel, back in the camera frame.
  cv::Mat one(gt.size(), CV_32F, cv::Scalar(0.0f));
  one.at<float>(20, 30) = gt.at<float>(20, 30);
  const Eigen::Vector3d x_cam = camera.back_project(30, 20, gt.at<float>(20, 30));
  const Eigen::Vector3d x_world = (pose.cast<float>() * x_cam.cast<float>()).cast<double>();
  const Eigen::Vector3d centre((std::floor(x_world.x() / res) + 0.5) * res,
                               (std::floor(x_world.y() / res) + 0.5) * res,
                               (std::floor(x_world.z() / res) + 0.5) * res);
  const double expected = (pose.inverse() * centre - x_cam).norm();
  const auto single =
      bench::voxel_accuracy_curve(one, one, camera, pose, *voxels, range_m, 1.0, 10000);
  ASSERT_EQ(single.gt_pixels(), 1);
  const int k = static_cast<int>(std::ceil(expected * 10000 - 1e-6));
  EXPECT_EQ(single.within(k + 1), 1);
  EXPECT_EQ(single.within(k - 2), 0);
}

TEST(VoxelAccuracy, AnEmptyVoxelMapHasNoPoints) {
  const StereoCamera camera = small_camera();
  const cv::Mat gt = slanted_gt();
  const voxel::VoxelMap empty;
  const auto curve = bench::voxel_accuracy_curve(gt, gt, camera, Pose::Identity(), empty, 40.0);
  EXPECT_EQ(curve.gt_pixels(), 59 * 80);
  EXPECT_EQ(curve.with_point(), 0);
  EXPECT_DOUBLE_EQ(curve.within_pct(100), 0.0);
}

}  // namespace
}  // namespace planecell::services
