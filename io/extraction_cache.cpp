#include "io/extraction_cache.hpp"

#include <unistd.h>
#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "core/error.hpp"
#include "io/blob_bytes.hpp"

namespace planecell::io {
namespace {

constexpr char kCacheMagic[4] = {'P', 'C', 'X', 'C'};
/// Bounds a corrupt header cannot get past (a cache holds one camera frame).
constexpr int kMaxCachedSide = 1 << 15;
constexpr std::uint32_t kMaxCachedVertices = 1u << 20;

std::uint32_t cache_crc(const std::uint8_t* data, std::size_t size) {
  return static_cast<std::uint32_t>(crc32(0L, data, static_cast<uInt>(size)));
}

void put_cached_cell(blob::Writer& w, const Planecell& c) {
  w.put(c.id);
  w.put(c.frame_id);
  w.put(static_cast<std::uint8_t>(c.has_plane));
  w.put(c.disparity_plane.a);
  w.put(c.disparity_plane.b);
  w.put(c.disparity_plane.c);
  w.put_matrix(c.plane.normal);
  w.put(c.plane.offset);
  w.put(static_cast<std::uint32_t>(c.vertices_px.size()));
  for (const auto& v : c.vertices_px) w.put_matrix(v);
  w.put(static_cast<std::uint32_t>(c.vertices_m.size()));
  for (const auto& v : c.vertices_m) w.put_matrix(v);
  w.put_matrix(c.mean_rgb);
  for (float h : c.histogram) w.put(h);
  w.put(c.area_px);
  w.put(c.inlier_count);
  w.put(c.inlier_ratio);
  w.put(c.depth_sigma_m);
  w.put(c.normal_sigma_rad);
  w.put(c.surface);
}

Planecell get_cached_cell(blob::Reader& r) {
  Planecell c;
  c.id = r.get<std::uint32_t>();
  c.frame_id = r.get<std::uint64_t>();
  c.has_plane = r.get<std::uint8_t>() != 0;
  c.disparity_plane.a = r.get<double>();
  c.disparity_plane.b = r.get<double>();
  c.disparity_plane.c = r.get<double>();
  r.get_matrix(c.plane.normal);
  c.plane.offset = r.get<double>();
  const std::uint32_t n_px = r.count(2 * sizeof(float));
  if (n_px > kMaxCachedVertices) throw StorageError(r.what() + ": " + std::to_string(n_px) + " image vertices");
  c.vertices_px.resize(n_px);
  for (auto& v : c.vertices_px) r.get_matrix(v);
  const std::uint32_t n_m = r.count(3 * sizeof(float));
  if (n_m > kMaxCachedVertices) throw StorageError(r.what() + ": " + std::to_string(n_m) + " 3D vertices");
  c.vertices_m.resize(n_m);
  for (auto& v : c.vertices_m) r.get_matrix(v);
  r.get_matrix(c.mean_rgb);
  for (float& h : c.histogram) h = r.get<float>();
  c.area_px = r.get<std::uint32_t>();
  c.inlier_count = r.get<std::uint32_t>();
  c.inlier_ratio = r.get<float>();
  c.depth_sigma_m = r.get<float>();
  c.normal_sigma_rad = r.get<float>();
  c.surface = r.get<std::uint32_t>();
  return c;
}

}  // namespace

std::filesystem::path extraction_cache_path(const std::filesystem::path& dir, std::uint64_t frame_id) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06llu.pcx", static_cast<unsigned long long>(frame_id));
  return dir / name;
}

void write_extraction_cache(const std::filesystem::path& path, std::uint64_t fingerprint,
                            std::uint64_t frame_id, const extraction::PlanecellFrame& frame) {
  const std::string what = "extraction cache '" + path.string() + "'";
  if (!frame.labels.empty() && (frame.labels.type() != CV_32S || !frame.labels.isContinuous()))
    throw InputError(what + ": the label image must be a continuous CV_32S image");
  blob::Writer w;
  for (char ch : kCacheMagic) w.put(ch);
  w.put(kExtractionCacheVersion);
  w.put(fingerprint);
  w.put(frame_id);
  w.put(frame.plane_fraction);
  w.put(static_cast<std::int32_t>(frame.cell_size_px));
  w.put(static_cast<std::int32_t>(frame.labels.rows));
  w.put(static_cast<std::int32_t>(frame.labels.cols));
  const uLong raw_bytes = static_cast<uLong>(frame.labels.total() * sizeof(std::int32_t));
  std::vector<std::uint8_t> packed(compressBound(raw_bytes));
  uLongf packed_bytes = static_cast<uLongf>(packed.size());
  if (raw_bytes > 0 &&
      compress2(packed.data(), &packed_bytes, frame.labels.ptr<std::uint8_t>(), raw_bytes, 1) != Z_OK)
    throw StorageError(what + ": cannot compress the label image");
  if (raw_bytes == 0) packed_bytes = 0;
  w.put(static_cast<std::uint32_t>(packed_bytes));
  w.bytes.insert(w.bytes.end(), packed.begin(), packed.begin() + static_cast<std::ptrdiff_t>(packed_bytes));
  w.put(static_cast<std::uint32_t>(frame.cells.size()));
  for (const Planecell& cell : frame.cells) put_cached_cell(w, cell);
  w.put(cache_crc(w.bytes.data(), w.bytes.size()));

  std::filesystem::path tmp = path;
  tmp += "." + std::to_string(::getpid()) + "." +
         std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id())) + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(w.bytes.data()), static_cast<std::streamsize>(w.bytes.size()));
    out.flush();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(tmp, ignored);
      throw StorageError(what + ": cannot be written (disk full or not writable?)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw StorageError(what + ": cannot be renamed into place: " + ec.message());
}

