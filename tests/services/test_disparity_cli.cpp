/// `planecell disparity` and `planecell eval-stereo` end to end: exit codes and outputs.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgproc.hpp>

#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "support/test_data.hpp"

namespace planecell {
namespace {

using test::planecell_binary;
using test::run_command;

/// Right = random texture, left = the same shifted by 7 px (true disparity 7).
void write_shifted_pair(const test::ScratchDir& dir, int width = 120, int height = 60) {
  cv::Mat texture(height, width + 20, CV_8UC3);
  cv::randu(texture, 0, 255);
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 0.8);
  io::write_image(dir / "left.png", texture(cv::Rect(3, 0, width, height)));
  io::write_image(dir / "right.png", texture(cv::Rect(10, 0, width, height)));
}

TEST(DisparityCli, WritesPfmPngAndPreview) {
  test::ScratchDir dir;
  write_shifted_pair(dir);
  std::string output;
  const std::string base = planecell_binary() + " disparity " + (dir / "left.png").string() + " " +
                           (dir / "right.png").string() + " --max-disparity 32";
  ASSERT_EQ(run_command(base + " -o " + (dir / "d.pfm").string() + " --preview " +
                            (dir / "p.png").string(),
                        &output),
            0)
      << output;
  ASSERT_EQ(run_command(base + " -o " + (dir / "d.png").string(), &output), 0) << output;
  const cv::Mat pfm = io::read_disparity(dir / "d.pfm");
  const cv::Mat png = io::read_disparity(dir / "d.png");
  ASSERT_EQ(pfm.size(), cv::Size(120, 60));
  int good = 0, total = 0;
  for (int y = 0; y < pfm.rows; ++y)
    for (int x = 10; x < pfm.cols; ++x, ++total) {
      const float d = pfm.at<float>(y, x);
      if (!std::isnan(d) && std::abs(d - 7.0f) <= 0.5f) ++good;
      // KITTI PNG stores round(256·d): the same map within 1/512 px.
      if (!std::isnan(d)) {
        EXPECT_NEAR(png.at<float>(y, x), d, 1.0 / 500);
      }
    }
  EXPECT_GE(good, 0.95 * total);
  const cv::Mat preview = io::read_image(dir / "p.png");
  EXPECT_EQ(preview.size(), pfm.size());
}

TEST(DisparityCli, BadInputGivesClearErrorsAndExitCodes) {
  test::ScratchDir dir;
  write_shifted_pair(dir);
  cv::Mat small(30, 50, CV_8UC3, cv::Scalar(1, 2, 3));
  io::write_image(dir / "small.png", small);
  const std::string left = (dir / "left.png").string(), right = (dir / "right.png").string();
  const std::string out = " -o " + (dir / "d.pfm").string();
  std::string output;
  // Mismatched sizes → input error (1), message names both files.
  EXPECT_EQ(run_command(planecell_binary() + " disparity " + left + " " + (dir / "small.png").string() +
                            out + " --max-disparity 16",
                        &output),
            1);
  EXPECT_NE(output.find("small.png"), std::string::npos) << output;
  // Missing file → input error naming it.
  EXPECT_EQ(run_command(planecell_binary() + " disparity " + left + " " + (dir / "nope.png").string() + out,
                        &output),
            1);
  EXPECT_NE(output.find("nope.png"), std::string::npos) << output;
  // Unreadable (not an image) → input error.
  std::ofstream(dir / "junk.png") << "not a png";
  EXPECT_EQ(run_command(planecell_binary() + " disparity " + left + " " + (dir / "junk.png").string() + out,
                        &output),
            1);
  // max-disparity ≤ 0 or ≥ width → configuration error (2).
  for (const char* bad : {"0", "-4", "120", "500"}) {
    EXPECT_EQ(run_command(planecell_binary() + " disparity " + left + " " + right + out +
                              " --max-disparity " + bad,
                          &output),
              2)
        << bad << ": " << output;
    EXPECT_NE(output.find("max_disparity"), std::string::npos) << output;
  }
  // Unknown output format → configuration error.
  EXPECT_EQ(run_command(planecell_binary() + " disparity " + left + " " + right + " -o " +
                            (dir / "d.tif").string() + " --max-disparity 16",
                        &output),
            2);
}

TEST(EvalStereoCli, RunsOnMiddleburyAndWritesJson) {
  const auto root = test::shared_data("middlebury/tsukuba");
  if (!root) GTEST_SKIP() << "shared data middlebury/tsukuba not present";
  test::ScratchDir dir;
  std::string output;
  const int code = run_command(planecell_binary() + " eval-stereo --dataset middlebury --root " +
                                   root->string() + " --json " + (dir / "m.json").string(),
                               &output);
  ASSERT_EQ(code, 0) << output;
  EXPECT_NE(output.find("planecell-sgm"), std::string::npos) << output;
  EXPECT_NE(output.find("opencv-sgbm"), std::string::npos) << output;
  std::ifstream json(dir / "m.json");
  const std::string text((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"bad2_pct\""), std::string::npos);
  EXPECT_NE(text.find("tsukuba"), std::string::npos);
}

TEST(EvalStereoCli, CalibGivesKittiPairsWithoutOneTheirThreeDimensionalAccuracy) {
  // A KITTI 2015 layout (image_2, image_3, disp_occ_0) without calibration, true disparity 7 px.
  test::ScratchDir dir;
  const auto training = dir / "training";
  std::filesystem::create_directories(training / "image_2");
  std::filesystem::create_directories(training / "image_3");
  std::filesystem::create_directories(training / "disp_occ_0");
  write_shifted_pair(dir, 160, 64);
  std::filesystem::rename(dir / "left.png", training / "image_2" / "000000_10.png");
  std::filesystem::rename(dir / "right.png", training / "image_3" / "000000_10.png");
  io::write_image(training / "disp_occ_0" / "000000_10.png", cv::Mat(64, 160, CV_16U, cv::Scalar(7 * 256)));
  std::ofstream(dir / "calib.txt") << "P0: 700 0 80 0 0 700 32 0 0 0 1 0\n"
                                      "P1: 700 0 80 -350 0 700 32 0 0 0 1 0\n"
                                      "P2: 700 0 80 0 0 700 32 0 0 0 1 0\n"
                                      "P3: 700 0 80 -350 0 700 32 0 0 0 1 0\n";
  auto eval_json = [&](const std::string& extra) {
    std::string output;
    const auto json_path = dir / "k.json";
    const int code = run_command(planecell_binary() + " eval-stereo --dataset kitti --root " +
                                     training.string() + " --json " + json_path.string() + extra,
                                 &output);
    EXPECT_EQ(code, 0) << output;
    std::ifstream json(json_path);
    return std::string((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
  };
  // Without a camera there is no 3D accuracy; with --calib (baseline 350 / 700 = 0.5 m, depth
  // 700 · 0.5 / 7 = 50 m) there is, and the planecell SGM points lie within 1 m of the GT points.
  EXPECT_EQ(eval_json("").find("\"points\""), std::string::npos);
  const std::string with_calib = eval_json(" --calib " + (dir / "calib.txt").string());
  const auto points = with_calib.find("\"points\"");
  ASSERT_NE(points, std::string::npos) << with_calib;
  const std::string key = "\"within_100cm_pct\": ";
  const auto within = with_calib.find(key, points);
  ASSERT_NE(within, std::string::npos);
  EXPECT_GT(std::stod(with_calib.substr(within + key.size())), 50.0) << with_calib;
  std::string output;
  EXPECT_NE(run_command(planecell_binary() + " eval-stereo --dataset kitti --root " + training.string() +
                            " --calib " + (dir / "missing.txt").string(),
                        &output),
            0);
}

TEST(EvalStereoCli, RejectsMissingRootAndBadDataset) {
  test::ScratchDir dir;
  std::string output;
  EXPECT_NE(run_command(planecell_binary() + " eval-stereo --dataset middlebury --root " +
                            (dir / "missing").string(),
                        &output),
            0);
  EXPECT_EQ(run_command(planecell_binary() + " eval-stereo --dataset nonsense --root " +
                            dir.path().string(),
                        &output),
            2)
      << output;
}

}  // namespace
}  // namespace planecell
