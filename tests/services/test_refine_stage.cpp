/// RefineStage (services/refine_stage): the per-frame records it keeps. A daemon runs
/// indefinitely, so without keep_records it holds only the last record, and must predict and
/// refine every frame exactly as a stage that keeps them all.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "mapping/map/global_map.hpp"
#include "mapping/map/pose_transform.hpp"
#include "services/refine_stage.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::services {
namespace {

Pose translation(double x, double y, double z) {
  Pose p = Pose::Identity();
  p.translation() = Eigen::Vector3d(x, y, z);
  return p;
}

TEST(RefineStage, WithoutRecordsKeepsOnlyTheLastAndRefinesTheSame) {
  MapConfig map_config;
  map_config.max_range_m = 40.0;  // the street's facade is 20 m ahead
  map::GlobalMap map(map_config);
  map.integrate(0, Pose::Identity(), test::street_cells(0.0f, false));
  RefineConfig config;
  config.enabled = true;

  RefineStage keeping(config, true), last_only(config, false);
  // The camera drives 1 m per frame; the odometry is off by a constant (0.1, −0.05, 0.1) m, so
  // each frame's prediction carries the previous frame's correction.
  const Pose offset = translation(0.1, -0.05, 0.1);
  for (std::uint64_t frame = 1; frame <= 3; ++frame) {
    const Pose truth = translation(0.0, 0.0, static_cast<double>(frame));
    const auto cells = map::to_world(test::street_cells(1.0f, false), truth.inverse());
    const StereoCamera camera;
    const Pose a = keeping.refine(frame, cells, offset * truth, map, camera);
    const Pose b = last_only.refine(frame, cells, offset * truth, map, camera);
    EXPECT_TRUE(a.isApprox(b, 1e-12)) << "frame " << frame;
    EXPECT_LT((a.translation() - truth.translation()).norm(), 0.01) << "frame " << frame;
  }
  const RefineSummary all = keeping.summary({}, std::nullopt), last = last_only.summary({}, std::nullopt);
  ASSERT_EQ(all.frames.size(), 3u);
  ASSERT_EQ(last.frames.size(), 1u);
  EXPECT_EQ(last.frames[0].frame_id, 3u);
  // Frame 3 was predicted from frame 2's correction in both: the same prediction.
  EXPECT_TRUE(last.frames[0].predicted.isApprox(all.frames[2].predicted, 1e-12));
  EXPECT_FALSE(last.frames[0].predicted.isApprox(last.frames[0].input, 1e-6));
}

// Odometry with a persistent bias: every 1 m step is reported 4 cm long. The map (frame 0's
// street, a facade 20 m ahead) observes the forward direction, so each frame's correction
// measures the bias; with drift_gain the stage learns it (b_z → −0.04 m/m, the correction that
// undoes the bias) and its predictions converge to the truth, while without it every prediction
// stays 4 cm long.
TEST(RefineStage, DriftEstimateLearnsAPersistentOdometryBias) {
  MapConfig map_config;
  map_config.max_range_m = 40.0;
  map::GlobalMap map(map_config);
  map.integrate(0, Pose::Identity(), test::street_cells(0.0f, false));
  RefineConfig config;
  config.enabled = true;  // no odometry prior: the map alone corrects each frame
  RefineConfig learning = config;
  learning.drift_gain = 0.3;
  RefineStage plain(config), adaptive(learning);
  const StereoCamera camera;
  constexpr int kFrames = 9;  // beyond, too few cells overlap frame 0's map to observe all six directions
  for (int frame = 0; frame <= kFrames; ++frame) {
    const double z = 0.5 * frame;  // 0.5 m per frame: the facade stays within 20 m
    const Pose truth = translation(0.0, 0.0, z);
    const Pose odometry = translation(0.0, 0.0, 1.04 * z);
    const auto cells = map::to_world(test::street_cells(static_cast<float>(z), false), truth.inverse());
    plain.refine(frame, cells, odometry, map, camera);
    adaptive.refine(frame, cells, odometry, map, camera);
  }
  const RefineSummary a = plain.summary({}, std::nullopt), b = adaptive.summary({}, std::nullopt);
  const auto prediction_error = [](const FrameRefinement& f) {
    return std::abs(f.predicted.translation().z() - 0.5 * static_cast<double>(f.frame_id));
  };
  // Without the estimate, every prediction is the bias (2 cm) off; with it, the last one is far closer.
  EXPECT_NEAR(prediction_error(a.frames.back()), 0.02, 0.005);
  EXPECT_LT(prediction_error(b.frames.back()), 0.005);
  EXPECT_NEAR(b.frames.back().drift[5], -0.04, 0.01);
  EXPECT_LT(b.frames.back().drift.head<3>().norm(), 1e-3);
  EXPECT_TRUE(a.frames.back().drift.isZero());
  // And the refined poses themselves stay on the truth in both.
  for (const auto* s : {&a, &b})
    EXPECT_LT(std::abs(s->frames.back().refined.translation().z() - 0.5 * kFrames), 0.01);
}

// A level camera whose positions climb 1 cm per metre driven: the best-fit alignment rotates the
// straight climb onto the ground truth (ATE < 1 mm), the first-pose anchor keeps it in full:
// RMS of 0.01·i for i = 0..10 = 0.01·√(385/11) m.
TEST(RefineStage, AnchoredAteKeepsASteadyClimbThatTheAlignmentHides) {
  RefineConfig off;  // refinement disabled: the refined poses are the inputs
  RefineStage stage(off);
  const map::GlobalMap map;
  const StereoCamera camera;
  std::vector<Pose> truth;
  for (int i = 0; i <= 10; ++i) {
    truth.push_back(translation(0.0, 0.0, i));
    stage.refine(static_cast<std::uint64_t>(i), {}, translation(0.0, -0.01 * i, i), map, camera);
  }
  const RefineSummary summary = stage.summary(truth, std::nullopt);
  ASSERT_TRUE(summary.trajectory.has_value());
  const TrajectoryComparison& t = *summary.trajectory;
  EXPECT_LT(t.refined_ate.rmse_m, 1e-3);  // only the climb's 0.005 % longer path is left
  EXPECT_NEAR(t.refined_ate_anchored.rmse_m, 0.01 * std::sqrt(385.0 / 11.0), 1e-9);
  EXPECT_NEAR(t.input_ate_anchored.rmse_m, t.refined_ate_anchored.rmse_m, 1e-12);
}

}  // namespace
}  // namespace planecell::services
