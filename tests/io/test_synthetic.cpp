/// Tests of the synthetic stereo world (io/synthetic): exact ground truth, photo-consistency,
/// determinism, the KITTI layout it writes, and its error handling.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "core/stereo_camera.hpp"
#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"
#include "io/synthetic/synthetic_world.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

/// A small street (quarter of KITTI size) without sensor noise.
SyntheticWorld small_street(std::uint64_t seed = 7, int frames = 40, bool loop = false) {
  SynthConfig config;
  config.seed = seed;
  config.frames = frames;
  config.width = 310;
  config.height = 94;
  config.loop = loop;
  config.sensor_noise_sigma = 0.0;
  return make_street_world(config);
}

const SyntheticSurface& surface_of(const SyntheticWorld& world, std::uint16_t id) {
  return world.surfaces.at(id - 1u);
}

/// Bilinear sample of a BGR image at (x, v), x fractional.
cv::Vec3f sample_row(const cv::Mat& image, int v, double x) {
  const int x0 = static_cast<int>(std::floor(x));
  const double f = x - x0;
  const auto a = image.at<cv::Vec3b>(v, x0), b = image.at<cv::Vec3b>(v, x0 + 1);
  cv::Vec3f out;
  for (int c = 0; c < 3; ++c) out[c] = static_cast<float>((1.0 - f) * a[c] + f * b[c]);
  return out;
}

struct Consistency {
  double mean_abs_diff = 0.0;  ///< per channel, grey levels
  std::size_t pixels = 0;
};

/// Compares left(u, v) with right(u − d − shift_px, v) at pixels visible in both views: the
/// right pixels on both sides of u − d belong to the same surface as the left pixel.
Consistency photo_consistency(const SyntheticView& view, double shift_px = 0.0) {
  Consistency out;
  double sum = 0.0;
  for (int v = 0; v < view.left.rows; ++v)
    for (int u = 0; u < view.left.cols; ++u) {
      const std::uint16_t id = view.surface_id.at<std::uint16_t>(v, u);
      if (id == 0) continue;
      const double x = u - view.disparity.at<float>(v, u) - shift_px;
      if (x < 0.0 || x + 1.0 >= view.right.cols) continue;
      const int x0 = static_cast<int>(std::floor(x));
      if (view.right_surface_id.at<std::uint16_t>(v, x0) != id ||
          view.right_surface_id.at<std::uint16_t>(v, x0 + 1) != id)
        continue;
      const cv::Vec3f r = sample_row(view.right, v, x);
      const cv::Vec3b l = view.left.at<cv::Vec3b>(v, u);
      for (int c = 0; c < 3; ++c) sum += std::abs(l[c] - r[c]);
      ++out.pixels;
    }
  out.mean_abs_diff = out.pixels ? sum / (3.0 * out.pixels) : 0.0;
  return out;
}

// --- typed fixture over the two world builders -------------------------------------------------

struct BoxWorldMaker {
  static SyntheticWorld make() { return make_box_world(320, 120, 3, 3); }
};
struct StreetWorldMaker {
  static SyntheticWorld make() { return small_street(11, 60); }
};

template <class Maker>
class SyntheticWorldTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    world_ = new SyntheticWorld(Maker::make());
    const Pose& pose = world_->trajectory.back();
    view_ = new SyntheticView(render_view(*world_, pose, 0));
  }
  static void TearDownTestSuite() {
    delete view_;
    delete world_;
    view_ = nullptr;
    world_ = nullptr;
  }
  static SyntheticWorld* world_;
  static SyntheticView* view_;
};
template <class Maker>
SyntheticWorld* SyntheticWorldTest<Maker>::world_ = nullptr;
template <class Maker>
SyntheticView* SyntheticWorldTest<Maker>::view_ = nullptr;

using WorldMakers = ::testing::Types<BoxWorldMaker, StreetWorldMaker>;
TYPED_TEST_SUITE(SyntheticWorldTest, WorldMakers);

