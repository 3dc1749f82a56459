/// Bad image and disparity files the readers must refuse before decoding allocates: headers that
/// claim huge sizes, images above a configured pixel limit, PFM data shorter than its header says.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "support/expect_error.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

using test::input_error_of;

void write_bytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

std::string big_endian_u32(std::uint32_t v) {
  return {static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
          static_cast<char>(v)};
}

/// A PNG signature and IHDR chunk claiming width × height (16-bit grey), then nothing: a decoder
/// that trusted it would allocate width·height·2 bytes.
std::string png_header(std::uint32_t width, std::uint32_t height) {
  std::string s("\x89PNG\r\n\x1a\n", 8);
  s += big_endian_u32(13) + "IHDR" + big_endian_u32(width) + big_endian_u32(height);
  s += std::string("\x10\x00\x00\x00\x00", 5) + big_endian_u32(0);  // depth 16, grey; bogus CRC
  return s;
}

TEST(BadImageInput, PngHeaderClaimingTenGigapixelsIsRefusedBeforeDecoding) {
  test::ScratchDir dir;
  write_bytes(dir / "huge.png", png_header(100000, 100000));
  const auto size = peek_image_size(dir / "huge.png");
  ASSERT_TRUE(size.has_value());
  EXPECT_EQ(size->first, 100000);
  EXPECT_EQ(size->second, 100000);
  for (auto read : {+[](const std::filesystem::path& p) { (void)read_image(p); },
                    +[](const std::filesystem::path& p) { (void)read_image_unchanged(p); },
                    +[](const std::filesystem::path& p) { (void)read_kitti_disparity(p); }}) {
    const std::string message = input_error_of([&] { read(dir / "huge.png"); });
    EXPECT_CONTAINS(message, "huge.png");
    EXPECT_CONTAINS(message, "100000x100000 exceeds the limit of 64000000 pixels");
  }
}

/// fuzz_kitti_disparity_png found it (first version of the limit): 3361932682 x 4278181228 made
/// width·height overflow int64 (UBSan: signed integer overflow) and pass the check.
TEST(BadImageInput, PngHeaderWhosePixelCountOverflowsIsRefused) {
  test::ScratchDir dir;
  write_bytes(dir / "wrap.png", png_header(3361932682u, 4278181228u));
  EXPECT_CONTAINS(input_error_of([&] { (void)read_kitti_disparity(dir / "wrap.png"); }),
                  "3361932682x4278181228 exceeds the limit of 64000000 pixels");
  write_bytes(dir / "max.png", png_header(0xFFFFFFFFu, 0xFFFFFFFFu));
  EXPECT_CONTAINS(input_error_of([&] { (void)read_image(dir / "max.png"); }),
                  "4294967295x4294967295 exceeds the limit");
}

TEST(BadImageInput, PngHeaderClaimingAZeroWidthIsRefused) {
  test::ScratchDir dir;
  write_bytes(dir / "empty.png", png_header(0, 7));
  EXPECT_CONTAINS(input_error_of([&] { (void)read_image(dir / "empty.png"); }), "empty image (0x7)");
}

TEST(BadImageInput, ConfiguredPixelLimitIsAppliedToRealPngAndJpegFiles) {
  test::ScratchDir dir;
  const cv::Mat image(30, 40, CV_8UC3, cv::Scalar(10, 20, 30));  // 1200 px
  write_image(dir / "a.png", image);
  write_image(dir / "a.jpg", image);
  for (const char* name : {"a.png", "a.jpg"}) {
    SCOPED_TRACE(name);
    const auto size = peek_image_size(dir / name);
    ASSERT_TRUE(size.has_value());
    EXPECT_EQ(size->first, 40);
    EXPECT_EQ(size->second, 30);
    EXPECT_EQ(read_image(dir / name, true, 1200).size(), cv::Size(40, 30));  // at the limit: ok
    EXPECT_CONTAINS(input_error_of([&] { (void)read_image(dir / name, true, 1199); }),
                    "40x30 exceeds the limit of 1199 pixels");
  }
}

