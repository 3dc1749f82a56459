#pragma once
/// Image reading/writing with clear errors (OpenCV codecs underneath).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <utility>
#include <vector>
#include <opencv2/core/mat.hpp>

namespace planecell::io {

/// Largest image the readers accept (width·height, pixels): 64 Mpx, far above any stereo camera
/// the project reads (KITTI 0.47 Mpx, Middlebury 2014 full size ≈ 6 Mpx), far below what a
/// corrupt header can claim. Checked from the file header before decoding allocates (PNG, JPEG,
/// PFM; other formats after OpenCV's own 2³⁰-pixel header check).
inline constexpr std::int64_t kDefaultMaxImagePixels = 64'000'000;

/// Width and height from the start of a PNG in memory: the 8-byte signature, then the IHDR chunk
/// (big-endian u32 width and height at bytes 16 and 20); nullopt when the bytes do not start so.
std::optional<std::pair<std::uint32_t, std::uint32_t>> png_header_size(std::span<const std::uint8_t> bytes);

/// Width and height from a PNG (IHDR) or JPEG (SOFn) header without decoding; nullopt for other
/// or unrecognised formats. Throws InputError naming the path when the file cannot be read.
std::optional<std::pair<std::int64_t, std::int64_t>> peek_image_size(const std::filesystem::path& path);

/// Reads an 8-bit image as BGR (colour = true) or grayscale. Throws InputError naming the path
/// when the file is missing, empty or cannot be decoded, or holds more than `max_pixels`.
cv::Mat read_image(const std::filesystem::path& path, bool colour = true,
                   std::int64_t max_pixels = kDefaultMaxImagePixels);

/// Reads an image keeping its depth and channels (e.g. 16-bit PNG). Same errors as read_image.
cv::Mat read_image_unchanged(const std::filesystem::path& path,
                             std::int64_t max_pixels = kDefaultMaxImagePixels);

/// The bytes of a PNG file as they are, not decoded, after the checks read_image makes before
/// decoding: the file exists, is not empty, starts with a PNG signature and IHDR, its size is
/// within `max_pixels`, and its chunks run whole up to IEND (a cut file is refused; the pixel
/// data itself is not decoded). Throws InputError naming the path otherwise.
std::vector<std::uint8_t> read_png_bytes(const std::filesystem::path& path,
                                         std::int64_t max_pixels = kDefaultMaxImagePixels);

/// True when the file starts with a PNG signature and IHDR (false when it cannot be read).
bool is_png_file(const std::filesystem::path& path);

/// Writes an image (format from the extension), creating parent folders. Throws StorageError
/// naming the path when it cannot be written (full disk, no permission, bad extension).
void write_image(const std::filesystem::path& path, const cv::Mat& image, int png_compression = 3);

}  // namespace planecell::io
