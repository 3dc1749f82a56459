/// ATE and RPE against hand-computed trajectories.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/error.hpp"
#include "services/eval/trajectory_metrics.hpp"

namespace planecell::services::eval {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Pose at(double x, double y, double z) {
  Pose p = Pose::Identity();
  p.translation() = Eigen::Vector3d(x, y, z);
  return p;
}

std::vector<Pose> straight(std::size_t n) {
  std::vector<Pose> poses;
  for (std::size_t i = 0; i < n; ++i) poses.push_back(at(static_cast<double>(i), 0, 0));
  return poses;
}

TEST(Ate, SymmetricOffsetsNeedNoAlignmentAndGiveTheirRms) {
  const auto gt = straight(4);
  // Offsets +0.1, −0.1, −0.1, +0.1 in y: centred and uncorrelated with x, so the best rigid
  // alignment leaves every point's x and the residuals are 0.1 m each.
  const std::vector<Pose> est = {at(0, 0.1, 0), at(1, -0.1, 0), at(2, -0.1, 0), at(3, 0.1, 0)};
  const AteResult r = absolute_trajectory_error(est, gt);
  EXPECT_EQ(r.poses, 4u);
  EXPECT_NEAR(r.rmse_m, 0.1, 1e-12);
  EXPECT_NEAR(r.mean_m, 0.1, 1e-12);
  EXPECT_NEAR(r.max_m, 0.1, 1e-12);
  // (The ground truth is a line, so any rotation about it is as good; the line itself stays put.)
  EXPECT_TRUE((r.alignment * Eigen::Vector3d(1.5, 0, 0)).isApprox(Eigen::Vector3d(1.5, 0, 0), 1e-9));
  EXPECT_TRUE((r.alignment.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitX(), 1e-9));
}

TEST(Ate, ARigidlyMovedTrajectoryAlignsToZero) {
  std::vector<Pose> gt = {at(0, 0, 0), at(1, 0, 0), at(2, 1, 0), at(3, 1, 1), at(2, 3, 1)};
  Pose motion = Pose::Identity();
  motion.linear() = Eigen::AngleAxisd(30 * kDeg, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  motion.translation() = Eigen::Vector3d(5, -2, 7);
  std::vector<Pose> est;
  for (const auto& p : gt) est.push_back(motion * p);
  const AteResult aligned = absolute_trajectory_error(est, gt);
  EXPECT_LT(aligned.rmse_m, 1e-9);
  EXPECT_TRUE(aligned.alignment.isApprox(motion.inverse(), 1e-9));
  // Unaligned: a pure shift of (3, 4, 0) gives exactly 5 m everywhere.
  std::vector<Pose> shifted;
  for (const auto& p : gt) shifted.push_back(at(3, 4, 0) * p);
  EXPECT_NEAR(absolute_trajectory_error(shifted, gt, false).rmse_m, 5.0, 1e-12);
  EXPECT_LT(absolute_trajectory_error(shifted, gt, true).rmse_m, 1e-9);
}

TEST(Rpe, OneBadStepGivesItsErrorOverTheDistance) {
  const auto gt = straight(10);  // 9 steps of 1 m
  // Same increments, except step 4 → 5 is 0.05 m too long and turned by 2° about z.
  std::vector<Pose> est{gt[0]};
  for (std::size_t i = 1; i < gt.size(); ++i) {
    Pose step = gt[i - 1].inverse() * gt[i];
    if (i == 5) {
      Pose error = Pose::Identity();
      error.linear() = Eigen::AngleAxisd(2 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      error.translation() = Eigen::Vector3d(0.05, 0, 0);
      step = step * error;
    }
    est.push_back(est.back() * step);
  }
  const RpeResult r = relative_pose_error(est, gt, 1);
  EXPECT_EQ(r.pairs, 9u);
  EXPECT_NEAR(r.translation_percent, 100.0 * 0.05 / 9.0, 1e-9);
  EXPECT_NEAR(r.rotation_deg_per_m, 2.0 / 9.0, 1e-9);
  EXPECT_NEAR(r.translation_rmse_m, std::sqrt(0.05 * 0.05 / 9.0), 1e-12);
  EXPECT_NEAR(r.rotation_rmse_deg, std::sqrt(2.0 * 2.0 / 9.0), 1e-9);
  // Over 3-frame windows the bad step is inside 3 of the 7 pairs: 3·0.05 m over 7·3 m.
  const RpeResult r3 = relative_pose_error(est, gt, 3);
  EXPECT_EQ(r3.pairs, 7u);
  EXPECT_NEAR(r3.rotation_deg_per_m, 3 * 2.0 / 21.0, 1e-9);
}

TEST(TrajectoryMetrics, MismatchedOrEmptyInputsAreErrors) {
  const auto gt = straight(5);
  EXPECT_THROW(absolute_trajectory_error(straight(4), gt), InputError);
  EXPECT_THROW(absolute_trajectory_error(std::vector<Pose>{}, std::vector<Pose>{}), InputError);
  EXPECT_THROW(relative_pose_error(straight(4), gt), InputError);
  EXPECT_THROW(relative_pose_error(gt, gt, 0), InputError);
  const RpeResult same = relative_pose_error(gt, gt, 2);
  EXPECT_EQ(same.pairs, 3u);
  EXPECT_NEAR(same.translation_percent, 0.0, 1e-12);
}

}  // namespace
}  // namespace planecell::services::eval
