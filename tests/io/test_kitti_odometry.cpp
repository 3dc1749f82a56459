/// KITTI odometry readers: calib.txt, poses, times.txt, the sequence layout and pose lookup.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"
#include "support/expect_error.hpp"
#include "support/test_data.hpp"
#include "support/text_files.hpp"

namespace planecell::io {
namespace {

using test::write_text;

namespace fs = std::filesystem;

constexpr double kFx = 718.856;
constexpr double kCx = 607.1928;
constexpr double kCy = 185.2157;
constexpr double kBaselineGray = 0.5371657;  // −P1[3]/fx = 386.1448 / 718.856
constexpr double kCam2OffsetM = 0.06;        // P2[3] = fx·0.06 → cam2 sits 6 cm left of cam0

/// calib.txt with KITTI seq 00 intrinsics; cam2/cam3 = cam0 shifted by 6 cm (P2[3] = fx·0.06).
std::string calib_text() {
  return "P0: 7.188560e+02 0 6.071928e+02 0 0 7.188560e+02 1.852157e+02 0 0 0 1 0\n"
         "P1: 7.188560e+02 0 6.071928e+02 -3.861448e+02 0 7.188560e+02 1.852157e+02 0 0 0 1 0\n"
         "P2: 7.188560e+02 0 6.071928e+02 43.13136 0 7.188560e+02 1.852157e+02 0 0 0 1 0\n"
         "P3: 7.188560e+02 0 6.071928e+02 -343.01344 0 7.188560e+02 1.852157e+02 0 0 0 1 0\n"
         "Tr: 1 0 0 0 0 1 0 0 0 0 1 0\n";
}

using test::input_error_of;


/// A small KITTI-layout sequence: `frames` 8×6 pairs, calib.txt, times.txt, and cam0 poses that
/// drive 1 m forward per frame while turning 90° about y at frame 1.
struct SequenceFixture {
  test::ScratchDir scratch;
  fs::path seq;
  std::vector<Pose> cam0_poses;

  explicit SequenceFixture(int frames = 3, const std::string& pair = "23") {
    seq = scratch / "dataset" / "sequences" / "07";
    for (int i = 0; i < frames; ++i) {
      char name[16];
      std::snprintf(name, sizeof name, "%06d.png", i);
      write_image(seq / ("image_" + pair.substr(0, 1)) / name, cv::Mat(6, 8, CV_8UC1, cv::Scalar(10 * i)));
      write_image(seq / ("image_" + pair.substr(1, 1)) / name, cv::Mat(6, 8, CV_8UC1, cv::Scalar(10 * i + 1)));
      Pose pose = Pose::Identity();
      if (i == 1) pose.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
      pose.translation() = Eigen::Vector3d(0, 0, i);
      cam0_poses.push_back(pose);
    }
    write_text(seq / "calib.txt", calib_text());
    std::string times;
    for (int i = 0; i < frames; ++i) times += std::to_string(0.1 * i) + "\n";
    write_text(seq / "times.txt", times);
  }

