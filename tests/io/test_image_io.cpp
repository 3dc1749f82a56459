/// Image I/O: lossless round trips, colour/gray conversion, and named errors.
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "io/image_io.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

template <class Error, class Fn>
void expect_error_naming(Fn&& fn, const std::string& needle) {
  try {
    fn();
    ADD_FAILURE() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

cv::Mat pattern_bgr() {
  cv::Mat image(5, 7, CV_8UC3);
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c) image.at<cv::Vec3b>(r, c) = cv::Vec3b(r * 40, c * 30, 200 - r - c);
  return image;
}

TEST(ImageIo, PngRoundTripIsLosslessAndCreatesFolders) {
  test::ScratchDir dir;
  const cv::Mat image = pattern_bgr();
  const auto path = dir / "a" / "b" / "image.png";
  write_image(path, image);
  const cv::Mat back = read_image(path, true);
  ASSERT_EQ(back.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(back, image, cv::NORM_INF), 0.0);
}

TEST(ImageIo, GrayAndColourReadsConvert) {
  test::ScratchDir dir;
  cv::Mat gray(3, 4, CV_8UC1);
  for (int i = 0; i < 12; ++i) gray.data[i] = static_cast<unsigned char>(20 * i);
  write_image(dir / "gray.png", gray);
  const cv::Mat as_colour = read_image(dir / "gray.png", true);
  ASSERT_EQ(as_colour.type(), CV_8UC3);
  const cv::Vec3b px = as_colour.at<cv::Vec3b>(2, 3);  // value 220 in all channels
  EXPECT_EQ(px, cv::Vec3b(220, 220, 220));
  const cv::Mat as_gray = read_image(dir / "gray.png", false);
  ASSERT_EQ(as_gray.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(as_gray, gray, cv::NORM_INF), 0.0);
}

TEST(ImageIo, UnchangedKeeps16Bit) {
  test::ScratchDir dir;
  cv::Mat deep(2, 2, CV_16UC1, cv::Scalar(40000));
  write_image(dir / "deep.png", deep);
  const cv::Mat back = read_image_unchanged(dir / "deep.png");
  ASSERT_EQ(back.type(), CV_16UC1);
  EXPECT_EQ(back.at<std::uint16_t>(1, 1), 40000);
}

TEST(ImageIo, MissingEmptyAndCorruptFilesAreNamed) {
  test::ScratchDir dir;
  expect_error_naming<InputError>([&] { read_image(dir / "absent.png"); }, "absent.png");
  std::ofstream(dir / "empty.png").close();
  expect_error_naming<InputError>([&] { read_image(dir / "empty.png"); }, "empty");
  std::ofstream(dir / "corrupt.png") << "definitely not a PNG file";
  expect_error_naming<InputError>([&] { read_image(dir / "corrupt.png"); }, "corrupt.png");
  expect_error_naming<InputError>([&] { read_image_unchanged(dir / "corrupt.png"); },
                                  "not a PNG, JPEG or PNM file");
  // A real PNG signature and header with the image data cut off: the decoder refuses it.
  write_image(dir / "whole.png", pattern_bgr());
  std::ifstream whole(dir / "whole.png", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(whole)), std::istreambuf_iterator<char>());
  std::ofstream(dir / "cut.png", std::ios::binary) << bytes.substr(0, 40);
  expect_error_naming<InputError>([&] { read_image(dir / "cut.png"); }, "cannot be decoded");
}

TEST(ImageIo, PngBytesAreTheFileAsItIsAfterTheHeaderChecks) {
  test::ScratchDir dir;
  write_image(dir / "whole.png", pattern_bgr());
  std::ifstream whole(dir / "whole.png", std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(whole)), std::istreambuf_iterator<char>());
  EXPECT_TRUE(is_png_file(dir / "whole.png"));
  const auto bytes = read_png_bytes(dir / "whole.png");
  EXPECT_EQ(std::string(bytes.begin(), bytes.end()), file);

  expect_error_naming<InputError>([&] { read_png_bytes(dir / "absent.png"); }, "absent.png");
  EXPECT_FALSE(is_png_file(dir / "absent.png"));
  std::ofstream(dir / "text.png") << "definitely not a PNG file";
  EXPECT_FALSE(is_png_file(dir / "text.png"));
  expect_error_naming<InputError>([&] { read_png_bytes(dir / "text.png"); }, "not a PNG file");
  // A PNG cut short, inside its data or just before its IEND chunk.
  for (const std::size_t keep : {std::size_t{40}, file.size() - 12, file.size() - 1}) {
    std::ofstream(dir / "cut.png", std::ios::binary) << file.substr(0, keep);
    expect_error_naming<InputError>([&] { read_png_bytes(dir / "cut.png"); }, "truncated PNG");
  }
  // 5x7 = 35 pixels: more than a 30-pixel limit.
  expect_error_naming<InputError>([&] { read_png_bytes(dir / "whole.png", 30); }, "whole.png");
}

TEST(ImageIo, UnwritableTargetsRaiseStorageError) {
  test::ScratchDir dir;
  expect_error_naming<StorageError>([&] { write_image(dir / "x.png", cv::Mat()); }, "x.png");
  expect_error_naming<StorageError>([&] { write_image(dir / "x.unknownext", pattern_bgr()); },
                                    "x.unknownext");
  std::ofstream(dir / "file").close();  // a regular file cannot hold a folder
  expect_error_naming<StorageError>([&] { write_image(dir / "file" / "x.png", pattern_bgr()); },
                                    "x.png");
}

TEST(RealData, TeddyDecodesAtItsDocumentedSize) {
  const auto path = test::shared_data("middlebury/teddy/im2.png");
  if (!path) GTEST_SKIP() << "shared data absent";
  const cv::Mat image = read_image(*path);
  EXPECT_EQ(image.cols, 450);
  EXPECT_EQ(image.rows, 375);
  EXPECT_EQ(image.type(), CV_8UC3);
}

}  // namespace
}  // namespace planecell::io
