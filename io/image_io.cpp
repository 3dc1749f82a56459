#include "io/image_io.hpp"

#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "core/error.hpp"

namespace planecell::io {
namespace {

cv::Mat read_with_flags(const std::filesystem::path& path, int flags) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError("image '" + path.string() + "': file not found");
  if (std::filesystem::file_size(path, ec) == 0)
    throw InputError("image '" + path.string() + "': file is empty");
  cv::Mat image;
  try {
    image = cv::imread(path.string(), flags);
  } catch (const cv::Exception& e) {
    throw InputError("image '" + path.string() + "': cannot be decoded (" + e.what() + ")");
  }
  if (image.empty())
    throw InputError("image '" + path.string() + "': cannot be decoded (corrupt or unsupported)");
  return image;
}

}  // namespace

cv::Mat read_image(const std::filesystem::path& path, bool colour) {
  cv::Mat image = read_with_flags(path, colour ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE);
  if (image.depth() != CV_8U)
    throw InputError("image '" + path.string() + "': expected 8-bit image");
  return image;
}

cv::Mat read_image_unchanged(const std::filesystem::path& path) {
  return read_with_flags(path, cv::IMREAD_UNCHANGED);
}

void write_image(const std::filesystem::path& path, const cv::Mat& image, int png_compression) {
  if (image.empty()) throw StorageError("image '" + path.string() + "': nothing to write");
  if (path.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec) throw StorageError("image '" + path.string() + "': cannot create folder: " + ec.message());
  }
  const std::vector<int> params{cv::IMWRITE_PNG_COMPRESSION, png_compression};
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), image, params);
  } catch (const cv::Exception& e) {
    throw StorageError("image '" + path.string() + "': cannot be written (" + e.what() + ")");
  }
  if (!ok) throw StorageError("image '" + path.string() + "': cannot be written");
}

}  // namespace planecell::io