TYPED_TEST(SyntheticWorldTest, ViewHasDocumentedTypesAndSizes) {
  const SyntheticView& view = *this->view_;
  const StereoCamera& cam = this->world_->camera;
  for (const cv::Mat* m : {&view.left, &view.right}) {
    EXPECT_EQ(m->type(), CV_8UC3);
    EXPECT_EQ(m->cols, cam.width);
    EXPECT_EQ(m->rows, cam.height);
  }
  EXPECT_EQ(view.disparity.type(), CV_32F);
  EXPECT_EQ(view.surface_id.type(), CV_16U);
  EXPECT_EQ(view.disparity.size(), view.left.size());
  // NaN disparity exactly where there is no surface.
  for (int v = 0; v < view.disparity.rows; ++v)
    for (int u = 0; u < view.disparity.cols; ++u) {
      const float d = view.disparity.at<float>(v, u);
      const bool sky = view.surface_id.at<std::uint16_t>(v, u) == 0;
      ASSERT_EQ(std::isnan(d), sky) << "at (" << u << ", " << v << ")";
      if (!sky) {
        ASSERT_GT(d, 0.0f);
      }
    }
}

/// GT disparity = plane geometry: back-projecting (u, v, d) and moving to the world lands on the
/// plane of the GT surface, n·X + e = 0, within 1e-3 of |X − camera|, and inside its polygon.
TYPED_TEST(SyntheticWorldTest, GroundTruthDisparityBackProjectsOntoSurfacePlane) {
  const SyntheticWorld& world = *this->world_;
  const SyntheticView& view = *this->view_;
  const Pose& pose = world.trajectory.back();
  std::size_t checked = 0;
  std::vector<bool> seen(world.surfaces.size() + 1, false);
  for (int v = 0; v < view.disparity.rows; v += 3)
    for (int u = 0; u < view.disparity.cols; u += 3) {
      const std::uint16_t id = view.surface_id.at<std::uint16_t>(v, u);
      if (id == 0) continue;
      const SyntheticSurface& s = surface_of(world, id);
      const Eigen::Vector3d p_cam = world.camera.back_project(u, v, view.disparity.at<float>(v, u));
      const Eigen::Vector3d p_world = pose * p_cam;
      ASSERT_LE(std::abs(s.plane.signed_distance(p_world)), 1e-3 * p_cam.norm())
          << "surface " << id << " (" << to_string(s.kind) << ") at (" << u << ", " << v << ")";
      // Inside the polygon (convex, either orientation), up to a pixel-size margin.
      const Eigen::Vector2d st((p_world - s.origin).dot(s.u_axis), (p_world - s.origin).dot(s.v_axis));
      double min_cross = 1e300, max_cross = -1e300;
      for (std::size_t i = 0; i < s.polygon.size(); ++i) {
        const Eigen::Vector2d a = s.polygon[i], b = s.polygon[(i + 1) % s.polygon.size()];
        const Eigen::Vector2d e = (b - a).normalized(), w = st - a;
        const double cross = e.x() * w.y() - e.y() * w.x();
        min_cross = std::min(min_cross, cross);
        max_cross = std::max(max_cross, cross);
      }
      const double margin = 1e-3 * p_cam.norm() + 1e-6;
      ASSERT_TRUE(min_cross >= -margin || max_cross <= margin)
          << "surface " << id << " at (" << u << ", " << v << ") lies outside its polygon";
      seen[id] = true;
      ++checked;
    }
  EXPECT_GT(checked, 500u);
  EXPECT_GE(std::count(seen.begin(), seen.end(), true), 4);
}

/// The right view's GT agrees with the left: the point seen at (u, v) with disparity d is seen
/// at (u − d, v) in the right view with the same surface and the same disparity (same depth).
TYPED_TEST(SyntheticWorldTest, RightGroundTruthMatchesLeftAtCorrespondingPixels) {
  const SyntheticView& view = *this->view_;
  std::size_t checked = 0;
  for (int v = 0; v < view.left.rows; v += 2)
    for (int u = 0; u < view.left.cols; u += 2) {
      const std::uint16_t id = view.surface_id.at<std::uint16_t>(v, u);
      if (id == 0) continue;
      const double d = view.disparity.at<float>(v, u);
      const double x = u - d;
      const int x0 = static_cast<int>(std::floor(x));
      if (x0 < 0 || x0 + 1 >= view.right.cols) continue;
      if (view.right_surface_id.at<std::uint16_t>(v, x0) != id ||
          view.right_surface_id.at<std::uint16_t>(v, x0 + 1) != id)
        continue;
      const double f = x - x0;
      // Disparity is linear in u on a plane, so interpolation is exact up to float rounding.
      const double d_right = (1 - f) * view.right_disparity.at<float>(v, x0) +
                             f * view.right_disparity.at<float>(v, x0 + 1);
      ASSERT_NEAR(d_right, d, 1e-3 * d + 1e-4) << "at (" << u << ", " << v << ")";
      ++checked;
    }
  EXPECT_GT(checked, 500u);
}

