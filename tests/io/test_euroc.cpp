/// EuRoC reader: sensor.yaml, ground truth (TUM and EuRoC csv), time alignment, rectification.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <sstream>

#include "core/error.hpp"
#include "io/euroc.hpp"
#include "io/euroc_to_kitti.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"
#include "support/expect_error.hpp"
#include "support/test_data.hpp"
#include "support/text_files.hpp"

namespace planecell::io {
namespace {

using test::write_text;

namespace fs = std::filesystem;


using test::input_error_of;

std::string matrix_text(const Pose& pose) {
  std::ostringstream text;
  text.precision(17);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) text << pose.matrix()(r, c) << (r == 3 && c == 3 ? "" : ", ");
  return text.str();
}

/// A sensor.yaml as EuRoC ships it (OpenCV's "%YAML:1.0" first line included).
std::string sensor_yaml(const Pose& T_BS, const std::string& intrinsics = "[458.654, 457.296, 367.215, 248.375]",
                        const std::string& distortion = "[-0.28, 0.07, 0.0002, 1.7e-05]",
                        const std::string& model = "radial-tangential") {
  return "%YAML:1.0\nsensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n  data: [" + matrix_text(T_BS) +
         "]\nrate_hz: 20\nresolution: [64, 48]\ncamera_model: pinhole\nintrinsics: " + intrinsics +
         " #fu, fv, cu, cv\ndistortion_model: " + model + "\ndistortion_coefficients: " + distortion + "\n";
}

Pose pose_of(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  Pose pose = Pose::Identity();
  pose.linear() = rotation;
  pose.translation() = translation;
  return pose;
}

TEST(EurocCamera, ParsesSensorYamlWithOpenCvDirective) {
  test::ScratchDir dir;
  const Pose T_BS = pose_of(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                            Eigen::Vector3d(-0.02, -0.06, 0.01));
  write_text(dir / "sensor.yaml", sensor_yaml(T_BS));
  const EurocCameraCalibration calib = read_euroc_camera(dir / "sensor.yaml");
  EXPECT_DOUBLE_EQ(calib.K.at<double>(0, 0), 458.654);
  EXPECT_DOUBLE_EQ(calib.K.at<double>(1, 1), 457.296);
  EXPECT_DOUBLE_EQ(calib.K.at<double>(0, 2), 367.215);
  EXPECT_DOUBLE_EQ(calib.K.at<double>(1, 2), 248.375);
  ASSERT_EQ(calib.distortion.total(), 4u);
  EXPECT_DOUBLE_EQ(calib.distortion.at<double>(0, 3), 1.7e-05);
  EXPECT_EQ(calib.width, 64);
  EXPECT_EQ(calib.height, 48);
  EXPECT_TRUE(calib.T_body_sensor.isApprox(T_BS, 1e-6));
}

TEST(EurocCamera, MalformedSensorYamlIsNamed) {
  test::ScratchDir dir;
  const auto path = dir / "sensor.yaml";
  write_text(path, sensor_yaml(Pose::Identity(), "[458.654, 457.296, 367.215]"));
  EXPECT_CONTAINS(input_error_of([&] { read_euroc_camera(path); }), "intrinsics");
  write_text(path, sensor_yaml(Pose::Identity(), "[458.654, 457.296, 367.215, 248.375]",
                               "[0.1, 0.2, 0.3, 0.4]", "equidistant"));
  EXPECT_CONTAINS(input_error_of([&] { read_euroc_camera(path); }), "equidistant");
  write_text(path, sensor_yaml(Pose::Identity(), "[458.654, 457.296, 367.215, cv]"));
  EXPECT_CONTAINS(input_error_of([&] { read_euroc_camera(path); }), "sensor.yaml");
  Pose not_rigid = Pose::Identity();
  not_rigid.matrix()(0, 0) = 2.0;
  write_text(path, sensor_yaml(not_rigid));
  EXPECT_CONTAINS(input_error_of([&] { read_euroc_camera(path); }), "T_BS");
  EXPECT_CONTAINS(input_error_of([&] { read_euroc_camera(dir / "absent.yaml"); }), "absent.yaml");
}

TEST(EurocGroundTruth, ReadsTumAndEurocCsvQuaternionOrders) {
  test::ScratchDir dir;
  const double s = std::sqrt(0.5);  // 90° about z
  write_text(dir / "gt.txt", "# timestamp(s) tx ty tz qx qy qz qw\n"
                             "1403715273.5 1 2 3 0 0 " + std::to_string(s) + " " + std::to_string(s) + "\n"
                             "1403715273.25 0 0 0 0 0 0 1\n");
  const auto tum = read_euroc_groundtruth(dir / "gt.txt");
  ASSERT_EQ(tum.size(), 2u);
  EXPECT_EQ(tum[0].timestamp_ns, 1403715273250000000);  // sorted by time
  EXPECT_EQ(tum[1].timestamp_ns, 1403715273500000000);  // exact: seconds parsed as decimal text
  EXPECT_TRUE(tum[1].pose.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  const Eigen::Vector3d x_turned = tum[1].pose.linear() * Eigen::Vector3d::UnitX();
  EXPECT_NEAR((x_turned - Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-6);

  write_text(dir / "data.csv", "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], "
                               "q_RS_y [], q_RS_z [], v_x, v_y, v_z\n"
                               "1403715273262142976,4,5,6," + std::to_string(s) + ",0,0," +
                                   std::to_string(s) + ",0.1,0.2,0.3\n");
  const auto csv = read_euroc_groundtruth(dir / "data.csv");
  ASSERT_EQ(csv.size(), 1u);
  EXPECT_EQ(csv[0].timestamp_ns, 1403715273262142976);
  EXPECT_NEAR((csv[0].pose.linear() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 0, 1e-6);

  write_text(dir / "bad.txt", "1 0 0 0 0 0 0 1\n2 0 0 0 0 0 1\n");
  const std::string message = input_error_of([&] { read_euroc_groundtruth(dir / "bad.txt"); });
  EXPECT_CONTAINS(message, "line 2");
  write_text(dir / "bad.txt", "1 0 0 0 0 0 0 0\n");  // zero quaternion
  EXPECT_CONTAINS(input_error_of([&] { read_euroc_groundtruth(dir / "bad.txt"); }), "quaternion");
}

TEST(EurocGroundTruth, TimesWithoutAnInt64NanosecondCountAreNamed) {
  test::ScratchDir dir;
  // 9 223 372 035 s is the last whole second whose nanoseconds fit an int64 (year 2262).
  write_text(dir / "gt.txt", "9223372035.5 0 0 0 0 0 0 1\n");
  EXPECT_EQ(read_euroc_groundtruth(dir / "gt.txt")[0].timestamp_ns, 9223372035500000000);
  write_text(dir / "gt.txt", "9223372036 0 0 0 0 0 0 1\n");
  EXPECT_CONTAINS(input_error_of([&] { read_euroc_groundtruth(dir / "gt.txt"); }), "outside");
  write_text(dir / "gt.txt", "1e300 0 0 0 0 0 0 1\n");
  EXPECT_CONTAINS(input_error_of([&] { read_euroc_groundtruth(dir / "gt.txt"); }), "outside");
  write_text(dir / "gt.txt", "-1.5e0 0 0 0 0 0 0 1\n");  // signed: double path, still exact here
  EXPECT_EQ(read_euroc_groundtruth(dir / "gt.txt")[0].timestamp_ns, -1500000000);

  write_text(dir / "gt.csv", "99999999999999999999,0,0,0,1,0,0,0\n");
  EXPECT_CONTAINS(input_error_of([&] { read_euroc_groundtruth(dir / "gt.csv"); }), "64 bits");
  write_text(dir / "gt.csv", "1.5e9,0,0,0,1,0,0,0\n");
  EXPECT_CONTAINS(input_error_of([&] { read_euroc_groundtruth(dir / "gt.csv"); }), "integer");
  write_text(dir / "gt.csv", "1403715273262142977,0,0,0,1,0,0,0\n");  // odd: not a double
  EXPECT_EQ(read_euroc_groundtruth(dir / "gt.csv")[0].timestamp_ns, 1403715273262142977);
}

TEST(EurocGroundTruth, NearestSampleWithin20Ms) {
  std::vector<StampedPose> trajectory(2);
  trajectory[0].timestamp_ns = 0;
  trajectory[1].timestamp_ns = 100'000'000;
  trajectory[1].pose.translation() = Eigen::Vector3d(1, 0, 0);
  auto x_at = [&](std::int64_t t) {
    const auto pose = nearest_pose(trajectory, t, kEurocMaxGroundTruthGapNs);
    return pose ? pose->translation().x() : -1.0;
  };
  EXPECT_EQ(x_at(15'000'000), 0.0);
  EXPECT_EQ(x_at(85'000'000), 1.0);
  EXPECT_EQ(x_at(115'000'000), 1.0);
  EXPECT_EQ(x_at(30'000'000), -1.0);   // 30 ms from both samples
  EXPECT_EQ(x_at(121'000'000), -1.0);  // 21 ms after the last
  EXPECT_EQ(x_at(-20'000'000), 0.0);
  EXPECT_FALSE(nearest_pose({}, 0, kEurocMaxGroundTruthGapNs).has_value());
}

/// A 64×48 EuRoC-layout folder: undistorted cameras, cam1 0.1 m to the right of cam0 and turned
/// by 2° about y, three stamps of which cam1 misses one, TUM ground truth for two of them.
struct EurocFixture {
  test::ScratchDir scratch;
  fs::path root;
  Pose T_BS0, T_BS1;
  EurocFixture() {
    root = scratch / "V0";
    const fs::path mav0 = root / "mav0";
    // Camera axes in the body frame as in EuRoC: x_cam ≈ y_body, y_cam ≈ −x_body, z_cam ≈ z_body.
    Eigen::Matrix3d R_BC;
    R_BC << 0, -1, 0, 1, 0, 0, 0, 0, 1;
    T_BS0 = pose_of(R_BC, Eigen::Vector3d(-0.02, -0.06, 0.01));
    const Pose T_cam0_cam1 =
        pose_of(Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix(),
                Eigen::Vector3d(0.1, 0.0, 0.0));
    T_BS1 = T_BS0 * T_cam0_cam1;
    const std::string k = "[60.0, 60.0, 32.0, 24.0]", d = "[0.0, 0.0, 0.0, 0.0]";
    write_text(mav0 / "cam0" / "sensor.yaml", sensor_yaml(T_BS0, k, d));
    write_text(mav0 / "cam1" / "sensor.yaml", sensor_yaml(T_BS1, k, d));
    std::string list0 = "#timestamp [ns],filename\n", list1 = list0;
    for (std::int64_t t : {1000000000LL, 1050000000LL, 1100000000LL}) {
      const std::string name = std::to_string(t) + ".png";
      cv::Mat image(48, 64, CV_8UC1);
      cv::randu(image, 0, 255);
      write_image(mav0 / "cam0" / "data" / name, image);
      list0 += std::to_string(t) + "," + name + "\n";
      if (t == 1050000000LL) continue;  // cam1 lacks this stamp
      write_image(mav0 / "cam1" / "data" / name, image);
      list1 += std::to_string(t) + "," + name + "\n";
    }
    list1 += "1150000000,1150000000.png\n";  // listed but absent (truncated copy)
    write_text(mav0 / "cam0" / "data.csv", list0);
    write_text(mav0 / "cam1" / "data.csv", list1);
    // Body 1 m along world x at t = 1.0 s; no sample near 1.1 s (30 ms away).
    write_text(root / "groundtruth" / "gt.txt", "1.0 1 0 0 0 0 0 1\n1.07 2 0 0 0 0 0 1\n");
  }
};

TEST(EurocSequence, RectifiesAndPosesTheRectifiedLeftCamera) {
  EurocFixture f;
  const EurocSequence seq = open_euroc(f.root);
  ASSERT_EQ(seq.size(), 2u);  // stamp 1.05 s has no cam1 image
  EXPECT_EQ(seq.timestamps_ns[1], 1100000000);
  EXPECT_EQ(seq.camera.width, 64);
  EXPECT_NEAR(seq.camera.baseline_m, 0.1, 1e-9);  // |t_cam1_cam0|
  EXPECT_DOUBLE_EQ(seq.camera.fx, seq.camera.fy);
  // The rectified left camera looks so that cam1's centre lies on its +x axis at B.
  const Eigen::Matrix3d& R = seq.R_rect_left;
  EXPECT_NEAR((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-9);
  const Eigen::Vector3d c1_in_cam0 = (f.T_BS0.inverse() * f.T_BS1).translation();
  EXPECT_NEAR((R * c1_in_cam0 - Eigen::Vector3d(0.1, 0, 0)).norm(), 0.0, 1e-9);

  // T_W_camrect = T_WB · T_BS0 · Rᵀ at t = 1.0 s; frame 1 (1.1 s) has no GT within 20 ms.
  ASSERT_TRUE(seq.poses[0].has_value());
  Pose T_WB = Pose::Identity();
  T_WB.translation() = Eigen::Vector3d(1, 0, 0);
  Pose rect = Pose::Identity();
  rect.linear() = R.transpose();
  EXPECT_TRUE(seq.poses[0]->isApprox(T_WB * f.T_BS0 * rect, 1e-9));
  EXPECT_FALSE(seq.poses[1].has_value());

  const StereoFrame frame = load_euroc_frame(seq, 0);
  EXPECT_EQ(frame.left.type(), CV_8UC3);
  EXPECT_EQ(frame.left.size(), cv::Size(64, 48));
  EXPECT_EQ(frame.right.size(), cv::Size(64, 48));
  EXPECT_DOUBLE_EQ(frame.timestamp_s, 1.0);
  EXPECT_CONTAINS(input_error_of([&] { load_euroc_frame(seq, 2); }), "out of range");
}

TEST(EurocToKitti, WritesThePosedPairsAsAKittiSequenceThatReadsBack) {
  EurocFixture f;
  const EurocSequence seq = open_euroc(f.root);
  const fs::path out = f.scratch / "kitti";
  const EurocExport written = write_euroc_as_kitti(seq, out);
  EXPECT_EQ(written.frames, 1u);          // 1.0 s has a pose; 1.1 s has none within 20 ms
  EXPECT_EQ(written.skipped_frames, 1u);
  const KittiOdometrySequence kitti = open_kitti_odometry(out);
  ASSERT_EQ(kitti.size(), 1u);
  EXPECT_NEAR(kitti.camera.fx, seq.camera.fx, 1e-6);
  EXPECT_NEAR(kitti.camera.cx, seq.camera.cx, 1e-6);
  EXPECT_NEAR(kitti.camera.cy, seq.camera.cy, 1e-6);
  EXPECT_NEAR(kitti.camera.baseline_m, 0.1, 1e-6);
  ASSERT_EQ(kitti.poses.size(), 1u);
  EXPECT_TRUE(kitti.poses[0].isApprox(Pose::Identity(), 1e-9));  // the first frame is the world
  ASSERT_EQ(written.poses.size(), 1u);  // what was written, handed back (for --pose-noise)
  EXPECT_TRUE(written.poses[0].isApprox(kitti.poses[0], 1e-12));
  const StereoFrame rectified = load_euroc_frame(seq, 0);
  const StereoFrame read = load_kitti_frame(kitti, 0);
  cv::Mat grey_rectified, grey_read;
  cv::extractChannel(rectified.left, grey_rectified, 0);
  cv::extractChannel(read.left, grey_read, 0);
  EXPECT_EQ(cv::norm(grey_rectified, grey_read, cv::NORM_INF), 0.0);  // lossless PNG

  // Without ground truth nothing can be written: a clear error naming the sequence.
  fs::remove_all(f.root / "groundtruth");
  const EurocSequence unposed = open_euroc(f.root);
  EXPECT_CONTAINS(input_error_of([&] { write_euroc_as_kitti(unposed, f.scratch / "none"); }),
                  "no stereo pair has a ground-truth pose");
}

TEST(EurocSequence, MissingPartsAreNamed) {
  {
    EurocFixture f;
    fs::remove(f.root / "mav0" / "cam1" / "sensor.yaml");
    EXPECT_CONTAINS(input_error_of([&] { open_euroc(f.root); }), "cam1");
  }
  {
    EurocFixture f;
    EXPECT_CONTAINS(input_error_of([&] { open_euroc(f.root, f.root / "nope.txt"); }), "nope.txt");
  }
  {
    EurocFixture f;
    write_text(f.root / "mav0" / "cam1" / "data.csv", "#timestamp [ns],filename\n5,x.png\n");
    EXPECT_CONTAINS(input_error_of([&] { open_euroc(f.root); }), "pair");
  }
  {
    EurocFixture f;
    write_text(f.root / "mav0" / "cam0" / "data.csv", "#timestamp [ns],filename\n1.5e9,x.png\n");
    const std::string message = input_error_of([&] { open_euroc(f.root); });
    EXPECT_CONTAINS(message, "cam0");
    EXPECT_CONTAINS(message, "line 2: timestamp '1.5e9' is not an integer");
  }
  EXPECT_CONTAINS(input_error_of([] { open_euroc("/no/euroc/here"); }), "/no/euroc/here");
}

/// Median |v_left − v_right| of cross-checked ORB matches between two gray images.
double median_row_difference(const cv::Mat& left, const cv::Mat& right, std::size_t* matches) {
  auto orb = cv::ORB::create(1500);
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  orb->detectAndCompute(left, cv::noArray(), kl, dl);
  orb->detectAndCompute(right, cv::noArray(), kr, dr);
  cv::BFMatcher matcher(cv::NORM_HAMMING, true);
  std::vector<cv::DMatch> found;
  matcher.match(dl, dr, found);
  std::vector<double> dv;
  for (const auto& m : found)
    if (m.distance < 40) dv.push_back(std::abs(kl[m.queryIdx].pt.y - kr[m.trainIdx].pt.y));
  *matches = dv.size();
  if (dv.empty()) return 1e9;
  std::nth_element(dv.begin(), dv.begin() + dv.size() / 2, dv.end());
  return dv[dv.size() / 2];
}

TEST(RealData, EurocV101MicroRectifiesToARowAlignedPair) {
  const auto root = test::shared_data("euroc/V1_01_easy_micro");
  if (!root) GTEST_SKIP() << "shared data absent";
  const EurocSequence seq = open_euroc(*root);
  EXPECT_EQ(seq.size(), 95u);
  EXPECT_NEAR(seq.camera.baseline_m, 0.110, 0.001);
  std::size_t with_pose = 0;
  for (const auto& pose : seq.poses)
    if (pose) {
      ++with_pose;
      EXPECT_NO_THROW(validate_pose(*pose, "EuRoC pose"));
    }
  EXPECT_EQ(with_pose, 95u);  // V101_gt.txt has a sample at every camera stamp

  const StereoFrame frame = load_euroc_frame(seq, 0);
  cv::Mat left_gray, right_gray;
  cv::extractChannel(frame.left, left_gray, 0);
  cv::extractChannel(frame.right, right_gray, 0);
  std::size_t rect_matches = 0, raw_matches = 0;
  const double rectified = median_row_difference(left_gray, right_gray, &rect_matches);
  const double raw = median_row_difference(read_image(seq.left_images[0], false),
                                           read_image(seq.right_images[0], false), &raw_matches);
  std::cout << "EuRoC frame 0: median |dv| raw " << raw << " px (" << raw_matches
            << " matches), rectified " << rectified << " px (" << rect_matches << " matches)\n";
  ASSERT_GT(rect_matches, 50u);
  EXPECT_LT(rectified, 1.0);
  // Measured 12.1 px on the raw pair: rectification is what aligns the rows.
  EXPECT_GT(raw, 5.0);
}

}  // namespace
}  // namespace planecell::io