std::uint32_t extraction_cache_crc32(std::span<const std::uint8_t> bytes) {
  return cache_crc(bytes.data(), bytes.size());
}

std::optional<extraction::PlanecellFrame> read_extraction_cache(const std::filesystem::path& path,
                                                                std::uint64_t fingerprint,
                                                                std::uint64_t frame_id) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw StorageError("extraction cache '" + path.string() + "': read error");
  return decode_extraction_cache(bytes, fingerprint, frame_id, "extraction cache '" + path.string() + "'");
}

std::optional<extraction::PlanecellFrame> decode_extraction_cache(std::span<const std::uint8_t> bytes,
                                                                  std::uint64_t fingerprint,
                                                                  std::uint64_t frame_id, const std::string& what) {
  constexpr std::size_t kHeader = sizeof(kCacheMagic) + 1 + 8;
  if (bytes.size() < kHeader + 4 || !std::equal(std::begin(kCacheMagic), std::end(kCacheMagic), bytes.begin()))
    throw StorageError(what + ": not an extraction cache file (bad magic or truncated)");
  blob::Reader header(bytes.data() + sizeof(kCacheMagic), bytes.size() - sizeof(kCacheMagic), what);
  if (header.get<std::uint8_t>() != kExtractionCacheVersion || header.get<std::uint64_t>() != fingerprint)
    return std::nullopt;  // another version or other inputs: stale, recomputed by the caller
  std::uint32_t stored_crc = 0;
  std::memcpy(&stored_crc, bytes.data() + bytes.size() - 4, 4);
  if (cache_crc(bytes.data(), bytes.size() - 4) != stored_crc)
    throw StorageError(what + ": checksum mismatch (truncated or corrupt file)");
  blob::Reader r(bytes.data() + kHeader, bytes.size() - kHeader - 4, what);
  const auto stored_frame = r.get<std::uint64_t>();
  if (stored_frame != frame_id)
    throw StorageError(what + ": holds frame " + std::to_string(stored_frame) + ", expected frame " +
                       std::to_string(frame_id));
  extraction::PlanecellFrame frame;
  frame.plane_fraction = r.get<double>();
  frame.cell_size_px = r.get<std::int32_t>();
  const auto rows = r.get<std::int32_t>(), cols = r.get<std::int32_t>();
  if (rows < 0 || cols < 0 || rows > kMaxCachedSide || cols > kMaxCachedSide || (rows == 0) != (cols == 0))
    throw StorageError(what + ": label image of " + std::to_string(rows) + " x " + std::to_string(cols) + " px");
  const std::uint32_t packed_bytes = r.count(1);
  const std::uint8_t* packed = bytes.data() + kHeader + 8 + 8 + 4 + 4 + 4 + 4;
  for (std::uint32_t i = 0; i < packed_bytes; ++i) (void)r.get<std::uint8_t>();  // skip, bounds-checked
  // Deflate expands at most ~1032:1: a header claiming more pixels than the stream can hold is
  // refused before the image is allocated.
  const double label_bytes = 4.0 * static_cast<double>(rows) * static_cast<double>(cols);
  if (label_bytes > 1032.0 * static_cast<double>(packed_bytes) + 64.0)
    throw StorageError(what + ": a " + std::to_string(packed_bytes) + "-byte stream cannot hold a " +
                       std::to_string(rows) + " x " + std::to_string(cols) + " px label image");
  if (rows > 0) {
    frame.labels.create(rows, cols, CV_32S);
    uLongf raw_bytes = static_cast<uLongf>(frame.labels.total() * sizeof(std::int32_t));
    const uLongf expected = raw_bytes;
    if (uncompress(frame.labels.ptr<std::uint8_t>(), &raw_bytes, packed, packed_bytes) != Z_OK ||
        raw_bytes != expected)
      throw StorageError(what + ": the label image does not decompress to " + std::to_string(rows) + " x " +
                         std::to_string(cols) + " px");
  }
  const std::uint32_t n = r.count(4 + 8 + 1 + 8 * 7 + 4 + 4 + 12 + 256 + 4 * 6);
  frame.cells.reserve(n);
  for (std::uint32_t i = 0; i < n; ++i) frame.cells.push_back(get_cached_cell(r));
  r.expect_end();
  for (int y = 0; y < frame.labels.rows; ++y) {
    const auto* row = frame.labels.ptr<std::int32_t>(y);
    for (int x = 0; x < frame.labels.cols; ++x)
      if (row[x] < -1 || row[x] >= static_cast<std::int32_t>(n))
        throw StorageError(what + ": label " + std::to_string(row[x]) + " at (" + std::to_string(x) + ", " +
                           std::to_string(y) + ") names no cell of its " + std::to_string(n));
  }
  return frame;
}

}  // namespace planecell::io
