#include "io/image_io.hpp"

#include <cctype>
#include <cstring>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace planecell::io {
namespace {

std::uint32_t big_endian(const unsigned char* p, int bytes) {
  std::uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

void check_pixels(const std::filesystem::path& path, std::int64_t width, std::int64_t height,
                  std::int64_t max_pixels) {
  if (width <= 0 || height <= 0)
    throw InputError("image '" + path.string() + "': header claims an empty image (" +
                     std::to_string(width) + "x" + std::to_string(height) + ")");
  if (width > max_pixels / height)  // width·height > max_pixels without overflowing (u32 sizes)
    throw InputError("image '" + path.string() + "': " + std::to_string(width) + "x" +
                     std::to_string(height) + " exceeds the limit of " +
                     std::to_string(max_pixels) + " pixels");
}

/// The image formats planecell reads, recognised by their first bytes exactly as OpenCV's own
/// decoders recognise them (so one of those claims the file first): PNG, JPEG, and binary or
/// ASCII PNM (P1–P6 followed by white space). OpenCV would also try its other decoders on anything
/// else, and a corrupt file can then claim gigabytes or abort inside a library (gdcm asserts on a
/// "DICM" tag at byte 128), so such files are refused here as well.
bool has_supported_signature(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char head[132] = {};
  in.read(reinterpret_cast<char*>(head), sizeof(head));
  const auto got = in.gcount();
  if (got >= 132 && std::memcmp(head + 128, "DICM", 4) == 0) return false;
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (got >= 8 && std::memcmp(head, kPng, 8) == 0) return true;
  if (got >= 3 && head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF) return true;
  return got >= 3 && head[0] == 'P' && head[1] >= '1' && head[1] <= '6' && std::isspace(head[2]);
}

/// Width and height from a PNM header ("P5 <w> <h> …"), if well formed, read the way OpenCV's
/// PNM decoder reads them: white space, or '#' comments that end at '\n' or '\r'.
std::optional<std::pair<std::int64_t, std::int64_t>> peek_pnm_size(std::istream& in) {
  std::int64_t values[2] = {0, 0};
  in.clear();
  in.seekg(2);
  for (auto& value : values) {
    int c = in.get();
    while (c != EOF && (std::isspace(c) || c == '#')) {
      if (c == '#')
        while (c != EOF && c != '\n' && c != '\r') c = in.get();
      c = in.get();
    }
    if (c == EOF || !std::isdigit(c)) return std::nullopt;
    value = 0;
    for (int digits = 0; c != EOF && std::isdigit(c); c = in.get(), ++digits) {
      if (digits >= 10) return std::nullopt;
      value = value * 10 + (c - '0');
    }
  }
  return std::pair<std::int64_t, std::int64_t>{values[0], values[1]};
}

cv::Mat read_with_flags(const std::filesystem::path& path, int flags, std::int64_t max_pixels) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError("image '" + path.string() + "': file not found");
  if (std::filesystem::file_size(path, ec) == 0)
    throw InputError("image '" + path.string() + "': file is empty");
  if (!has_supported_signature(path))
    throw InputError("image '" + path.string() +
                     "': not a PNG, JPEG or PNM file (unrecognised signature)");
  // The size comes from the header before anything is decoded; a header it cannot be read from
  // is refused rather than left to a decoder that might read a different, huge size from it.
  const auto size = peek_image_size(path);
  if (!size)
    throw InputError("image '" + path.string() + "': cannot read the image size from its header");
  check_pixels(path, size->first, size->second, max_pixels);
  cv::Mat image;
  try {
    image = cv::imread(path.string(), flags);
  } catch (const cv::Exception& e) {
    throw InputError("image '" + path.string() + "': cannot be decoded (" + e.what() + ")");
  }
  if (image.empty())
    throw InputError("image '" + path.string() + "': cannot be decoded (corrupt or unsupported)");
  check_pixels(path, image.cols, image.rows, max_pixels);
  return image;
}

}  // namespace

std::optional<std::pair<std::uint32_t, std::uint32_t>> png_header_size(std::span<const std::uint8_t> bytes) {
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size() < 24 || std::memcmp(bytes.data(), kPng, 8) != 0 || std::memcmp(bytes.data() + 12, "IHDR", 4) != 0)
    return std::nullopt;
  return std::pair{big_endian(bytes.data() + 16, 4), big_endian(bytes.data() + 20, 4)};
}

