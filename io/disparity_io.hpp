#pragma once
/// Disparity maps at the edges of the system. Inside: CV_32F px, NaN = invalid.
#include <filesystem>
#include <cstdint>
#include <opencv2/core/mat.hpp>

#include "io/image_io.hpp"

namespace planecell::io {

/// Reads a PFM (Pf grayscale; PF colour uses the first channel), honouring the scale's sign for
/// endianness and flipping rows (PFM stores bottom-up). Inf and non-positive values → NaN.
/// Throws InputError naming the path on a missing, truncated or malformed file, or one whose
/// header claims more than `max_pixels` pixels (checked before anything is allocated).
cv::Mat read_pfm(const std::filesystem::path& path, std::int64_t max_pixels = kDefaultMaxImagePixels);

/// Writes a CV_32F map as little-endian grayscale PFM; invalid (NaN) is written as +inf so
/// that other tools treat it as invalid). Throws StorageError when the file cannot be written.
void write_pfm(const std::filesystem::path& path, const cv::Mat& disparity);

/// Reads a KITTI 16-bit disparity PNG: d = value / 256, 0 = invalid (→ NaN). Same errors and
/// size limit as read_image_unchanged.
cv::Mat read_kitti_disparity(const std::filesystem::path& path,
                             std::int64_t max_pixels = kDefaultMaxImagePixels);

/// Writes a KITTI 16-bit disparity PNG: value = round(d·256) clamped to [1, 65535]; NaN/≤0 → 0.
void write_kitti_disparity(const std::filesystem::path& path, const cv::Mat& disparity,
                           int png_compression = 3);

/// Reads a disparity map by extension: .pfm → PFM, .png → KITTI 16-bit.
cv::Mat read_disparity(const std::filesystem::path& path);
/// Writes a disparity map by extension: .pfm → PFM, .png → KITTI 16-bit.
void write_disparity(const std::filesystem::path& path, const cv::Mat& disparity);

/// Colour-mapped 8-bit BGR preview of a disparity map (invalid = black), scaled to max_disparity.
cv::Mat colourise_disparity(const cv::Mat& disparity, float max_disparity_px);

}  // namespace planecell::io
