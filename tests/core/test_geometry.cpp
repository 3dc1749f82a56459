/// Geometry of core/: stereo camera (back-projection/projection), disparity planes ↔ 3D planes,
/// plane transforms and pose validation, against hand-computed values.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/error.hpp"
#include "core/plane.hpp"
#include "core/pose.hpp"
#include "core/stereo_camera.hpp"

namespace planecell {
namespace {

/// fx ≠ fy and a non-centred principal point, so swapped terms show up.
StereoCamera test_camera() {
  StereoCamera camera;
  camera.fx = 700.0;
  camera.fy = 720.0;
  camera.cx = 600.0;
  camera.cy = 180.0;
  camera.baseline_m = 0.5;
  camera.width = 1200;
  camera.height = 360;
  return camera;
}

TEST(StereoCamera, BackProjectsAHandComputedPixel) {
  const StereoCamera camera = test_camera();
  // Z = fx·B/d = 700·0.5/35 = 10; X = (650−600)·10/700; Y = (200−180)·10/720.
  const Eigen::Vector3d p = camera.back_project(650.0, 200.0, 35.0);
  EXPECT_DOUBLE_EQ(p.z(), 10.0);
  EXPECT_NEAR(p.x(), 500.0 / 700.0, 1e-12);
  EXPECT_NEAR(p.y(), 200.0 / 720.0, 1e-12);
  EXPECT_DOUBLE_EQ(camera.depth_from_disparity(35.0), 10.0);
  EXPECT_DOUBLE_EQ(camera.disparity_from_depth(10.0), 35.0);
}

TEST(StereoCamera, NonPositiveDisparityHasInfiniteDepth) {
  const StereoCamera camera = test_camera();
  EXPECT_TRUE(std::isinf(camera.depth_from_disparity(0.0)));
  EXPECT_TRUE(std::isinf(camera.depth_from_disparity(-3.0)));
  EXPECT_TRUE(std::isinf(camera.depth_from_disparity(std::numeric_limits<double>::quiet_NaN())));
}

TEST(StereoCamera, ProjectionInvertsBackProjection) {
  const StereoCamera camera = test_camera();
  for (double u : {0.0, 313.5, 1199.0})
    for (double v : {0.0, 97.25, 359.0})
      for (double d : {0.5, 7.0, 120.0}) {
        const Eigen::Vector3d uvd = camera.project(camera.back_project(u, v, d));
        EXPECT_NEAR(uvd.x(), u, 1e-9);
        EXPECT_NEAR(uvd.y(), v, 1e-9);
        EXPECT_NEAR(uvd.z(), d, 1e-9);
      }
}

TEST(StereoCamera, ValidateNamesTheBadField) {
  StereoCamera camera = test_camera();
  EXPECT_NO_THROW(camera.validate());
  camera.baseline_m = -0.1;
  try {
    camera.validate("calib");
    FAIL() << "negative baseline accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("baseline"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("calib"), std::string::npos) << e.what();
  }
  camera = test_camera();
  camera.fy = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(camera.validate(), ConfigError);
}

TEST(DisparityPlane, GroundPlaneHasHandComputedCoefficients) {
  const StereoCamera camera = test_camera();
  // Road 1.5 m below the camera (y down): Y = 1.5 → n = (0, 1, 0), e = −1.5.
  // v − cy = fy·1.5/Z and d = fx·B/Z → d = fx·B/(1.5·fy)·(v − cy).
  Plane3 ground;
  ground.normal = Eigen::Vector3d::UnitY();
  ground.offset = -1.5;
  const DisparityPlane d = disparity_from_plane(ground, camera);
  const double b = 700.0 * 0.5 / (1.5 * 720.0);
  EXPECT_NEAR(d.a, 0.0, 1e-15);
  EXPECT_NEAR(d.b, b, 1e-12);
  EXPECT_NEAR(d.c, -b * 180.0, 1e-9);
  // Row 288 is 108 px below cy: d = b·108 → Z = fx·B/d = 1.5·fy/108 = 10 m.
  EXPECT_NEAR(camera.depth_from_disparity(d.at(42.0, 288.0)), 10.0, 1e-9);

  const Plane3 back = plane_from_disparity(d, camera);
  EXPECT_NEAR((back.normal - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(back.offset, -1.5, 1e-12);
}

TEST(DisparityPlane, FrontoParallelPlaneHasConstantDisparity) {
  const StereoCamera camera = test_camera();
  Plane3 wall;  // Z = 10 → d = fx·B/10 = 35 everywhere
  wall.normal = Eigen::Vector3d::UnitZ();
  wall.offset = -10.0;
  const DisparityPlane d = disparity_from_plane(wall, camera);
  EXPECT_NEAR(d.a, 0.0, 1e-15);
  EXPECT_NEAR(d.b, 0.0, 1e-15);
  EXPECT_NEAR(d.c, 35.0, 1e-12);
}

TEST(DisparityPlane, EveryBackProjectedPixelLiesOnTheExactPlane) {
  const StereoCamera camera = test_camera();
  const DisparityPlane d{0.013, -0.041, 31.0};  // slanted, positive over the image
  const Plane3 plane = plane_from_disparity(d, camera);
  EXPECT_NEAR(plane.normal.norm(), 1.0, 1e-12);
  for (int v = 0; v < camera.height; v += 7)
    for (int u = 0; u < camera.width; u += 11) {
      const double disparity = d.at(u, v);
      ASSERT_GT(disparity, 0.0);
      const Eigen::Vector3d p = camera.back_project(u, v, disparity);
      EXPECT_NEAR(plane.signed_distance(p), 0.0, 1e-9) << "pixel " << u << "," << v;
    }
  // And the inverse recovers the coefficients.
  const DisparityPlane again = disparity_from_plane(plane, camera);
  EXPECT_NEAR(again.a, d.a, 1e-12);
  EXPECT_NEAR(again.b, d.b, 1e-12);
  EXPECT_NEAR(again.c, d.c, 1e-9);
}

TEST(DisparityPlane, NormalSigmaOfAFrontoParallelPlaneIsItsSlopesSigmaOverItsDisparity) {
  // d = 35 (Z = 10). Slopes moved by σ_a along u, with c keeping d at the centroid (cx, cy):
  // the raw normal (a·fx, b·fy, a·cx + b·cy + c) becomes (σ_a·fx, 0, 35), turned by
  // atan(σ_a·fx / 35); likewise atan(σ_b·fy / 35) along v; the two add in quadrature.
  const StereoCamera camera = test_camera();
  const DisparityPlane wall{0.0, 0.0, 35.0};
  const Eigen::Vector2d centroid(camera.cx, camera.cy);
  const double sigma_a = 0.002, sigma_b = 0.001;
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  cov.diagonal() << sigma_a * sigma_a, sigma_b * sigma_b;
  const double along_u = std::atan(sigma_a * camera.fx / 35.0), along_v = std::atan(sigma_b * camera.fy / 35.0);
  EXPECT_NEAR(normal_sigma_rad(wall, cov, centroid, camera), std::hypot(along_u, along_v), 1e-9);
  // A cell 4× wider in each direction (scatter ×16, slopes' covariance ÷16) turns a quarter as much.
  EXPECT_NEAR(normal_sigma_rad(wall, cov / 16.0, centroid, camera),
              std::hypot(std::atan(sigma_a / 4 * camera.fx / 35.0), std::atan(sigma_b / 4 * camera.fy / 35.0)), 1e-9);
  // A slope error turns a far plane (small disparity) more than a near one.
  EXPECT_GT(normal_sigma_rad({0.0, 0.0, 7.0}, cov, centroid, camera), normal_sigma_rad(wall, cov, centroid, camera));
  EXPECT_EQ(normal_sigma_rad(wall, Eigen::Matrix2d::Zero(), centroid, camera), 0.0);
}

TEST(DisparityPlane, PlaneThroughTheCameraCentreIsRejected) {
  Plane3 edge_on;
  edge_on.normal = Eigen::Vector3d::UnitX();
  edge_on.offset = 0.0;
  EXPECT_THROW(disparity_from_plane(edge_on, test_camera()), InputError);
}

TEST(FitPlane, RecoversAKnownPlane) {
  // Plane 2x − y + 2z − 6 = 0 → n = (2, −1, 2)/3, e = −2.
  Eigen::Matrix3Xd points(3, 4);
  points << 3, 0, 0, 1,  //
      0, -6, 0, -2,      //
      0, 0, 3, 1;
  Plane3 plane = fit_plane(points);
  if (plane.offset > 0) {
    plane.normal = -plane.normal;
    plane.offset = -plane.offset;
  }
  EXPECT_NEAR((plane.normal - Eigen::Vector3d(2, -1, 2) / 3.0).norm(), 0.0, 1e-12);
  EXPECT_NEAR(plane.offset, -2.0, 1e-12);
  EXPECT_THROW(fit_plane(points.leftCols(2)), InputError);
}

TEST(TransformPlane, MovesPlaneWithItsPoints) {
  // 90° about z, then translate (1, 2, 3). Plane X = 2 → n' = R·n = (0, 1, 0),
  // e' = e − n'·t = −2 − 2 = −4, i.e. Y = 4.
  Pose pose = Pose::Identity();
  pose.linear() = Eigen::AngleAxisd(M_PI / 2.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(1, 2, 3);
  Plane3 plane;
  plane.normal = Eigen::Vector3d::UnitX();
  plane.offset = -2.0;
  const Plane3 moved = transform_plane(pose, plane);
  EXPECT_NEAR((moved.normal - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-12);
  EXPECT_NEAR(moved.offset, -4.0, 1e-12);
  const Eigen::Vector3d on_plane(2.0, 5.0, 7.0);
  const Eigen::Vector3d moved_point = pose * on_plane;  // (−4, 4, 10)
  EXPECT_NEAR((moved_point - Eigen::Vector3d(-4, 4, 10)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(moved.signed_distance(moved_point), 0.0, 1e-12);
}

TEST(ValidatePose, AcceptsARotationAndRejectsBadMatrices) {
  Pose good = Pose::Identity();
  good.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  good.translation() = Eigen::Vector3d(4, -5, 6);
  EXPECT_NO_THROW(validate_pose(good, "good"));

  auto expect_rejected = [](Pose pose, const std::string& why) {
    try {
      validate_pose(pose, "poses.txt line 7");
      ADD_FAILURE() << why << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("poses.txt line 7"), std::string::npos) << e.what();
    }
  };
  Pose nan = good;
  nan.translation().x() = std::numeric_limits<double>::quiet_NaN();
  expect_rejected(nan, "NaN translation");
  Pose inf = good;
  inf.matrix()(1, 1) = std::numeric_limits<double>::infinity();
  expect_rejected(inf, "Inf rotation entry");
  Pose scaled = good;
  scaled.linear() *= 1.01;
  expect_rejected(scaled, "scaled rotation");
  Pose sheared = Pose::Identity();
  sheared.matrix()(0, 1) = 0.2;
  expect_rejected(sheared, "sheared rotation");
  Pose reflection = Pose::Identity();
  reflection.matrix()(2, 2) = -1.0;
  expect_rejected(reflection, "reflection (det −1)");
}

TEST(PoseFrom3x4, ReadsRowMajorKittiLayout) {
  // [R | t] with R = 90° about z: rows (0 −1 0), (1 0 0), (0 0 1).
  const double v[12] = {0, -1, 0, 1.5, 1, 0, 0, -2.5, 0, 0, 1, 3.25};
  const Pose pose = pose_from_3x4(v, "test");
  EXPECT_DOUBLE_EQ(pose.translation().x(), 1.5);
  EXPECT_DOUBLE_EQ(pose.translation().y(), -2.5);
  EXPECT_DOUBLE_EQ(pose.translation().z(), 3.25);
  EXPECT_DOUBLE_EQ(pose.linear()(0, 1), -1.0);
  EXPECT_DOUBLE_EQ(pose.linear()(1, 0), 1.0);
  const double bad[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 2, 0};
  EXPECT_THROW(pose_from_3x4(bad, "bad"), InputError);
}

}  // namespace
}  // namespace planecell
