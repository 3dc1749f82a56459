/// Disparity I/O: PFM (both endiannesses, bottom-up rows, invalid values) and KITTI 16-bit PNG.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

/// Writes raw bytes: header text followed by floats in the given byte order.
void write_raw_pfm(const std::filesystem::path& path, const std::string& header,
                   const std::vector<float>& values, bool big_endian) {
  std::ofstream out(path, std::ios::binary);
  out << header;
  for (float v : values) {
    unsigned char bytes[4];
    std::memcpy(bytes, &v, 4);  // host is little-endian (x86-64)
    if (big_endian) std::swap(bytes[0], bytes[3]), std::swap(bytes[1], bytes[2]);
    out.write(reinterpret_cast<const char*>(bytes), 4);
  }
}

template <class Fn>
void expect_input_error_naming(Fn&& fn, const std::string& needle) {
  try {
    fn();
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(Pfm, RoundTripKeepsValuesRowOrderAndInvalid) {
  test::ScratchDir dir;
  cv::Mat d(3, 4, CV_32F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) d.at<float>(r, c) = 10.0f * r + c + 0.125f;
  d.at<float>(1, 2) = kNaN;
  write_pfm(dir / "d.pfm", d);
  const cv::Mat back = read_pfm(dir / "d.pfm");
  ASSERT_EQ(back.size(), d.size());
  ASSERT_EQ(back.type(), CV_32F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      if (r == 1 && c == 2)
        EXPECT_TRUE(std::isnan(back.at<float>(r, c)));
      else
        EXPECT_EQ(back.at<float>(r, c), d.at<float>(r, c)) << r << "," << c;
    }
}

TEST(Pfm, ReadsAHandWrittenBigEndianFile) {
  test::ScratchDir dir;
  // 2×2, positive scale = big-endian, rows stored bottom-up: bottom row (3, 4) first.
  write_raw_pfm(dir / "be.pfm", "Pf\n2 2\n1.0\n", {3.0f, 4.0f, 1.0f, 2.5f}, true);
  const cv::Mat d = read_pfm(dir / "be.pfm");
  ASSERT_EQ(d.rows, 2);
  ASSERT_EQ(d.cols, 2);
  EXPECT_EQ(d.at<float>(0, 0), 1.0f);
  EXPECT_EQ(d.at<float>(0, 1), 2.5f);
  EXPECT_EQ(d.at<float>(1, 0), 3.0f);
  EXPECT_EQ(d.at<float>(1, 1), 4.0f);
}

TEST(Pfm, LittleEndianInfinityZeroAndNegativeBecomeNaN) {
  test::ScratchDir dir;
  write_raw_pfm(dir / "le.pfm", "Pf\n3 1\n-1.0\n", {kInf, 0.0f, -2.0f}, false);
  const cv::Mat d = read_pfm(dir / "le.pfm");
  ASSERT_EQ(d.cols, 3);
  for (int c = 0; c < 3; ++c) EXPECT_TRUE(std::isnan(d.at<float>(0, c))) << c;
  // Colour PF: the first channel is the disparity.
  write_raw_pfm(dir / "rgb.pfm", "PF\n2 1\n-1.0\n", {5.0f, 99.0f, 99.0f, 6.0f, 99.0f, 99.0f},
                false);
  const cv::Mat rgb = read_pfm(dir / "rgb.pfm");
  ASSERT_EQ(rgb.cols, 2);
  EXPECT_EQ(rgb.at<float>(0, 0), 5.0f);
  EXPECT_EQ(rgb.at<float>(0, 1), 6.0f);
}

TEST(Pfm, TruncatedGarbageAndMissingFilesAreNamed) {
  test::ScratchDir dir;
  write_raw_pfm(dir / "short.pfm", "Pf\n4 4\n-1.0\n", {1.0f, 2.0f, 3.0f}, false);
  expect_input_error_naming([&] { read_pfm(dir / "short.pfm"); }, "short.pfm");
  expect_input_error_naming([&] { read_pfm(dir / "short.pfm"); }, "truncated");
  std::ofstream(dir / "garbage.pfm") << "hello world, not a PFM";
  expect_input_error_naming([&] { read_pfm(dir / "garbage.pfm"); }, "garbage.pfm");
  std::ofstream(dir / "header.pfm") << "Pf\nwide tall\n-1\n";
  expect_input_error_naming([&] { read_pfm(dir / "header.pfm"); }, "header.pfm");
  std::ofstream(dir / "zero.pfm") << "Pf\n0 5\n-1\n";
  expect_input_error_naming([&] { read_pfm(dir / "zero.pfm"); }, "zero.pfm");
  expect_input_error_naming([&] { read_pfm(dir / "absent.pfm"); }, "absent.pfm");
}

TEST(KittiDisparityPng, RoundTripIsExactOnTheQuarterPixelGrid) {
  test::ScratchDir dir;
  // value = round(d·256): 12.5 → 3200, 1/256 → 1, 65535/256 → 65535; NaN and ≤ 0 → 0.
  cv::Mat d(1, 6, CV_32F);
  d.at<float>(0, 0) = 12.5f;
  d.at<float>(0, 1) = 1.0f / 256.0f;
  d.at<float>(0, 2) = 65535.0f / 256.0f;
  d.at<float>(0, 3) = kNaN;
  d.at<float>(0, 4) = -3.0f;
  d.at<float>(0, 5) = 10.001f;  // rounds to 2560 → 10.0
  write_kitti_disparity(dir / "d.png", d);
  const cv::Mat raw = read_image_unchanged(dir / "d.png");
  ASSERT_EQ(raw.type(), CV_16UC1);
  EXPECT_EQ(raw.at<std::uint16_t>(0, 0), 3200);
  EXPECT_EQ(raw.at<std::uint16_t>(0, 1), 1);
  EXPECT_EQ(raw.at<std::uint16_t>(0, 2), 65535);
  EXPECT_EQ(raw.at<std::uint16_t>(0, 3), 0);
  EXPECT_EQ(raw.at<std::uint16_t>(0, 4), 0);
  EXPECT_EQ(raw.at<std::uint16_t>(0, 5), 2560);
  const cv::Mat back = read_disparity(dir / "d.png");
  EXPECT_EQ(back.at<float>(0, 0), 12.5f);
  EXPECT_EQ(back.at<float>(0, 1), 1.0f / 256.0f);
  EXPECT_EQ(back.at<float>(0, 2), 65535.0f / 256.0f);
  EXPECT_TRUE(std::isnan(back.at<float>(0, 3)));
  EXPECT_TRUE(std::isnan(back.at<float>(0, 4)));
  EXPECT_EQ(back.at<float>(0, 5), 10.0f);
}

TEST(KittiDisparityPng, RejectsAn8BitImageAndUnknownExtensions) {
  test::ScratchDir dir;
  write_image(dir / "gray.png", cv::Mat(4, 4, CV_8UC1, cv::Scalar(7)));
  expect_input_error_naming([&] { read_kitti_disparity(dir / "gray.png"); }, "16-bit");
  expect_input_error_naming([&] { read_disparity(dir / "d.txt"); }, "d.txt");
  EXPECT_THROW(write_disparity(dir / "d.txt", cv::Mat(2, 2, CV_32F, cv::Scalar(1))), StorageError);
  EXPECT_THROW(write_pfm(dir / "bad.pfm", cv::Mat(2, 2, CV_8U, cv::Scalar(1))), StorageError);
}

TEST(Colourise, InvalidPixelsAreBlackValidOnesAreNot) {
  cv::Mat d(1, 3, CV_32F);
  d.at<float>(0, 0) = kNaN;
  d.at<float>(0, 1) = 20.0f;
  d.at<float>(0, 2) = 0.0f;
  const cv::Mat colour = colourise_disparity(d, 64.0f);
  ASSERT_EQ(colour.type(), CV_8UC3);
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));
  EXPECT_EQ(colour.at<cv::Vec3b>(0, 2), cv::Vec3b(0, 0, 0));
  EXPECT_NE(colour.at<cv::Vec3b>(0, 1), cv::Vec3b(0, 0, 0));
}

