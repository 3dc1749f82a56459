/// Pose refinement end to end: a generated street replayed with seeded odometry drift
/// (1 %/m, 0.1°/m, as `synth --pose-noise 0.01,0.1` writes) and with the exact poses, scored
/// against the renderer's ground-truth trajectory.
#include <gtest/gtest.h>

#include "io/euroc.hpp"
#include "io/euroc_to_kitti.hpp"
#include "io/kitti_odometry.hpp"
#include "io/map_store.hpp"
#include "io/synthetic/pose_noise.hpp"
#include "services/replay.hpp"
#include "support/small_street.hpp"
#include "support/test_data.hpp"

namespace planecell::services {
namespace {

class ReplayRefinementTest : public ::testing::Test {
 protected:
  static constexpr int kFrames = 40;
  static constexpr std::uint64_t kSeed = 6;

  void SetUp() override {
    // 640 × 192: a half-size KITTI frame with the default stage settings (~850 cells), enough
    // cells for the map surfaces to constrain all six directions.
    test::write_small_street(scratch_ / "seq", kFrames, kSeed, 640, 192);
    const auto file = io::find_kitti_poses_file(scratch_ / "seq");
    ASSERT_TRUE(file.has_value());
    const auto sequence = io::open_kitti_odometry(scratch_ / "seq", *file);
    io::write_kitti_poses(scratch_ / "noisy.txt",
                          io::add_odometry_drift(sequence.poses, {0.01, 0.1}, kSeed));
    config_.refine.enabled = true;
    config_.refine.prior_sigma_m = 0.01;
    config_.refine.prior_sigma_deg = 0.05;
  }

  TrajectoryComparison replay(bool noisy) {
    ReplayOptions options;
    options.sequence_dir = scratch_ / "seq";
    options.progress = false;
    if (noisy) options.poses_path = scratch_ / "noisy.txt";
    const ReplayReport report = run_replay(options, config_);
    EXPECT_TRUE(report.refine.has_value());
    if (!report.refine || !report.refine->trajectory) {
      ADD_FAILURE() << "no trajectory comparison in the replay report";
      return {};
    }
    // The first frame has no map to align to; every later one must find its surfaces.
    EXPECT_GE(report.refine->refined_frames, static_cast<std::size_t>(kFrames - 2));
    return *report.refine->trajectory;
  }

  test::ScratchDir scratch_;
  AppConfig config_;
};

TEST_F(ReplayRefinementTest, DriftingOdometryIsPulledTowardsTheTrueTrajectory) {
  const TrajectoryComparison t = replay(true);
  // The drift is exactly 1 %/m and 0.1°/m per step (pose_noise): the input RPE states it.
  EXPECT_NEAR(t.input_rpe.rotation_deg_per_m, 0.1, 1e-6);
  EXPECT_LT(t.refined_rpe.rotation_deg_per_m, 0.95 * t.input_rpe.rotation_deg_per_m);
  EXPECT_LT(t.refined_ate.rmse_m, 0.8 * t.input_ate.rmse_m);
}

TEST_F(ReplayRefinementTest, ExactPosesStayWithinCentimetres) {
  const TrajectoryComparison t = replay(false);
  EXPECT_LT(t.input_ate.rmse_m, 1e-9);
  // 39 m driven: SGM's bias on the slanted road near the bottom rows (≈ −0.1 to −0.2 px) pulls
  // each frame by millimetres; the prior keeps the sum within a few centimetres.
  EXPECT_LT(t.refined_ate.rmse_m, 0.03);
  EXPECT_LT(t.refined_rpe.rotation_deg_per_m, 0.1);
}

TEST_F(ReplayRefinementTest, ThreadedPipelineRefinesLikeTheSingleThreadedReplayAndStoresBothPoses) {
  ReplayOptions options;
  options.sequence_dir = scratch_ / "seq";
  options.progress = false;
  options.poses_path = scratch_ / "noisy.txt";
  options.last_frame = 12;
  options.map_path = scratch_ / "single.db";
  const ReplayReport single = run_replay(options, config_);
  options.threads = true;
  options.map_path = scratch_ / "threaded.db";
  const ReplayReport threaded = run_replay(options, config_);
  ASSERT_TRUE(single.refine && threaded.refine);
  ASSERT_EQ(threaded.refine->frames.size(), single.refine->frames.size());
  EXPECT_GE(threaded.refine->refined_frames, 10u);
  for (std::size_t i = 0; i < single.refine->frames.size(); ++i)
    EXPECT_TRUE(threaded.refine->frames[i].refined.isApprox(single.refine->frames[i].refined, 1e-12)) << "frame " << i;
  // The store keeps the refined pose and, beside it, the odometry pose the frame came with.
  const auto noisy = io::open_kitti_odometry(scratch_ / "seq", scratch_ / "noisy.txt").poses;
  io::MapStore store(scratch_ / "threaded.db");
  for (std::uint64_t f = 1; f < 12; ++f) {
    const FrameRefinement& record = threaded.refine->frames[f];
    ASSERT_EQ(record.frame_id, f);
    ASSERT_TRUE(store.pose(f).has_value());
    EXPECT_TRUE(store.pose(f)->isApprox(record.refined, 0.0)) << "frame " << f;
    ASSERT_TRUE(store.input_pose(f).has_value()) << "frame " << f;
    EXPECT_TRUE(store.input_pose(f)->isApprox(noisy[f], 1e-12)) << "frame " << f;
  }
}

/// The EuRoC V1_01 sample (real images; the MAV stands or hovers), imported into the KITTI layout,
/// with its ground-truth poses given per-frame noise (2 mm and 0.03° per frame).
TEST(RealData, EurocRefinementIsNoWorseThanNoisyOrExactPoses) {
  const auto root = test::shared_data("euroc/V1_01_easy_micro");
  if (!root) GTEST_SKIP() << "shared data absent";
  test::ScratchDir scratch;
  io::write_euroc_as_kitti(io::open_euroc(*root), scratch / "v101");
  const auto sequence = io::open_kitti_odometry(scratch / "v101");
  io::write_kitti_poses(scratch / "noisy.txt",
                        io::add_odometry_drift(sequence.poses, {0.01, 0.1, 0.002, 0.03}, 1));
  AppConfig config;  // config/euroc.yaml
  config.sgm.max_disparity = 64;
  config.extraction.target_cells = 500;
  config.map.max_range_m = 15.0;
  config.refine.enabled = true;
  config.refine.prior_sigma_m = 0.01;
  config.refine.prior_sigma_deg = 0.05;
  ReplayOptions options;
  options.sequence_dir = scratch / "v101";
  options.progress = false;
  options.last_frame = 30;
  const auto trajectory = [&](bool noisy) {
    options.poses_path = noisy ? std::optional(scratch / "noisy.txt") : std::nullopt;
    const ReplayReport report = run_replay(options, config);
    EXPECT_TRUE(report.refine && report.refine->trajectory);
    return report.refine && report.refine->trajectory ? *report.refine->trajectory : TrajectoryComparison{};
  };
  const TrajectoryComparison noisy = trajectory(true);
  EXPECT_GT(noisy.input_ate.rmse_m, 0.005);
  EXPECT_LT(noisy.refined_ate.rmse_m, 0.5 * noisy.input_ate.rmse_m);
  const TrajectoryComparison exact = trajectory(false);
  EXPECT_LT(exact.refined_ate.rmse_m, 0.01);
  EXPECT_LT(exact.refined_rpe.rotation_rmse_deg, 0.1);
}

}  // namespace
}  // namespace planecell::services