/// Photo-consistency at non-occluded pixels: left(u, v) ≈ right(u − d, v). A 3 px error in the
/// disparity must make the match clearly worse (the texture gives stereo real work).
TYPED_TEST(SyntheticWorldTest, LeftAndRightArePhotoConsistentAtGroundTruthDisparity) {
  const SyntheticView& view = *this->view_;
  const Consistency at_gt = photo_consistency(view);
  const Consistency shifted = photo_consistency(view, 3.0);
  ASSERT_GT(at_gt.pixels, static_cast<std::size_t>(view.left.total() / 3));
  EXPECT_LT(at_gt.mean_abs_diff, 2.5);
  EXPECT_GT(shifted.mean_abs_diff, 2.5 * at_gt.mean_abs_diff);
}

TYPED_TEST(SyntheticWorldTest, RenderingIsDeterministic) {
  const SyntheticWorld& world = *this->world_;
  const SyntheticView again = render_view(world, world.trajectory.back(), 0);
  EXPECT_EQ(cv::norm(again.left, this->view_->left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(again.right, this->view_->right, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(again.surface_id, this->view_->surface_id, cv::NORM_INF), 0.0);
  // Bitwise-equal disparity, NaN where NaN (OpenCV's compare does not treat NaN == NaN).
  const SyntheticView& first = *this->view_;
  int differing = 0;
  for (int v = 0; v < again.disparity.rows; ++v)
    for (int u = 0; u < again.disparity.cols; ++u) {
      const float a = again.disparity.at<float>(v, u), b = first.disparity.at<float>(v, u);
      differing += !(a == b || (std::isnan(a) && std::isnan(b)));
    }
  EXPECT_EQ(differing, 0);
}

// --- hand-computed geometry of the box world ---------------------------------------------------

TEST(BoxWorld, DisparityMatchesHandComputedDepths) {
  const SyntheticWorld world = make_box_world(320, 120, 1, 1);
  const SyntheticView view = render_view(world, world.trajectory[0]);
  const StereoCamera& cam = world.camera;
  // Box face at Z = 6 m, centre x = −1.0 m, y = 1.5 − 0.9 = 0.6 m: d = fx·B/6.
  const int u_box = static_cast<int>(std::lround(cam.cx + cam.fx * -1.0 / 6.0));
  const int v_box = static_cast<int>(std::lround(cam.cy + cam.fy * 0.6 / 6.0));
  EXPECT_EQ(view.surface_id.at<std::uint16_t>(v_box, u_box), 3);
  EXPECT_NEAR(view.disparity.at<float>(v_box, u_box), cam.fx * 0.54 / 6.0, 1e-4);
  // Ground y = 1.5 m under the principal column, bottom row: Z = 1.5·fy/(v − cy), d = fx·B/Z.
  const int v_ground = cam.height - 1, u_ground = static_cast<int>(std::lround(cam.cx));
  EXPECT_EQ(view.surface_id.at<std::uint16_t>(v_ground, u_ground), 1);
  const double z_ground = 1.5 * cam.fy / (v_ground - cam.cy);
  EXPECT_NEAR(view.disparity.at<float>(v_ground, u_ground), cam.fx * 0.54 / z_ground, 1e-4);
  // Back wall at Z = 14 m above the box: top row, principal column.
  EXPECT_EQ(view.surface_id.at<std::uint16_t>(0, u_ground), 2);
  EXPECT_NEAR(view.disparity.at<float>(0, u_ground), cam.fx * 0.54 / 14.0, 1e-4);
}

TEST(BoxWorld, NonOccludedDisparityDropsTheStripTheBoxHidesFromTheRightCamera) {
  // The right camera sits 0.54 m to the right: left of the box face (Z = 6 m, d_box = fx·B/6),
  // a strip of the surface behind it (disparity d_behind) d_box − d_behind px wide is hidden from
  // it; the left border u − d < 0 (match outside the right image) is not seen either.
  const SyntheticWorld world = make_box_world(320, 120, 1, 1);
  const SyntheticView view = render_view(world, world.trajectory[0]);
  const cv::Mat noc = non_occluded_disparity(view);
  const StereoCamera& cam = world.camera;
  const double d_box = cam.fx * 0.54 / 6.0;
  for (const double y_m : {0.2, 1.2}) {  // beside the weak panel (Z = 10), beside the ground
    const int v = static_cast<int>(std::lround(cam.cy + cam.fy * y_m / 6.0));
    int u_edge = -1;
    for (int u = 0; u < cam.width && u_edge < 0; ++u)
      if (view.surface_id.at<std::uint16_t>(v, u) == 3) u_edge = u;
    ASSERT_GT(u_edge, 30) << y_m;
    int hidden = 0;
    while (std::isnan(noc.at<float>(v, u_edge - 1 - hidden))) ++hidden;
    const int u_behind = u_edge - 1 - hidden;  // first seen pixel left of the strip
    const double d_behind = view.disparity.at<float>(v, u_behind);
    EXPECT_NEAR(hidden, d_box - d_behind, 1.0) << "row " << v << ", d_behind " << d_behind;
    // Beside the strip, and on the box, the disparity is kept as it is.
    EXPECT_EQ(noc.at<float>(v, u_behind), view.disparity.at<float>(v, u_behind));
    EXPECT_EQ(noc.at<float>(v, u_edge + 3), view.disparity.at<float>(v, u_edge + 3));
    // The left border: u − d < 0 is never seen by the right camera.
    for (int u = 0; u < 10; ++u) {
      const float d = view.disparity.at<float>(v, u);
      if (std::isfinite(d) && u - d < -1.0f) {
        EXPECT_TRUE(std::isnan(noc.at<float>(v, u))) << u;
      }
    }
  }
  EXPECT_THROW(non_occluded_disparity(SyntheticView{}), InputError);
}

TEST(BoxWorld, WeaklyTexturedPanelHasLowContrast) {
  const SyntheticWorld world = make_box_world(320, 120, 1, 1);
  const SyntheticView view = render_view(world, world.trajectory[0]);
  cv::Mat grey;
  cv::cvtColor(view.left, grey, cv::COLOR_BGR2GRAY);
  cv::Scalar mean_weak, std_weak, mean_box, std_box;
  cv::meanStdDev(grey, mean_weak, std_weak, view.surface_id == 5);
  cv::meanStdDev(grey, mean_box, std_box, view.surface_id == 3);
  ASSERT_GT(cv::countNonZero(view.surface_id == 5), 100);
  EXPECT_LT(std_weak[0], 0.25 * std_box[0]);
  EXPECT_GT(std_box[0], 5.0);
}

// --- the street --------------------------------------------------------------------------------

TEST(StreetWorld, FirstCameraIsTheWorldAndTheRoadIsCameraHeightBelow) {
  const SyntheticWorld world = small_street(5, 200);
  EXPECT_TRUE(world.trajectory.front().isApprox(Pose::Identity(), 1e-12));
  std::size_t roads = 0;
  for (const auto& s : world.surfaces) {
    EXPECT_EQ(static_cast<std::ptrdiff_t>(s.id), &s - world.surfaces.data() + 1);
    if (s.kind != SurfaceKind::kRoad) continue;
    ++roads;
    EXPECT_NEAR(s.plane.normal.y(), -1.0, 1e-12);  // up is −y
    EXPECT_NEAR(s.plane.offset, 1.65, 1e-12);      // −y + 1.65 = 0
  }
  EXPECT_GE(roads, 2u);
  // Ground under the first camera: the road surface id under the principal point's column.
  const SyntheticView view = render_view(world, world.trajectory.front());
  const auto id = view.surface_id.at<std::uint16_t>(world.camera.height - 1,
                                                    static_cast<int>(world.camera.cx));
  ASSERT_NE(id, 0);
  EXPECT_EQ(surface_of(world, id).kind, SurfaceKind::kRoad);
  // Sky at the top of the first image (buildings are 6–20 m high, the street is open above).
  EXPECT_GT(cv::countNonZero(view.surface_id.row(0) == 0), 0);
}

TEST(StreetWorld, TrajectoryIsSmoothLevelAndTurns) {
  const SyntheticWorld world = small_street(5, 400);
  double min_yaw = 0.0, max_yaw = 0.0;
  for (std::size_t i = 0; i + 1 < world.trajectory.size(); ++i) {
    const Pose& a = world.trajectory[i];
    const Pose& b = world.trajectory[i + 1];
    EXPECT_NEAR((b.translation() - a.translation()).norm(), 1.0, 1e-3);  // 10 m/s at 10 Hz
    EXPECT_NEAR(b.translation().y(), 0.0, 1e-12);                         // level road
    EXPECT_NEAR((b.linear() * Eigen::Vector3d::UnitY()).y(), 1.0, 1e-12);  // yaw only
    const Eigen::Vector3d forward = b.linear() * Eigen::Vector3d::UnitZ();
    const double yaw = std::atan2(forward.x(), forward.z());
    min_yaw = std::min(min_yaw, yaw);
    max_yaw = std::max(max_yaw, yaw);
    const Eigen::Vector3d prev_forward = a.linear() * Eigen::Vector3d::UnitZ();
    EXPECT_LT(std::acos(std::clamp(prev_forward.dot(forward), -1.0, 1.0)), 0.1);  // smooth
  }
  EXPECT_GT(max_yaw - min_yaw, 20.0 * M_PI / 180.0);  // it turns
  EXPECT_NEAR(world.path_length_m, 399.0, 1e-9);
}

TEST(StreetWorld, LoopDrivesTheSameBlockTwice) {
  const SyntheticWorld world = small_street(5, 200, true);
  ASSERT_EQ(world.trajectory.size(), 200u);
  for (std::size_t i = 0; i < 100; ++i)
    ASSERT_TRUE(world.trajectory[i].isApprox(world.trajectory[i + 100], 1e-6)) << "frame " << i;
  // One lap (frames 0..100, frame 100 = frame 0) turns by exactly 360° (four right turns).
  double turned = 0.0;
  for (std::size_t i = 0; i < 100; ++i) {
    const Eigen::Vector3d a = world.trajectory[i].linear() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d b = world.trajectory[i + 1].linear() * Eigen::Vector3d::UnitZ();
    turned += std::atan2(a.cross(b).y(), a.dot(b));
  }
  EXPECT_NEAR(std::abs(turned), 2.0 * M_PI, 1e-6);
}

TEST(StreetWorld, SameSeedGivesIdenticalImagesAndDifferentSeedsDiffer) {
  const SyntheticWorld a = small_street(21, 5), b = small_street(21, 5), c = small_street(22, 5);
  const SyntheticView va = render_view(a, a.trajectory[4], 4);
  const SyntheticView vb = render_view(b, b.trajectory[4], 4);
  const SyntheticView vc = render_view(c, c.trajectory[4], 4);
  EXPECT_EQ(cv::norm(va.left, vb.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(va.right, vb.right, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(va.surface_id, vb.surface_id, cv::NORM_INF), 0.0);
  cv::Mat diff;
  cv::absdiff(va.left, vc.left, diff);
  cv::cvtColor(diff, diff, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(diff > 8), static_cast<int>(diff.total() / 3));
}

TEST(StreetWorld, SensorNoiseIsSmallAndDeterministic) {
  SynthConfig config;
  config.frames = 2;
  config.width = 310;
  config.height = 94;
  config.sensor_noise_sigma = 0.0;
  const SyntheticWorld clean = make_street_world(config);
  config.sensor_noise_sigma = 1.5;
  const SyntheticWorld noisy = make_street_world(config);
  const SyntheticView a = render_view(clean, clean.trajectory[1], 1);
  const SyntheticView b = render_view(noisy, noisy.trajectory[1], 1);
  const SyntheticView b2 = render_view(noisy, noisy.trajectory[1], 1);
  EXPECT_EQ(cv::norm(b.left, b2.left, cv::NORM_INF), 0.0);
  cv::Mat diff;
  a.left.convertTo(diff, CV_32F);
  cv::Mat noisy_f;
  b.left.convertTo(noisy_f, CV_32F);
  diff = noisy_f - diff;
  cv::Scalar mean, stddev;
  cv::meanStdDev(diff.reshape(1), mean, stddev);
  EXPECT_NEAR(mean[0], 0.0, 0.2);
  EXPECT_NEAR(stddev[0], 1.5, 0.35);  // 8-bit rounding adds ≈ 1/12 variance
  EXPECT_EQ(cv::norm(a.surface_id, b.surface_id, cv::NORM_INF), 0.0);
}

TEST(StreetWorld, BadConfigurationIsRejectedWithTheFieldName) {
  SynthConfig config;
  config.frames = 0;
  EXPECT_THROW(
      {
        try {
          make_street_world(config);
        } catch (const ConfigError& e) {
          EXPECT_NE(std::string(e.what()).find("frames"), std::string::npos);
          throw;
        }
      },
      ConfigError);
  config.frames = 10;
  config.width = 10;
  EXPECT_THROW(make_street_world(config), ConfigError);
  config.width = 1242;
  config.height = 100000;
  EXPECT_THROW(make_street_world(config), ConfigError);
  config.height = 375;
  config.baseline_m = -1.0;
  EXPECT_THROW(make_street_world(config), ConfigError);
}

// --- the written sequence ------------------------------------------------------------------------

/// Reads whitespace-separated numbers per line.
std::vector<std::vector<double>> read_numbers(const std::filesystem::path& path,
                                              bool skip_label = false) {
  std::ifstream in(path);
  std::vector<std::vector<double>> rows;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    if (skip_label) {
      std::string label;
      fields >> label;
    }
    std::vector<double> row;
    double value;
    while (fields >> value) row.push_back(value);
    rows.push_back(row);
  }
  return rows;
}

TEST(KittiWriters, PosesRoundTripThroughTheTextFormat) {
  test::ScratchDir dir;
  const SyntheticWorld world = small_street(9, 30);
  write_kitti_poses(dir / "poses.txt", world.trajectory);
  const auto rows = read_numbers(dir / "poses.txt");
  ASSERT_EQ(rows.size(), world.trajectory.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].size(), 12u);
    const Pose parsed = pose_from_3x4(rows[i].data(), "test");
    EXPECT_TRUE(parsed.isApprox(world.trajectory[i], 1e-8)) << "pose " << i;
  }
}

TEST(KittiWriters, UnwritablePathThrowsStorageError) {
  test::ScratchDir dir;
  std::ofstream(dir / "file") << "x";
  EXPECT_THROW(write_kitti_poses(dir / "file" / "poses.txt", {Pose::Identity()}), StorageError);
  EXPECT_THROW(write_kitti_times(dir / "file" / "times.txt", {0.0}), StorageError);
}

TEST(WriteSequence, WritesKittiLayoutWithGroundTruthAndScene) {
  test::ScratchDir dir;
  const SyntheticWorld world = small_street(13, 4);
  std::vector<std::size_t> progress;
  const SequenceStats stats = write_sequence(
      world, dir.path(), [&](std::size_t done, std::size_t) { progress.push_back(done); });
  EXPECT_EQ(stats.frames, 4u);
  EXPECT_EQ(progress, (std::vector<std::size_t>{1, 2, 3, 4}));
  EXPECT_EQ(stats.surfaces, world.surfaces.size());

  // Images and ground truth of frame 3 equal a fresh render (disparity within PNG 1/256 px).
  const SyntheticView view = render_view(world, world.trajectory[3], 3);
  EXPECT_EQ(cv::norm(read_image(dir / "image_2" / "000003.png"), view.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(read_image(dir / "image_3" / "000003.png"), view.right, cv::NORM_INF), 0.0);
  const cv::Mat ids = read_image_unchanged(dir / "surface_0" / "000003.png");
  ASSERT_EQ(ids.type(), CV_16UC1);
  EXPECT_EQ(cv::norm(ids, view.surface_id, cv::NORM_INF), 0.0);
  const cv::Mat disparity = read_kitti_disparity(dir / "disp_occ_0" / "000003.png");
  const cv::Mat noc = read_kitti_disparity(dir / "disp_noc_0" / "000003.png");
  const cv::Mat noc_expected = non_occluded_disparity(view);
  EXPECT_EQ(cv::countNonZero(noc == noc), cv::countNonZero(noc_expected == noc_expected));
  EXPECT_LT(cv::countNonZero(noc == noc), cv::countNonZero(disparity == disparity));
  for (int v = 0; v < disparity.rows; v += 2)
    for (int u = 0; u < disparity.cols; u += 2) {
      const float d = view.disparity.at<float>(v, u), read = disparity.at<float>(v, u);
      if (std::isnan(d)) {
        ASSERT_TRUE(std::isnan(read));
      } else {
        ASSERT_NEAR(read, d, 0.5 / 256.0 + 1e-6);
      }
    }

  // calib.txt: P2 = K[I|0], P3 = K[I|−fx·B]; baseline = −P3[3]/fx.
  const auto calib = read_numbers(dir / "calib.txt", true);
  ASSERT_GE(calib.size(), 4u);
  EXPECT_NEAR(calib[2][0], world.camera.fx, 1e-9);
  EXPECT_NEAR(calib[2][2], world.camera.cx, 1e-9);
  EXPECT_NEAR(calib[2][6], world.camera.cy, 1e-9);
  EXPECT_NEAR(-calib[3][3] / calib[3][0], world.camera.baseline_m, 1e-9);
  // times.txt at 10 Hz, poses/00.txt one line per frame.
  const auto times = read_numbers(dir / "times.txt");
  ASSERT_EQ(times.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(times[i][0], 0.1 * i, 1e-9);
  EXPECT_EQ(read_numbers(dir / "poses" / "00.txt").size(), 4u);

  // scene.yaml holds every surface's exact plane and polygon: the GT of frame 3 back-projects
  // onto the plane read from the file.
  const auto surfaces = read_scene_surfaces(dir / "scene.yaml");
  ASSERT_EQ(surfaces.size(), world.surfaces.size());
  for (std::size_t i = 0; i < surfaces.size(); ++i) {
    EXPECT_EQ(surfaces[i].id, world.surfaces[i].id);
    EXPECT_EQ(surfaces[i].kind, world.surfaces[i].kind);
    EXPECT_TRUE(surfaces[i].plane.normal.isApprox(world.surfaces[i].plane.normal, 1e-9));
    EXPECT_NEAR(surfaces[i].plane.offset, world.surfaces[i].plane.offset,
                1e-9 * (1.0 + std::abs(world.surfaces[i].plane.offset)));
    EXPECT_EQ(surfaces[i].polygon.size(), world.surfaces[i].polygon.size());
  }
  std::size_t checked = 0;
  for (int v = 1; v < view.disparity.rows; v += 5)
    for (int u = 1; u < view.disparity.cols; u += 5) {
      const auto id = view.surface_id.at<std::uint16_t>(v, u);
      if (id == 0) continue;
      const Eigen::Vector3d p_cam =
          world.camera.back_project(u, v, view.disparity.at<float>(v, u));
      const Eigen::Vector3d p = world.trajectory[3] * p_cam;
      ASSERT_LE(std::abs(surfaces[id - 1].plane.signed_distance(p)), 1e-3 * p_cam.norm());
      ++checked;
    }
  EXPECT_GT(checked, 300u);
}

TEST(WriteSequence, UnwritableOutputThrowsStorageError) {
  test::ScratchDir dir;
  std::ofstream(dir / "file") << "x";
  const SyntheticWorld world = make_box_world(64, 32, 1, 1);
  EXPECT_THROW(write_sequence(world, dir / "file" / "seq"), StorageError);
}

TEST(SceneYaml, MissingOrMalformedFileThrowsInputError) {
  test::ScratchDir dir;
  EXPECT_THROW(read_scene_surfaces(dir / "missing.yaml"), InputError);
  std::ofstream(dir / "bad.yaml") << "surfaces:\n  - {id: 1, kind: spaceship}\n";
  EXPECT_THROW(read_scene_surfaces(dir / "bad.yaml"), InputError);
}

// --- the CLI -------------------------------------------------------------------------------------

TEST(SynthCommand, WritesASequenceAndRejectsBadOptions) {
  test::ScratchDir dir;
  std::string output;
  const std::string bin = test::planecell_binary();
  const auto out = (dir / "seq").string();
  ASSERT_EQ(test::run_command(bin + " synth --out " + out + " --frames 3 --width 160 --height 48 "
                                    "--seed 4",
                              &output),
            0)
      << output;
  EXPECT_TRUE(std::filesystem::exists(dir / "seq" / "image_3" / "000002.png"));
  EXPECT_TRUE(std::filesystem::exists(dir / "seq" / "scene.yaml"));
  EXPECT_EQ(read_image(dir / "seq" / "image_2" / "000000.png").cols, 160);
  EXPECT_NE(output.find("fps"), std::string::npos) << output;

  EXPECT_NE(test::run_command(bin + " synth --out " + out + " --frames 0", &output), 0);
  EXPECT_NE(output.find("frames"), std::string::npos) << output;
  EXPECT_NE(test::run_command(bin + " synth --out " + out + " --frames 2 --width 20", &output), 0);
  EXPECT_NE(output.find("width"), std::string::npos) << output;
  std::ofstream(dir / "file") << "x";
  EXPECT_NE(test::run_command(bin + " synth --out " + (dir / "file").string() + " --frames 2",
                              &output),
            0);
  EXPECT_NE(output.find("file"), std::string::npos) << output;
}

}  // namespace
}  // namespace planecell::io