  std::string poses_text(int count) const {
    std::string text;
    for (int i = 0; i < count; ++i) {
      const auto& m = cam0_poses[i].matrix();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) text += std::to_string(m(r, c)) + (r == 2 && c == 3 ? "\n" : " ");
    }
    return text;
  }
};

TEST(KittiCalibration, ReadsProjectionsAndBuildsBothPairs) {
  test::ScratchDir dir;
  write_text(dir / "calib.txt", calib_text());
  const KittiCalibration calib = read_kitti_calibration(dir / "calib.txt");
  EXPECT_DOUBLE_EQ(calib.projection[1][3], -386.1448);
  EXPECT_DOUBLE_EQ(calib.projection[2][3], 43.13136);

  const StereoCamera gray = stereo_camera_from_kitti(calib, 0, 1241, 376);
  EXPECT_DOUBLE_EQ(gray.fx, kFx);
  EXPECT_DOUBLE_EQ(gray.fy, kFx);
  EXPECT_DOUBLE_EQ(gray.cx, kCx);
  EXPECT_DOUBLE_EQ(gray.cy, kCy);
  EXPECT_NEAR(gray.baseline_m, kBaselineGray, 1e-7);
  EXPECT_EQ(gray.width, 1241);
  EXPECT_EQ(gray.height, 376);
  // Colour pair: (43.13136 + 343.01344) / 718.856 = 0.5371657 as well.
  const StereoCamera colour = stereo_camera_from_kitti(calib, 2, 1241, 376);
  EXPECT_NEAR(colour.baseline_m, 386.1448 / kFx, 1e-9);
  EXPECT_THROW(stereo_camera_from_kitti(calib, 1, 10, 10), InputError);
}

TEST(KittiCalibration, ReadsTheRectifiedProjectionsOfKittiRawCamToCam) {
  test::ScratchDir dir;
  // The layout of KITTI raw's calib_cam_to_cam.txt (other keys, some with colons in the value).
  std::string text = "calib_time: 09-Jan-2012 13:57:47\ncorner_dist: 9.950000e-02\n";
  const double tx[4] = {0.0, -387.5744, 44.85728, -339.5242};
  for (int k = 0; k < 4; ++k) {
    const std::string n = "0" + std::to_string(k);
    text += "S_" + n + ": 1.392000e+03 5.120000e+02\n";
    text += "R_rect_" + n + ": 1 0 0 0 1 0 0 0 1\n";
    text += "P_rect_" + n + ": 721.5377 0 609.5593 " + std::to_string(tx[k]) +
            " 0 721.5377 172.854 0 0 0 1 0\n";
  }
  write_text(dir / "calib_cam_to_cam.txt", text);
  const KittiCalibration calib = read_kitti_calibration(dir / "calib_cam_to_cam.txt");
  EXPECT_DOUBLE_EQ(calib.projection[3][3], -339.5242);
  const StereoCamera colour = stereo_camera_from_kitti(calib, 2, 1242, 375);
  EXPECT_DOUBLE_EQ(colour.fx, 721.5377);
  EXPECT_DOUBLE_EQ(colour.cy, 172.854);
  EXPECT_NEAR(colour.baseline_m, (44.85728 + 339.5242) / 721.5377, 1e-9);  // 0.5327 m
}

TEST(KittiCalibration, SwappedRowsGiveANegativeBaselineError) {
  test::ScratchDir dir;
  // P0 and P1 numbers swapped: the "right" camera is to the left.
  write_text(dir / "calib.txt",
             "P0: 718.856 0 607.1928 -386.1448 0 718.856 185.2157 0 0 0 1 0\n"
             "P1: 718.856 0 607.1928 0 0 718.856 185.2157 0 0 0 1 0\n"
             "P2: 718.856 0 607.1928 0 0 718.856 185.2157 0 0 0 1 0\n"
             "P3: 718.856 0 607.1928 -386.1448 0 718.856 185.2157 0 0 0 1 0\n");
  const auto calib = read_kitti_calibration(dir / "calib.txt");
  EXPECT_CONTAINS(input_error_of([&] { stereo_camera_from_kitti(calib, 0, 10, 10); }), "baseline");
  EXPECT_NO_THROW(stereo_camera_from_kitti(calib, 2, 10, 10));
}

TEST(KittiCalibration, MalformedFilesNameTheLine) {
  test::ScratchDir dir;
  const auto path = dir / "calib.txt";
  write_text(path, "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP1: 1 0 0 0 0 1 0 0 0 0 1 0\nP2: 1 0 0 0 0 1 0 0 0 0 1\n");
  std::string message = input_error_of([&] { read_kitti_calibration(path); });
  EXPECT_CONTAINS(message, "line 3");
  EXPECT_CONTAINS(message, "12 numbers");
  EXPECT_CONTAINS(message, "calib.txt");
  write_text(path, "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP1: 1 0 0 0 0 1 0 0 0 0 1 0\nP2: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_CONTAINS(input_error_of([&] { read_kitti_calibration(path); }), "P3");
  write_text(path, "P0: 1 0 0 zero 0 1 0 0 0 0 1 0\n");
  EXPECT_CONTAINS(input_error_of([&] { read_kitti_calibration(path); }), "line 1");
  write_text(path, "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP0: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_CONTAINS(input_error_of([&] { read_kitti_calibration(path); }), "twice");
  EXPECT_CONTAINS(input_error_of([&] { read_kitti_calibration(dir / "none.txt"); }), "none.txt");
}

TEST(KittiCalibration, DifferentIntrinsicsAreNotARectifiedPair) {
  KittiCalibration calib;
  for (auto& p : calib.projection) p = {700, 0, 600, 0, 0, 700, 180, 0, 0, 0, 1, 0};
  calib.projection[1][3] = -350.0;
  EXPECT_NEAR(stereo_camera_from_kitti(calib, 0, 0, 0).baseline_m, 0.5, 1e-12);
  calib.projection[1][6] = 181.0;  // cy differs
  EXPECT_CONTAINS(input_error_of([&] { stereo_camera_from_kitti(calib, 0, 0, 0); }), "rectified");
  calib.projection[1][6] = 180.0;
  calib.projection[1][1] = 0.5;  // skew
  EXPECT_THROW(stereo_camera_from_kitti(calib, 0, 0, 0), InputError);
}

TEST(KittiPoses, ReadsRowsAndNamesBadLines) {
  test::ScratchDir dir;
  const auto path = dir / "poses.txt";
  write_text(path,
             "1 0 0 0 0 1 0 0 0 0 1 0\n"
             "0 -1 0 1.5 1 0 0 -2 0 0 1 3.25\n");
  const auto poses = read_kitti_poses(path);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_TRUE(poses[0].isApprox(Pose::Identity()));
  EXPECT_EQ(poses[1].translation(), Eigen::Vector3d(1.5, -2, 3.25));
  EXPECT_EQ(poses[1].linear()(0, 1), -1.0);

  write_text(path, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n");
  std::string message = input_error_of([&] { read_kitti_poses(path); });
  EXPECT_CONTAINS(message, "line 2");
  EXPECT_CONTAINS(message, "got 11");
  write_text(path, "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 nan 0 1 0 0 0 0 1 0\n");
  EXPECT_CONTAINS(input_error_of([&] { read_kitti_poses(path); }), "line 2");
  write_text(path, "2 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_CONTAINS(input_error_of([&] { read_kitti_poses(path); }), "orthonormal");
  write_text(path, "1 0 0 0 0 1 0 0 0 0 1 0\n\n1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_CONTAINS(input_error_of([&] { read_kitti_poses(path); }), "line 2");
}

TEST(KittiTimes, ReadsSecondsAndRejectsBadRows) {
  test::ScratchDir dir;
  const auto path = dir / "times.txt";
  write_text(path, "0.000000e+00\n1.037359e-01\n2.073381e-01\n\n");
  const auto times = read_kitti_times(path);
  ASSERT_EQ(times.size(), 3u);
  EXPECT_DOUBLE_EQ(times[1], 0.1037359);
  write_text(path, "0\n0.1\nabc\n");
  EXPECT_CONTAINS(input_error_of([&] { read_kitti_times(path); }), "line 3");
  write_text(path, "0\n0.2\n0.1\n");
  EXPECT_CONTAINS(input_error_of([&] { read_kitti_times(path); }), "backwards");
}

TEST(KittiSequence, OpensTheColourPairAndMovesPosesToCam2) {
  SequenceFixture f;
  write_text(f.seq / ".." / ".." / "poses" / "07.txt", f.poses_text(3));  // official layout
  const auto seq = open_kitti_odometry(f.seq);
  ASSERT_EQ(seq.size(), 3u);
  EXPECT_EQ(seq.left_dir.filename(), "image_2");
  EXPECT_EQ(seq.camera.width, 8);
  EXPECT_EQ(seq.camera.height, 6);
  EXPECT_NEAR(seq.camera.baseline_m, kBaselineGray, 1e-7);
  EXPECT_NEAR((seq.T_cam0_left.translation() - Eigen::Vector3d(-kCam2OffsetM, 0, 0)).norm(), 0, 1e-9);
  ASSERT_EQ(seq.times_s.size(), 3u);
  ASSERT_EQ(seq.poses.size(), 3u);
  // Frame 0: identity cam0 → cam2 at x = −0.06. Frame 1: cam0 at (0,0,1) turned 90° about y,
  // so the cam2 offset (−0.06, 0, 0) becomes R·(−0.06, 0, 0) = (0, 0, +0.06).
  EXPECT_NEAR((seq.poses[0].translation() - Eigen::Vector3d(-0.06, 0, 0)).norm(), 0, 1e-6);
  EXPECT_NEAR((seq.poses[1].translation() - Eigen::Vector3d(0, 0, 1.06)).norm(), 0, 1e-6);
  EXPECT_TRUE(seq.poses[1].linear().isApprox(f.cam0_poses[1].linear(), 1e-6));

  const StereoFrame frame = load_kitti_frame(seq, 2);
  EXPECT_EQ(frame.frame_id, 2u);
  EXPECT_EQ(frame.left.type(), CV_8UC3);
  EXPECT_EQ(frame.left.at<cv::Vec3b>(0, 0), cv::Vec3b(20, 20, 20));
  EXPECT_EQ(frame.right.at<cv::Vec3b>(5, 7), cv::Vec3b(21, 21, 21));
  EXPECT_NEAR(frame.timestamp_s, 0.2, 1e-9);
  ASSERT_TRUE(frame.pose.has_value());
  EXPECT_NEAR((frame.pose->translation() - Eigen::Vector3d(-0.06, 0, 2)).norm(), 0, 1e-6);
  EXPECT_CONTAINS(input_error_of([&] { load_kitti_frame(seq, 3); }), "out of range");
}

TEST(KittiSequence, FallsBackToTheGrayPair) {
  SequenceFixture f(2, "01");
  const auto seq = open_kitti_odometry(f.seq);
  EXPECT_EQ(seq.left_dir.filename(), "image_0");
  EXPECT_TRUE(seq.T_cam0_left.isApprox(Pose::Identity()));
  EXPECT_TRUE(seq.poses.empty());  // no pose file anywhere: allowed
}

TEST(KittiSequence, PoseLookupOrder) {
  SequenceFixture f;
  EXPECT_FALSE(find_kitti_poses_file(f.seq).has_value());
  write_text(f.seq / ".." / ".." / "poses" / "07.txt", f.poses_text(3));
  EXPECT_EQ(find_kitti_poses_file(f.seq)->filename(), "07.txt");
  EXPECT_EQ(find_kitti_poses_file(f.seq)->parent_path().parent_path().filename(), "dataset");
  write_text(f.seq / "poses" / "mine.txt", f.poses_text(3));  // the only *.txt in SEQ/poses
  EXPECT_EQ(find_kitti_poses_file(f.seq)->filename(), "mine.txt");
  write_text(f.seq / "poses" / "00.txt", f.poses_text(3));
  EXPECT_EQ(*find_kitti_poses_file(f.seq), f.seq / "poses" / "00.txt");
  write_text(f.seq / "poses" / "07.txt", f.poses_text(3));
  EXPECT_EQ(*find_kitti_poses_file(f.seq), f.seq / "poses" / "07.txt");
  // An explicit file wins; a missing explicit file is an error.
  write_text(f.scratch / "explicit.txt", f.poses_text(2) + "1 0 0 0 0 1 0 0 0 0 1 9\n");
  const auto seq = open_kitti_odometry(f.seq, f.scratch / "explicit.txt");
  EXPECT_NEAR(seq.poses[2].translation().z(), 9.0, 1e-9);
  EXPECT_CONTAINS(input_error_of([&] { open_kitti_odometry(f.seq, f.scratch / "nope.txt"); }),
                  "nope.txt");
}

TEST(KittiSequence, InconsistentFoldersAreRejected) {
  {
    SequenceFixture f;
    write_text(f.seq / "poses" / "07.txt", f.poses_text(2));
    const std::string message = input_error_of([&] { open_kitti_odometry(f.seq); });
    EXPECT_CONTAINS(message, "2 poses");
    EXPECT_CONTAINS(message, "3 frames");
  }
  {
    SequenceFixture f;
    write_text(f.seq / "times.txt", "0\n0.1\n");
    EXPECT_CONTAINS(input_error_of([&] { open_kitti_odometry(f.seq); }), "times.txt");
  }
  {
    SequenceFixture f;
    fs::remove(f.seq / "image_3" / "000001.png");
    EXPECT_CONTAINS(input_error_of([&] { open_kitti_odometry(f.seq); }), "000001.png");
  }
  {
    SequenceFixture f;
    fs::remove(f.seq / "calib.txt");
    EXPECT_CONTAINS(input_error_of([&] { open_kitti_odometry(f.seq); }), "calib.txt");
  }
  {
    SequenceFixture f;
    fs::remove_all(f.seq / "image_3");
    EXPECT_CONTAINS(input_error_of([&] { open_kitti_odometry(f.seq); }), "stereo pair");
  }
  {
    SequenceFixture f;
    write_image(f.seq / "image_3" / "000002.png", cv::Mat(7, 8, CV_8UC1, cv::Scalar(0)));
    const auto seq = open_kitti_odometry(f.seq);
    EXPECT_CONTAINS(input_error_of([&] { load_kitti_frame(seq, 2); }), "000002.png");
  }
  EXPECT_CONTAINS(input_error_of([] { open_kitti_odometry("/nonexistent/seq"); }), "/nonexistent/seq");
}

TEST(RealData, KittiSequence00PosesAndTimes) {
  const auto root = test::shared_data("kitti_odometry");
  if (!root) GTEST_SKIP() << "shared data absent";
  const auto poses = read_kitti_poses(*root / "poses" / "00.txt");
  ASSERT_EQ(poses.size(), 4541u);
  EXPECT_TRUE(poses.front().isApprox(Pose::Identity(), 1e-6));
  // Line 2 of 00.txt: "... -4.690294e-02 ... -2.839928e-02 ... 8.586941e-01" (t_x, t_y, t_z).
  EXPECT_DOUBLE_EQ(poses[1].translation().x(), -4.690294e-02);
  EXPECT_DOUBLE_EQ(poses[1].translation().y(), -2.839928e-02);
  EXPECT_DOUBLE_EQ(poses[1].translation().z(), 8.586941e-01);
  // Last line: t = (−5.583931, −3.562758, 96.96153).
  EXPECT_DOUBLE_EQ(poses.back().translation().z(), 9.696153e+01);
  const auto times = read_kitti_times(*root / "sequences" / "00" / "times.txt");
  ASSERT_EQ(times.size(), 4541u);
  EXPECT_DOUBLE_EQ(times[0], 0.0);
  EXPECT_DOUBLE_EQ(times[2], 2.073381e-01);
  EXPECT_DOUBLE_EQ(times.back(), 4.705816e+02);
  // The official layout puts the poses at dataset/poses/00.txt beside dataset/sequences/00.
  const auto found = find_kitti_poses_file(*root / "sequences" / "00");
  ASSERT_TRUE(found.has_value());
  EXPECT_TRUE(fs::equivalent(*found, *root / "poses" / "00.txt"));
}

}  // namespace
}  // namespace planecell::io
