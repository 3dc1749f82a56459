/// A `planecell synth` sequence read back through the project's own KITTI odometry reader:
/// camera, poses, times and images must be exactly what the renderer used.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "io/disparity_io.hpp"
#include "io/kitti_odometry.hpp"
#include "io/synthetic/synthetic_world.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

TEST(SyntheticRoundTrip, SequenceLoadsThroughTheKittiOdometryReader) {
  test::ScratchDir scratch;
  SynthConfig config;
  config.frames = 5;
  config.seed = 11;
  config.width = 310;
  config.height = 94;
  const SyntheticWorld world = make_street_world(config);
  write_sequence(world, scratch / "seq");

  const KittiOdometrySequence sequence = open_kitti_odometry(scratch / "seq");
  ASSERT_EQ(sequence.size(), 5u);
  EXPECT_EQ(sequence.left_dir.filename(), "image_2");
  EXPECT_NEAR(sequence.camera.fx, world.camera.fx, 1e-6);
  EXPECT_NEAR(sequence.camera.cy, world.camera.cy, 1e-6);
  EXPECT_NEAR(sequence.camera.baseline_m, world.camera.baseline_m, 1e-9);
  EXPECT_EQ(sequence.camera.width, config.width);
  ASSERT_EQ(sequence.times_s.size(), 5u);
  EXPECT_NEAR(sequence.times_s[4] - sequence.times_s[0], 4.0 / config.frame_rate_hz, 1e-9);
  ASSERT_EQ(sequence.poses.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i)
    EXPECT_LT((sequence.poses[i].matrix() - world.trajectory[i].matrix()).cwiseAbs().maxCoeff(), 1e-6)
        << "pose " << i;

  const StereoFrame frame = load_kitti_frame(sequence, 3);
  const SyntheticView view = render_view(world, world.trajectory[3], 3);
  ASSERT_EQ(frame.left.size(), view.left.size());
  EXPECT_EQ(cv::norm(frame.left, view.left, cv::NORM_INF), 0.0);  // PNG is lossless
  EXPECT_EQ(cv::norm(frame.right, view.right, cv::NORM_INF), 0.0);
  const cv::Mat gt = read_kitti_disparity(scratch / "seq" / "disp_occ_0" / "000003.png");
  int checked = 0;
  for (int v = 0; v < gt.rows; v += 7)
    for (int u = 0; u < gt.cols; u += 7) {
      const float expected = view.disparity.at<float>(v, u);
      if (!std::isfinite(expected)) continue;
      EXPECT_NEAR(gt.at<float>(v, u), expected, 1.0 / 256.0) << u << "," << v;
      ++checked;
    }
  EXPECT_GT(checked, 100);
}

}  // namespace
}  // namespace planecell::io
