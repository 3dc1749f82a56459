#include "io/disparity_io.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>

#include "core/error.hpp"
#include "io/image_io.hpp"

namespace planecell::io {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// Reads the next whitespace-delimited header token of a PFM file.
std::string next_token(std::istream& in, const std::filesystem::path& path) {
  std::string token;
  if (!(in >> token)) throw InputError("PFM '" + path.string() + "': truncated header");
  return token;
}

std::filesystem::path ensure_parent(const std::filesystem::path& path) {
  if (path.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec) throw StorageError("'" + path.string() + "': cannot create folder: " + ec.message());
  }
  return path;
}

}  // namespace

cv::Mat read_pfm(const std::filesystem::path& path, std::int64_t max_pixels) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("PFM '" + path.string() + "': file not found or unreadable");
  const std::string magic = next_token(in, path);
  int channels = 0;
  if (magic == "Pf") channels = 1;
  else if (magic == "PF") channels = 3;
  else throw InputError("PFM '" + path.string() + "': bad magic '" + magic.substr(0, 8) + "'");
  long width = 0, height = 0;
  double scale = 0.0;
  try {
    width = std::stol(next_token(in, path));
    height = std::stol(next_token(in, path));
    scale = std::stod(next_token(in, path));
  } catch (const std::logic_error&) {
    throw InputError("PFM '" + path.string() + "': malformed header");
  }
  if (width <= 0 || height <= 0 || width > 65535 || height > 65535 || scale == 0.0 ||
      !std::isfinite(scale))
    throw InputError("PFM '" + path.string() + "': bad size or scale in header");
  if (static_cast<std::int64_t>(width) * height > max_pixels)
    throw InputError("PFM '" + path.string() + "': " + std::to_string(width) + "x" +
                     std::to_string(height) + " exceeds the limit of " +
                     std::to_string(max_pixels) + " pixels");
  in.get();  // the single whitespace after the scale
  const bool little_endian = scale < 0.0;
  const std::size_t count = static_cast<std::size_t>(width) * height * channels;
  // The data must be in the file before the buffer for it is allocated.
  const std::streamoff data_start = in.tellg();
  std::error_code ec;
  const auto file_size = std::filesystem::file_size(path, ec);
  if (ec || data_start < 0 || file_size < static_cast<std::uintmax_t>(data_start) + count * 4)
    throw InputError("PFM '" + path.string() + "': truncated data (expected " +
                     std::to_string(count * 4) + " bytes)");
  std::vector<float> data(count);
  in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(count * 4));
  if (static_cast<std::size_t>(in.gcount()) != count * 4)
    throw InputError("PFM '" + path.string() + "': truncated data (expected " +
                     std::to_string(count * 4) + " bytes)");
  const bool host_little = std::endian::native == std::endian::little;
  cv::Mat out(static_cast<int>(height), static_cast<int>(width), CV_32F);
  for (long row = 0; row < height; ++row) {
    float* dst = out.ptr<float>(static_cast<int>(height - 1 - row));  // stored bottom-up
    for (long col = 0; col < width; ++col) {
      float value = data[(static_cast<std::size_t>(row) * width + col) * channels];
      if (little_endian != host_little) {
        std::uint32_t bits;
        std::memcpy(&bits, &value, 4);
        bits = __builtin_bswap32(bits);
        std::memcpy(&value, &bits, 4);
      }
      dst[col] = (std::isfinite(value) && value > 0.0f) ? value : kNaN;
    }
  }
  return out;
}