TEST(BadImageInput, PnmHeaderIsPeekedAndItsSizeCheckedBeforeDecoding) {
  test::ScratchDir dir;
  write_image(dir / "a.ppm", cv::Mat(30, 40, CV_8UC3, cv::Scalar(1, 2, 3)));
  const auto size = peek_image_size(dir / "a.ppm");
  ASSERT_TRUE(size.has_value());
  EXPECT_EQ(size->first, 40);
  EXPECT_EQ(size->second, 30);
  EXPECT_CONTAINS(input_error_of([&] { (void)read_image(dir / "a.ppm", true, 1000); }),
                  "40x30 exceeds the limit of 1000 pixels");
  // A comment between the fields, and a header claiming 9·10⁹ pixels with no data behind it.
  write_bytes(dir / "huge.pgm", "P5\n# made by hand\n90000 100000\n255\n");
  const auto huge = peek_image_size(dir / "huge.pgm");
  ASSERT_TRUE(huge.has_value());
  EXPECT_EQ(huge->first, 90000);
  EXPECT_EQ(huge->second, 100000);
  EXPECT_CONTAINS(input_error_of([&] { (void)read_image(dir / "huge.pgm"); }),
                  "90000x100000 exceeds the limit of 64000000 pixels");
}

/// fuzz_kitti_disparity_png oom-3617dfd2: a mutated PNG lost its signature, OpenCV's DICOM decoder
/// took it and asked for 4 GB. Only PNG, JPEG and PNM signatures reach a decoder now.
TEST(BadImageInput, FileWithoutAPngJpegOrPnmSignatureIsRefusedBeforeDecoding) {
  test::ScratchDir dir;
  std::string dicom(128, '\0');
  dicom += "DICM" + std::string(64, '\xff');
  write_bytes(dir / "scan.png", dicom);
  write_bytes(dir / "tiff.png", std::string("II*\0", 4) + std::string(64, '\x7f'));
  for (const char* name : {"scan.png", "tiff.png"}) {
    SCOPED_TRACE(name);
    for (auto read : {+[](const std::filesystem::path& p) { (void)read_image(p); },
                      +[](const std::filesystem::path& p) { (void)read_image_unchanged(p); },
                      +[](const std::filesystem::path& p) { (void)read_kitti_disparity(p); }}) {
      const std::string message = input_error_of([&] { read(dir / name); });
      EXPECT_CONTAINS(message, name);
      EXPECT_CONTAINS(message, "not a PNG, JPEG or PNM file");
    }
  }
}

TEST(BadImageInput, PfmHeaderAboveThePixelLimitIsRefused) {
  test::ScratchDir dir;
  write_bytes(dir / "huge.pfm", "Pf\n60000 60000\n-1\n" + std::string(16, '\0'));
  const std::string message = input_error_of([&] { (void)read_pfm(dir / "huge.pfm"); });
  EXPECT_CONTAINS(message, "huge.pfm");
  EXPECT_CONTAINS(message, "60000x60000 exceeds the limit of 64000000 pixels");
  // A configured lower limit applies to small files too (3x2 = 6 px).
  cv::Mat d(2, 3, CV_32F, cv::Scalar(1.5f));
  write_pfm(dir / "small.pfm", d);
  EXPECT_EQ(read_pfm(dir / "small.pfm", 6).size(), cv::Size(3, 2));
  EXPECT_CONTAINS(input_error_of([&] { (void)read_pfm(dir / "small.pfm", 5); }),
                  "3x2 exceeds the limit of 5 pixels");
}

TEST(BadImageInput, PfmDataShorterThanItsHeaderIsRefusedBeforeAllocating) {
  test::ScratchDir dir;
  // 4000x4000 colour = 192 MB of floats claimed, 16 bytes present.
  write_bytes(dir / "short.pfm", "PF\n4000 4000\n-1\n" + std::string(16, '\0'));
  const std::string message = input_error_of([&] { (void)read_pfm(dir / "short.pfm"); });
  EXPECT_CONTAINS(message, "short.pfm");
  EXPECT_CONTAINS(message, "truncated data (expected 192000000 bytes)");
}

}  // namespace
}  // namespace planecell::io
