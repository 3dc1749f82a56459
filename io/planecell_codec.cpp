/// Compact binary codec of a frame's planecells (see planecell_codec.hpp for the layout).
#include "io/planecell_codec.hpp"

#include <opencv2/core/cvdef.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>

#include "core/error.hpp"

namespace planecell::io {
namespace {

constexpr std::array<std::uint8_t, 3> kMagic = {'P', 'C', 'L'};
constexpr std::uint8_t kFlagHistogram = 1u << 0;
constexpr std::uint8_t kFlagStatistics = 1u << 1;
constexpr std::uint8_t kFlagSequentialIds = 1u << 2;  ///< ids are 0, 1, 2, … and not stored
constexpr std::uint8_t kFlagPlanelessPolygons = 1u << 3;
constexpr std::uint8_t kKnownFlags =
    kFlagHistogram | kFlagStatistics | kFlagSequentialIds | kFlagPlanelessPolygons;
constexpr double kDisparityStep = 1.0 / 64.0;  ///< d̄ quantum (px)
constexpr double kMinVertexDisparityPx = 0.25; ///< as extraction::convert_to_3d

std::uint32_t crc32(std::span<const std::uint8_t> data) {
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::uint8_t byte : data) {
    crc ^= byte;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

std::uint64_t zigzag(std::int64_t v) {
  return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
std::int64_t unzigzag(std::uint64_t v) {
  return static_cast<std::int64_t>(v >> 1) ^ -static_cast<std::int64_t>(v & 1);
}

/// Szudzik pairing of two naturals: small pairs get small codes (both ≤ 10 → < 128, one byte).
std::uint64_t pair_code(std::uint64_t a, std::uint64_t b) {
  return a >= b ? a * a + a + b : a + b * b;
}
std::pair<std::uint64_t, std::uint64_t> unpair_code(std::uint64_t z) {
  auto s = static_cast<std::uint64_t>(std::sqrt(static_cast<long double>(z)));
  while (s * s > z) --s;
  while ((s + 1) * (s + 1) <= z) ++s;
  const std::uint64_t rest = z - s * s;
  return rest < s ? std::pair{rest, s} : std::pair{s, rest - s};
}

struct Writer {
  std::vector<std::uint8_t> out;
  void u8(std::uint8_t v) { out.push_back(v); }
  void varint(std::uint64_t v) {
    while (v >= 0x80) {
      out.push_back(static_cast<std::uint8_t>(v | 0x80));
      v >>= 7;
    }
    out.push_back(static_cast<std::uint8_t>(v));
  }
  void svarint(std::int64_t v) { varint(zigzag(v)); }
  void u16(std::uint16_t v) {
    u8(static_cast<std::uint8_t>(v));
    u8(static_cast<std::uint8_t>(v >> 8));
  }
  void u32(std::uint32_t v) {
    for (int k = 0; k < 4; ++k) u8(static_cast<std::uint8_t>(v >> (8 * k)));
  }
  void f32(float f) {
    std::uint32_t bits;
    std::memcpy(&bits, &f, 4);
    u32(bits);
  }
};

struct Reader {
  std::span<const std::uint8_t> in;
  std::size_t pos = 0;

  [[noreturn]] void fail(const std::string& what) const {
    throw InputError("planecell codec: " + what + " at byte " + std::to_string(pos) + " of " +
                     std::to_string(in.size()));
  }
  void need(std::size_t n, const char* field) const {
    if (in.size() - pos < n) fail(std::string("truncated input while reading ") + field);
  }
  std::size_t remaining() const { return in.size() - pos; }
  std::uint8_t u8(const char* field) {
    need(1, field);
    return in[pos++];
  }
  std::uint16_t u16(const char* field) {
    need(2, field);
    const std::uint16_t v = static_cast<std::uint16_t>(in[pos] | (in[pos + 1] << 8));
    pos += 2;
    return v;
  }
  std::uint32_t u32(const char* field) {
    need(4, field);
    std::uint32_t v = 0;
    for (int k = 0; k < 4; ++k) v |= static_cast<std::uint32_t>(in[pos + k]) << (8 * k);
    pos += 4;
    return v;
  }
  float f32(const char* field) {
    const std::uint32_t bits = u32(field);
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
  }
  std::uint64_t varint(const char* field) {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      const std::uint8_t byte = u8(field);
      v |= static_cast<std::uint64_t>(byte & 0x7F) << shift;
      if ((byte & 0x80) == 0) return v;
    }
    fail(std::string("over-long varint in ") + field);
  }
  std::int64_t svarint(const char* field) { return unzigzag(varint(field)); }
};

std::uint16_t to_half(double v) {
  return cv::float16_t(static_cast<float>(std::clamp(v, -60000.0, 60000.0))).bits();
}
double from_half(std::uint16_t bits) { return static_cast<float>(cv::float16_t::fromBits(bits)); }

/// Mean of lattice vertices in pixel-centre coordinates (identical in encoder and decoder).
/// Mean colour as RGB 5-6-5.
std::uint16_t rgb565(const Eigen::Vector3f& rgb) {
  auto q = [](float v, int levels) {
    return static_cast<std::uint16_t>(std::lround(std::clamp(v, 0.0f, 255.0f) * levels / 255.0f));
  };
  return static_cast<std::uint16_t>(q(rgb.x(), 31) << 11 | q(rgb.y(), 63) << 5 | q(rgb.z(), 31));
}
Eigen::Vector3f from_rgb565(std::uint16_t c) {
  return {std::round((c >> 11) * 255.0f / 31.0f), std::round(((c >> 5) & 63) * 255.0f / 63.0f),
          std::round((c & 31) * 255.0f / 31.0f)};
}

Eigen::Vector2d centroid(const std::vector<std::array<std::int64_t, 2>>& lattice) {
  if (lattice.empty()) return Eigen::Vector2d::Zero();
  std::int64_t sx = 0, sy = 0;
  for (const auto& q : lattice) {
    sx += q[0];
    sy += q[1];
  }
  const double n = static_cast<double>(lattice.size());
  return {static_cast<double>(sx) / n - 0.5, static_cast<double>(sy) / n - 0.5};
}

}  // namespace

std::vector<std::uint8_t> encode_planecells(const std::vector<Planecell>& cells,
                                            const StereoCamera& camera, std::uint64_t frame_id,
                                            const PlanecellCodecOptions& options) {
  Writer w;
  w.out.reserve(64 + cells.size() * 24);
  for (std::uint8_t m : kMagic) w.u8(m);
  w.u8(kPlanecellCodecVersion);
  bool sequential = true;
  for (std::size_t k = 0; k < cells.size() && sequential; ++k) sequential = cells[k].id == k;
  w.u8(static_cast<std::uint8_t>((options.include_histogram ? kFlagHistogram : 0) |
                                 (options.include_statistics ? kFlagStatistics : 0) |
                                 (sequential ? kFlagSequentialIds : 0) |
                                 (options.include_planeless_polygons ? kFlagPlanelessPolygons : 0)));
  w.varint(frame_id);
  for (double v : {camera.fx, camera.fy, camera.cx, camera.cy, camera.baseline_m})
    w.f32(static_cast<float>(v));
  w.varint(static_cast<std::uint64_t>(std::max(0, camera.width)));
  w.varint(static_cast<std::uint64_t>(std::max(0, camera.height)));
  w.varint(cells.size());

  std::int64_t previous_id = -1;
  std::array<std::int64_t, 2> previous_first = {0, 0};
  std::vector<std::array<std::int64_t, 2>> lattice;
  for (const Planecell& cell : cells) {
    if (!sequential) w.svarint(static_cast<std::int64_t>(cell.id) - previous_id - 1);
    previous_id = cell.id;
    lattice.clear();
    const bool with_polygon = cell.has_plane || options.include_planeless_polygons;
    for (const auto& p : cell.vertices_px) {
      if (!with_polygon) break;
      const double x = std::round(p.x() + 0.5), y = std::round(p.y() + 0.5);
      if (!(x >= 0.0 && y >= 0.0 && x <= 65535.0 && y <= 65535.0))
        throw InputError("encode_planecells: cell " + std::to_string(cell.id) +
                         " has a vertex outside the image lattice (" + std::to_string(p.x()) +
                         ", " + std::to_string(p.y()) + ")");
      lattice.push_back({static_cast<std::int64_t>(x), static_cast<std::int64_t>(y)});
    }
    w.varint((static_cast<std::uint64_t>(lattice.size()) << 1) | (cell.has_plane ? 1u : 0u));
    for (std::size_t k = 0; k < lattice.size(); ++k) {
      const auto& ref = k == 0 ? previous_first : lattice[k - 1];
      w.varint(pair_code(zigzag(lattice[k][0] - ref[0]), zigzag(lattice[k][1] - ref[1])));
    }
    if (!lattice.empty()) previous_first = lattice.front();
    if (cell.has_plane) {
      const Eigen::Vector2d mu = centroid(lattice);
      const std::uint16_t a = to_half(cell.disparity_plane.a);
      const std::uint16_t b = to_half(cell.disparity_plane.b);
      // d̄ at the centroid: the decoded plane is exact there up to half a quantum (1/128 px).
      const double d_mean = cell.disparity_plane.at(mu.x(), mu.y());
      const double q = std::clamp(std::round(d_mean / kDisparityStep), -32768.0, 32767.0);
      w.u16(a);
      w.u16(b);
      w.u16(static_cast<std::uint16_t>(static_cast<std::int16_t>(q)));
    }
    w.u16(rgb565(cell.mean_rgb));
    if (options.include_statistics) {
      w.varint(cell.area_px);
      w.varint(cell.inlier_count);
      w.u8(static_cast<std::uint8_t>(
          std::clamp(std::round(cell.inlier_ratio * 255.0f), 0.0f, 255.0f)));
      w.u16(static_cast<std::uint16_t>(std::clamp(std::round(cell.depth_sigma_m * 100.0f), 0.0f, 65535.0f)));
    }
    if (options.include_histogram) {
      std::uint8_t nonzero = 0;
      for (float h : cell.histogram) nonzero += std::round(h * 255.0f) > 0.0f;
      w.u8(nonzero);
      for (int bin = 0; bin < kColourHistogramBins; ++bin) {
        const float q = std::round(cell.histogram[bin] * 255.0f);
        if (q <= 0.0f) continue;
        w.u8(static_cast<std::uint8_t>(bin));
        w.u8(static_cast<std::uint8_t>(std::min(q, 255.0f)));
      }
    }
  }
  w.u32(crc32(w.out));
  return std::move(w.out);
}

DecodedPlanecells decode_planecells(std::span<const std::uint8_t> bytes) {
  Reader r{bytes};
  if (bytes.size() < kMagic.size() + 2 + 4) r.fail("input too short for a planecell frame");
  for (std::uint8_t m : kMagic)
    if (r.u8("magic") != m) r.fail("bad magic (not a planecell frame)");
  const std::uint8_t version = r.u8("version");
  if (version != kPlanecellCodecVersion)
    r.fail("unsupported version " + std::to_string(version) + " (this build reads " +
           std::to_string(kPlanecellCodecVersion) + ")");
  // The checksum covers everything before it: verify before trusting any count.
  const std::uint32_t stored = static_cast<std::uint32_t>(bytes[bytes.size() - 4]) |
                               static_cast<std::uint32_t>(bytes[bytes.size() - 3]) << 8 |
                               static_cast<std::uint32_t>(bytes[bytes.size() - 2]) << 16 |
                               static_cast<std::uint32_t>(bytes[bytes.size() - 1]) << 24;
  if (crc32(bytes.first(bytes.size() - 4)) != stored)
    r.fail("checksum mismatch (corrupt or truncated frame)");
  r.in = bytes.first(bytes.size() - 4);

  DecodedPlanecells out;
  const std::uint8_t flags = r.u8("flags");
  if (flags & ~kKnownFlags) r.fail("unknown flags");
  const bool sequential = flags & kFlagSequentialIds;
  out.options.include_planeless_polygons = flags & kFlagPlanelessPolygons;
  out.options.include_histogram = flags & kFlagHistogram;
  out.options.include_statistics = flags & kFlagStatistics;
  out.frame_id = r.varint("frame id");
  out.camera.fx = r.f32("camera fx");
  out.camera.fy = r.f32("camera fy");
  out.camera.cx = r.f32("camera cx");
  out.camera.cy = r.f32("camera cy");
  out.camera.baseline_m = r.f32("camera baseline");
  const std::uint64_t width = r.varint("image width"), height = r.varint("image height");
  if (width > 65535 || height > 65535) r.fail("implausible image size");
  out.camera.width = static_cast<int>(width);
  out.camera.height = static_cast<int>(height);
  try {
    out.camera.validate("planecell codec camera");
  } catch (const ConfigError& e) {
    r.fail(e.what());
  }
  const std::uint64_t count = r.varint("cell count");
  if (count > r.remaining() / 3) r.fail("cell count " + std::to_string(count) + " too large");
  out.cells.resize(count);

  std::int64_t previous_id = -1;
  std::array<std::int64_t, 2> previous_first = {0, 0};
  std::vector<std::array<std::int64_t, 2>> lattice;
  for (Planecell& cell : out.cells) {
    const std::int64_t id = previous_id + 1 + (sequential ? 0 : r.svarint("cell id"));
    if (id < 0 || id > 0xFFFFFFFFll) r.fail("cell id out of range");
    cell.id = static_cast<std::uint32_t>(id);
    previous_id = id;
    cell.frame_id = out.frame_id;
    const std::uint64_t header = r.varint("vertex count");
    cell.has_plane = header & 1u;
    const std::uint64_t n_vertices = header >> 1;
    if (n_vertices > 0 && !cell.has_plane && !out.options.include_planeless_polygons)
      r.fail("polygon on a planeless cell");
    if (n_vertices > r.remaining() / 2) r.fail("vertex count too large");
    lattice.resize(n_vertices);
    for (std::uint64_t k = 0; k < n_vertices; ++k) {
      const auto& ref = k == 0 ? previous_first : lattice[k - 1];
      const std::uint64_t code = r.varint("vertex");
      if (code > (1ull << 40)) r.fail("vertex delta out of range");
      const auto [zx, zy] = unpair_code(code);
      lattice[k][0] = ref[0] + unzigzag(zx);
      lattice[k][1] = ref[1] + unzigzag(zy);
      if (lattice[k][0] < 0 || lattice[k][1] < 0 || lattice[k][0] > 65535 ||
          lattice[k][1] > 65535)
        r.fail("vertex outside the lattice");
    }
    if (!lattice.empty()) previous_first = lattice.front();
    cell.vertices_px.clear();
    for (const auto& q : lattice)
      cell.vertices_px.emplace_back(static_cast<float>(q[0]) - 0.5f,
                                    static_cast<float>(q[1]) - 0.5f);
    if (cell.has_plane) {
      const Eigen::Vector2d mu = centroid(lattice);
      const double a = from_half(r.u16("plane a"));
      const double b = from_half(r.u16("plane b"));
      const double d_mean = static_cast<std::int16_t>(r.u16("plane d")) * kDisparityStep;
      if (!std::isfinite(a) || !std::isfinite(b)) r.fail("non-finite plane");
      cell.disparity_plane = {a, b, d_mean - a * mu.x() - b * mu.y()};
      cell.plane = plane_from_disparity(cell.disparity_plane, out.camera);
      for (const auto& p : cell.vertices_px) {
        const double d = std::max(kMinVertexDisparityPx, cell.disparity_plane.at(p.x(), p.y()));
        cell.vertices_m.push_back(out.camera.back_project(p.x(), p.y(), d).cast<float>());
      }
    }
    cell.mean_rgb = from_rgb565(r.u16("mean colour"));
    if (out.options.include_statistics) {
      const std::uint64_t area = r.varint("area"), inliers = r.varint("inlier count");
      if (area > 0xFFFFFFFFull || inliers > 0xFFFFFFFFull) r.fail("statistics out of range");
      cell.area_px = static_cast<std::uint32_t>(area);
      cell.inlier_count = static_cast<std::uint32_t>(inliers);
      cell.inlier_ratio = r.u8("inlier ratio") / 255.0f;
      cell.depth_sigma_m = r.u16("depth sigma") / 100.0f;
    }
    if (out.options.include_histogram) {
      cell.histogram.fill(0.0f);
      const int nonzero = r.u8("histogram size");
      for (int k = 0; k < nonzero; ++k) {
        const int bin = r.u8("histogram bin");
        if (bin >= kColourHistogramBins) r.fail("histogram bin out of range");
        cell.histogram[bin] = r.u8("histogram value") / 255.0f;
      }
    }
  }
  if (r.remaining() != 0) r.fail(std::to_string(r.remaining()) + " trailing bytes");
  return out;
}

}  // namespace planecell::io