std::optional<std::pair<std::int64_t, std::int64_t>> peek_image_size(
    const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("image '" + path.string() + "': cannot be opened");
  unsigned char head[24] = {};
  in.read(reinterpret_cast<char*>(head), sizeof(head));
  const auto got = in.gcount();
  if (const auto png = png_header_size(std::span<const std::uint8_t>(head, static_cast<std::size_t>(got))))
    return std::pair<std::int64_t, std::int64_t>{png->first, png->second};
  // JPEG: SOI, then segments (FF marker, big-endian length) up to a SOFn frame header:
  // FF Cn, length, precision, height (u16), width (u16).
  if (got >= 2 && head[0] == 0xFF && head[1] == 0xD8) {
    in.clear();
    in.seekg(2);
    for (int segment = 0; segment < 4096; ++segment) {
      unsigned char marker[4];
      if (!in.read(reinterpret_cast<char*>(marker), 4) || marker[0] != 0xFF) return std::nullopt;
      const int m = marker[1];
      const std::uint32_t length = big_endian(marker + 2, 2);
      if (length < 2) return std::nullopt;
      const bool sof = m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC;
      if (sof) {
        unsigned char frame[5];
        if (!in.read(reinterpret_cast<char*>(frame), 5)) return std::nullopt;
        return std::pair<std::int64_t, std::int64_t>{big_endian(frame + 3, 2), big_endian(frame + 1, 2)};
      }
      in.seekg(length - 2, std::ios::cur);
    }
  }
  if (got >= 2 && head[0] == 'P' && head[1] >= '1' && head[1] <= '6') return peek_pnm_size(in);
  return std::nullopt;
}

cv::Mat read_image(const std::filesystem::path& path, bool colour, std::int64_t max_pixels) {
  cv::Mat image =
      read_with_flags(path, colour ? cv::IMREAD_COLOR : cv::IMREAD_GRAYSCALE, max_pixels);
  if (image.depth() != CV_8U)
    throw InputError("image '" + path.string() + "': expected 8-bit image");
  return image;
}

cv::Mat read_image_unchanged(const std::filesystem::path& path, std::int64_t max_pixels) {
  return read_with_flags(path, cv::IMREAD_UNCHANGED, max_pixels);
}

bool is_png_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::uint8_t head[24] = {};
  in.read(reinterpret_cast<char*>(head), sizeof(head));
  return png_header_size(std::span<const std::uint8_t>(head, static_cast<std::size_t>(in.gcount()))).has_value();
}

std::vector<std::uint8_t> read_png_bytes(const std::filesystem::path& path, std::int64_t max_pixels) {
  std::error_code ec;
  const auto file_size = std::filesystem::is_regular_file(path, ec) ? std::filesystem::file_size(path, ec) : 0;
  if (ec || file_size == 0) throw InputError("image '" + path.string() + "': file not found or empty");
  // One read: the header is checked (signature, IHDR, size) before the rest is read.
  std::ifstream in(path, std::ios::binary);
  std::vector<std::uint8_t> bytes(std::min<std::uintmax_t>(file_size, 24));
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  const auto size = png_header_size(bytes);
  if (!in || !size) throw InputError("image '" + path.string() + "': not a PNG file (no PNG signature and IHDR)");
  check_pixels(path, size->first, size->second, max_pixels);
  bytes.resize(file_size);
  if (!in.read(reinterpret_cast<char*>(bytes.data()) + 24, static_cast<std::streamsize>(file_size - 24)))
    throw InputError("image '" + path.string() + "': cannot be read");
  // The chunk layout, without decompressing: after the signature, chunks of (big-endian length,
  // type, data, CRC) up to IEND. A cut file ends inside a chunk or before IEND.
  std::size_t at = 8;
  bool ended = false;
  while (!ended && at + 12 <= bytes.size()) {
    const std::size_t length = big_endian(bytes.data() + at, 4);
    ended = std::memcmp(bytes.data() + at + 4, "IEND", 4) == 0;
    if (length > bytes.size() - at - 12) break;
    at += 12 + length;
  }
  if (!ended || at > bytes.size())
    throw InputError("image '" + path.string() + "': truncated PNG (its chunks end before IEND)");
  return bytes;
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
