/// RefineStage (services/refine_stage): the per-frame records it keeps. A daemon runs
/// indefinitely, so without keep_records it holds only the last record, and must predict and
/// refine every frame exactly as a stage that keeps them all.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace planecell::services