void write_pfm(const std::filesystem::path& path, const cv::Mat& disparity) {
  if (disparity.empty() || disparity.type() != CV_32F)
    throw StorageError("PFM '" + path.string() + "': expected a non-empty CV_32F map");
  std::ofstream out(ensure_parent(path), std::ios::binary);
  if (!out) throw StorageError("PFM '" + path.string() + "': cannot open for writing");
  out << "Pf\n" << disparity.cols << " " << disparity.rows << "\n-1\n";
  std::vector<float> row(static_cast<std::size_t>(disparity.cols));
  for (int r = disparity.rows - 1; r >= 0; --r) {
    const float* src = disparity.ptr<float>(r);
    for (int c = 0; c < disparity.cols; ++c)
      row[c] = std::isnan(src[c]) ? std::numeric_limits<float>::infinity() : src[c];
    out.write(reinterpret_cast<const char*>(row.data()),
              static_cast<std::streamsize>(row.size() * sizeof(float)));
  }
  out.flush();
  if (!out) throw StorageError("PFM '" + path.string() + "': write failed (disk full?)");
}

cv::Mat read_kitti_disparity(const std::filesystem::path& path, std::int64_t max_pixels) {
  const cv::Mat raw = read_image_unchanged(path, max_pixels);
  if (raw.type() != CV_16UC1)
    throw InputError("KITTI disparity '" + path.string() + "': expected a 16-bit single-channel PNG");
  cv::Mat out(raw.size(), CV_32F);
  for (int r = 0; r < raw.rows; ++r) {
    const auto* src = raw.ptr<std::uint16_t>(r);
    float* dst = out.ptr<float>(r);
    for (int c = 0; c < raw.cols; ++c) dst[c] = src[c] == 0 ? kNaN : src[c] / 256.0f;
  }
  return out;
}

void write_kitti_disparity(const std::filesystem::path& path, const cv::Mat& disparity,
                           int png_compression) {
  if (disparity.empty() || disparity.type() != CV_32F)
    throw StorageError("KITTI disparity '" + path.string() + "': expected a non-empty CV_32F map");
  cv::Mat raw(disparity.size(), CV_16UC1);
  for (int r = 0; r < disparity.rows; ++r) {
    const float* src = disparity.ptr<float>(r);
    auto* dst = raw.ptr<std::uint16_t>(r);
    for (int c = 0; c < disparity.cols; ++c) {
      const float d = src[c];
      if (!(std::isfinite(d) && d > 0.0f)) {
        dst[c] = 0;
      } else {
        const float v = std::round(d * 256.0f);
        dst[c] = static_cast<std::uint16_t>(std::clamp(v, 1.0f, 65535.0f));
      }
    }
  }
  write_image(path, raw, png_compression);
}

cv::Mat read_disparity(const std::filesystem::path& path) {
  const auto ext = path.extension().string();
  if (ext == ".pfm" || ext == ".PFM") return read_pfm(path);
  if (ext == ".png" || ext == ".PNG") return read_kitti_disparity(path);
  throw InputError("disparity '" + path.string() + "': unknown format (use .pfm or .png)");
}

void write_disparity(const std::filesystem::path& path, const cv::Mat& disparity) {
  const auto ext = path.extension().string();
  if (ext == ".pfm" || ext == ".PFM") return write_pfm(path, disparity);
  if (ext == ".png" || ext == ".PNG") return write_kitti_disparity(path, disparity);
  throw StorageError("disparity '" + path.string() + "': unknown format (use .pfm or .png)");
}

cv::Mat colourise_disparity(const cv::Mat& disparity, float max_disparity_px) {
  cv::Mat scaled(disparity.size(), CV_8UC1);
  cv::Mat valid(disparity.size(), CV_8UC1);
  const float scale = 255.0f / std::max(max_disparity_px, 1.0f);
  for (int r = 0; r < disparity.rows; ++r) {
    const float* src = disparity.ptr<float>(r);
    auto* dst = scaled.ptr<std::uint8_t>(r);
    auto* ok = valid.ptr<std::uint8_t>(r);
    for (int c = 0; c < disparity.cols; ++c) {
      const bool is_valid = std::isfinite(src[c]) && src[c] > 0.0f;
      ok[c] = is_valid ? 255 : 0;
      dst[c] = is_valid ? cv::saturate_cast<std::uint8_t>(src[c] * scale) : 0;
    }
  }
  cv::Mat colour;
  cv::applyColorMap(scaled, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar::all(0), valid == 0);
  return colour;
}

}  // namespace planecell::io