TEST(RealData, SceneFlowPfmMatchesItsDocumentedRange) {
  const auto path = test::shared_data("sceneflow_sample/disparity/left/A-0032-0006.pfm");
  if (!path) GTEST_SKIP() << "shared data absent";
  const cv::Mat d = read_disparity(*path);
  ASSERT_EQ(d.cols, 960);
  ASSERT_EQ(d.rows, 540);
  EXPECT_EQ(cv::countNonZero(d == d), 960 * 540);  // all finite (no NaN)
  double lo = 0, hi = 0;
  cv::minMaxLoc(d, &lo, &hi);
  EXPECT_NEAR(lo, 1.21, 0.01);
  EXPECT_NEAR(hi, 130.36, 0.01);
}

TEST(RealData, Kitti2015GroundTruthMatchesItsDocumentedRange) {
  const auto path = test::shared_data("kitti2015/training/disp_occ_0/000000_10.png");
  if (!path) GTEST_SKIP() << "shared data absent";
  const cv::Mat d = read_disparity(*path);
  ASSERT_EQ(d.cols, 1242);
  ASSERT_EQ(d.rows, 375);
  double hi = 0;
  cv::minMaxLoc(d, nullptr, &hi, nullptr, nullptr, d == d);
  EXPECT_FLOAT_EQ(hi, 16406.0f / 256.0f);  // SOURCES.md: max raw value 16406
}

}  // namespace
}  // namespace planecell::io
