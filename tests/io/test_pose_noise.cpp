/// Noisy odometry generator: every step errs by exactly the configured rates, deterministically per
/// seed, and the accumulated error grows with the distance driven.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/error.hpp"
#include "io/synthetic/pose_noise.hpp"

namespace planecell::io {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/// A curving drive: step lengths 0.5 + 0.05·i m, heading turning 1° per step about y.
std::vector<Pose> drive(std::size_t n) {
  std::vector<Pose> poses{Pose::Identity()};
  for (std::size_t i = 1; i < n; ++i) {
    Pose step = Pose::Identity();
    step.linear() = Eigen::AngleAxisd(1.0 * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix();
    step.translation() = Eigen::Vector3d(0, 0, 0.5 + 0.05 * static_cast<double>(i));
    poses.push_back(poses.back() * step);
  }
  return poses;
}

TEST(PoseNoise, EachStepErrsByExactlyTheRatesTimesItsLength) {
  const auto truth = drive(40);
  const PoseDrift drift{0.01, 0.1};
  const auto noisy = add_odometry_drift(truth, drift, 7);
  ASSERT_EQ(noisy.size(), truth.size());
  EXPECT_TRUE(noisy[0].isApprox(truth[0], 0.0));
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const Pose gt_step = truth[i - 1].inverse() * truth[i];
    const Pose error = gt_step.inverse() * (noisy[i - 1].inverse() * noisy[i]);
    const double length_m = gt_step.translation().norm();
    EXPECT_NEAR(error.translation().norm(), 0.01 * length_m, 1e-9) << "step " << i;
    EXPECT_NEAR(Eigen::AngleAxisd(error.linear()).angle() / kDeg, 0.1 * length_m, 1e-7) << "step " << i;
  }
}

TEST(PoseNoise, DeterministicPerSeedAndExactWithZeroRates) {
  const auto truth = drive(20);
  const auto a = add_odometry_drift(truth, {0.02, 0.2}, 3);
  const auto b = add_odometry_drift(truth, {0.02, 0.2}, 3);
  const auto c = add_odometry_drift(truth, {0.02, 0.2}, 4);
  for (std::size_t i = 0; i < truth.size(); ++i) EXPECT_TRUE(a[i].isApprox(b[i], 0.0));
  EXPECT_GT((a.back().translation() - c.back().translation()).norm(), 1e-3);
  const auto exact = add_odometry_drift(truth, {0.0, 0.0}, 3);
  for (std::size_t i = 0; i < truth.size(); ++i)
    EXPECT_LT((exact[i].matrix() - truth[i].matrix()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_TRUE(add_odometry_drift(std::vector<Pose>{}, {0.01, 0.1}, 1).empty());
}

TEST(PoseNoise, AccumulatedErrorGrowsWithDistance) {
  const auto truth = drive(60);
  const auto noisy = add_odometry_drift(truth, {0.01, 0.1}, 11);
  const auto error_at = [&](std::size_t i) { return (noisy[i].translation() - truth[i].translation()).norm(); };
  // A biased random walk: the error keeps growing (the 0.1°/m heading error alone puts the end,
  // ~117 m along, metres off; 1 % of the distance is ~1.2 m).
  EXPECT_LT(error_at(10), error_at(30));
  EXPECT_LT(error_at(30), error_at(59));
  EXPECT_GT(error_at(59), 0.5);
}

TEST(PoseNoise, AStandingRigErrsByThePerStepFloorsOnly) {
  // Twenty poses at one place (a hovering or parked rig): no metre is driven, so only the floors
  // act, and every step errs by exactly them.
  Pose parked = Pose::Identity();
  parked.translation() = Eigen::Vector3d(1, 2, 3);
  const std::vector<Pose> truth(20, parked);
  const auto noisy = add_odometry_drift(truth, {0.01, 0.1, 0.002, 0.03}, 5);
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const Pose error = noisy[i - 1].inverse() * noisy[i];  // the true step is the identity
    EXPECT_NEAR(error.translation().norm(), 0.002, 1e-12) << "step " << i;
    EXPECT_NEAR(Eigen::AngleAxisd(error.linear()).angle() / kDeg, 0.03, 1e-9) << "step " << i;
  }
  // Driving adds the floors to the rates.
  const auto moving = drive(10);
  const auto both = add_odometry_drift(moving, {0.01, 0.1, 0.002, 0.03}, 5);
  for (std::size_t i = 1; i < moving.size(); ++i) {
    const Pose gt_step = moving[i - 1].inverse() * moving[i];
    const Pose error = gt_step.inverse() * (both[i - 1].inverse() * both[i]);
    EXPECT_NEAR(error.translation().norm(), 0.01 * gt_step.translation().norm() + 0.002, 1e-9);
  }
}

TEST(PoseNoise, ParsesRatesAndRejectsBadText) {
  const PoseDrift floors = parse_pose_drift("0.01,0.1,0.002,0.03");
  EXPECT_DOUBLE_EQ(floors.translation_per_step_m, 0.002);
  EXPECT_DOUBLE_EQ(floors.rotation_deg_per_step, 0.03);
  const PoseDrift d = parse_pose_drift("0.01,0.1");
  EXPECT_DOUBLE_EQ(d.translation_per_m, 0.01);
  EXPECT_DOUBLE_EQ(d.rotation_deg_per_m, 0.1);
  for (const char* bad : {"", "0.01", "a,b", "-0.01,0.1", "0.01,0.1x", "0.01,", ",0.1", "nan,0.1", "0.01,0.1,0.002",
                          "0.01,0.1,0.002,-0.03", "0.01,0.1,0.002,0.03,1"}) {
    try {
      parse_pose_drift(bad);
      ADD_FAILURE() << "no ConfigError for '" << bad << "'";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("--pose-noise"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(add_odometry_drift(drive(3), {-1.0, 0.0}, 1), ConfigError);
}

}  // namespace
}  // namespace planecell::io
