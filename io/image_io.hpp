#pragma once
/// Image reading/writing with clear errors (OpenCV codecs underneath).
#include <filesystem>
#include <opencv2/core/mat.hpp>

namespace planecell::io {

/// Reads an 8-bit image as BGR (colour = true) or grayscale. Throws InputError naming the path
/// when the file is missing, empty or cannot be decoded.
cv::Mat read_image(const std::filesystem::path& path, bool colour = true);

/// Reads an image keeping its depth and channels (e.g. 16-bit PNG). Same errors as read_image.
cv::Mat read_image_unchanged(const std::filesystem::path& path);

/// Writes an image (format from the extension), creating parent folders. Throws StorageError
/// naming the path when it cannot be written (full disk, no permission, bad extension).
void write_image(const std::filesystem::path& path, const cv::Mat& image, int png_compression = 3);

}  // namespace planecell::io
