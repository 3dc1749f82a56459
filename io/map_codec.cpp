#include "io/map_codec.hpp"

#include <zlib.h>

#include <array>
#include <cmath>
#include <cstring>
#include <optional>
#include <span>

#include "core/error.hpp"
#include "io/blob_bytes.hpp"
#include "mapping/map/geometry.hpp"

namespace planecell::io::map_codec {
namespace {

using blob::Reader;
using blob::Writer;

void check_version(int version) {
  if (version < kOldestVersion || version > kCurrentVersion)
    throw StorageError("map codec: store version " + std::to_string(version) + " is not in [" +
                       std::to_string(kOldestVersion) + ", " + std::to_string(kCurrentVersion) +
                       "]");
}

/// A group of reals: flag 1 and floats when every value is exactly a float, else flag 0 and
/// doubles.
void put_reals(Writer& w, std::span<const double> values) {
  bool floats = true;
  for (double x : values) floats = floats && map::to_float_precision(x) == x;
  // NaN never equals itself: a NaN group is written as doubles, bit for bit.
  w.put(static_cast<std::uint8_t>(floats ? 1 : 0));
  for (double x : values) floats ? w.put(static_cast<float>(x)) : w.put(x);
}

void get_reals(Reader& r, std::span<double> values) {
  const auto flag = r.get<std::uint8_t>();
  if (flag > 1)
    throw StorageError(r.what() + ": real group flag " + std::to_string(flag) +
                       " is neither 0 nor 1");
  for (double& x : values) x = flag == 1 ? static_cast<double>(r.get<float>()) : r.get<double>();
}

template <int N>
void get_reals(Reader& r, Eigen::Matrix<double, N, 1>& v) {
  get_reals(r, std::span<double>(v.data(), N));
}

std::uint64_t zigzag(std::int64_t v) {
  return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
std::int64_t unzigzag(std::uint64_t u) {
  return static_cast<std::int64_t>(u >> 1) ^ -static_cast<std::int64_t>(u & 1);
}

/// The millimetre count k with float(k / 1000) == x, if there is one within ±10⁹ m.
std::optional<std::int64_t> whole_mm(float x) {
  if (!(std::abs(x) < 1e9f) || (x == 0.0f && std::signbit(x))) return std::nullopt;  // -0 stays raw
  const std::int64_t k = std::llround(static_cast<double>(x) * 1000.0);
  if (map::from_mm(k) != x) return std::nullopt;
  return k;
}

/// A footprint: resolution (double), tile count (u32, or a varint when `varint_count`), each tile
/// as s, t (i32) and its 32 rows (u32).
void put_footprint(Writer& w, const map::Footprint& footprint, bool varint_count) {
  w.put(footprint.resolution_m());
  varint_count ? w.put_varint(footprint.tiles().size())
               : w.put(static_cast<std::uint32_t>(footprint.tiles().size()));
  for (const auto& tile : footprint.tiles()) {
    w.put(tile.s), w.put(tile.t);
    for (std::uint32_t row : tile.rows) w.put(row);
  }
}

map::Footprint get_footprint(Reader& r, std::size_t blob_size, bool varint_count) {
  const auto resolution_m = r.get<double>();
  if (!(resolution_m > 0.0 && resolution_m <= 10.0))
    throw StorageError(r.what() + " has an invalid footprint resolution");
  std::size_t tile_count = 0;
  if (varint_count) {
    tile_count = r.get_varint();
    if (tile_count > blob_size / sizeof(map::FootprintTile))
      throw StorageError(r.what() + ": tile count " + std::to_string(tile_count) +
                         " exceeds the blob");
  } else {
    tile_count = r.count(sizeof(map::FootprintTile));
  }
  std::vector<map::FootprintTile> tiles(tile_count);
  for (auto& tile : tiles) {
    tile.s = r.get<std::int32_t>(), tile.t = r.get<std::int32_t>();
    for (std::uint32_t& row : tile.rows) row = r.get<std::uint32_t>();
  }
  try {
    return map::Footprint::from_tiles(resolution_m, std::move(tiles));
  } catch (const StorageError& e) {
    throw StorageError(r.what() + ": " + e.what());
  }
}

/// A basis as two real groups: origin, then u and v.
void put_basis(Writer& w, const map::PlaneBasis& b) {
  put_reals(w, std::array{b.origin.x(), b.origin.y(), b.origin.z()});
  put_reals(w, std::array{b.u.x(), b.u.y(), b.u.z(), b.v.x(), b.v.y(), b.v.z()});
}

void get_basis(Reader& r, map::PlaneBasis& b) {
  get_reals(r, b.origin);
  std::array<double, 6> uv{};
  get_reals(r, uv);
  b.u = {uv[0], uv[1], uv[2]};
  b.v = {uv[3], uv[4], uv[5]};
}

/// A count or id read as a varint, refused beyond 2³² − 1.
std::uint32_t get_u32_varint(Reader& r, const char* what) {
  const auto v = r.get_varint();
  if (v > UINT32_MAX) throw StorageError(r.what() + ": " + what + " beyond 2^32");
  return static_cast<std::uint32_t>(v);
}

/// Versions 6 and 7: the histogram weight and areas, the mean colour (floats) and the bounds, as
/// real groups.
void put_areas_colour_bounds(Writer& w, const map::Surface& s) {
  put_reals(w, std::array<double, 3>{s.histogram_weight_m2, s.observed_area_m2, s.area_m2});
  w.put_matrix(s.mean_rgb);
  const Eigen::Vector3d lo = s.bounds.min(), hi = s.bounds.max();
  put_reals(w, std::array{lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z()});
}

void get_areas_colour_bounds(Reader& r, map::Surface& s) {
  std::array<double, 3> areas{};
  get_reals(r, areas);
  s.histogram_weight_m2 = static_cast<float>(areas[0]);
  s.observed_area_m2 = static_cast<float>(areas[1]);
  s.area_m2 = static_cast<float>(areas[2]);
  r.get_matrix(s.mean_rgb);
  std::array<double, 6> bounds{};
  get_reals(r, bounds);
  s.bounds = map::Aabb{{bounds[0], bounds[1], bounds[2]}, {bounds[3], bounds[4], bounds[5]}};
}

/// The raw surface encoding of `version` ≤ 6 (a live surface: these versions had no dormant
/// ones): 3–5 doubles and u32 counts as they are; 6 reals as float groups where exact
/// (put_reals), counts and ids as varints.
std::vector<std::uint8_t> encode_surface_legacy(const map::Surface& s, int version) {
  if (!s.detail)
    throw StorageError("surface " + std::to_string(s.id) + " is dormant: store version " +
                       std::to_string(version) + " cannot hold it (7 can)");
  const map::SurfaceDetail& d = *s.detail;
  const bool v6 = version >= 6;
  Writer w;
  const auto reals = [&](std::initializer_list<double> values) {
    if (v6) return put_reals(w, std::span<const double>(values.begin(), values.size()));
    for (double x : values) w.put(x);
  };
  const auto count = [&](std::size_t n) {
    v6 ? w.put_varint(n) : w.put(static_cast<std::uint32_t>(n));
  };
  const Eigen::Vector3d n = s.plane.normal();
  reals({n.x(), n.y(), n.z(), s.plane.offset()});
  w.put(s.information);
  w.put_matrix(d.moment_sum);
  w.put_matrix(d.moment_outer);
  for (std::uint16_t h : s.histogram.bins()) w.put(h);
  if (v6) {
    put_areas_colour_bounds(w, s);
  } else {  // version 5 kept the colour between the histogram weight and the areas
    w.put(double{s.histogram_weight_m2});
    w.put_matrix(s.mean_rgb);
    w.put(double{s.observed_area_m2});
    w.put(double{s.area_m2});
    w.put_matrix(s.bounds.min());
    w.put_matrix(s.bounds.max());
  }
  reals({d.basis.origin.x(), d.basis.origin.y(), d.basis.origin.z()});
  reals({d.basis.u.x(), d.basis.u.y(), d.basis.u.z(), d.basis.v.x(), d.basis.v.y(), d.basis.v.z()});
  count(s.observations);
  count(s.cells.size());
  for (auto id : s.cells) v6 ? w.put_varint(id) : w.put(id);
  put_footprint(w, d.footprint, v6);
  return std::move(w.bytes);
}

/// Decodes encode_surface_legacy's bytes into a live surface (last_observed_frame 0: the caller
/// sets it).
map::Surface decode_surface_legacy(std::uint32_t id, const void* data, std::size_t size,
                                   const std::string& where, int version) {
  Reader r(data, size, where + ": surface " + std::to_string(id));
  map::Surface s;
  s.id = id;
  map::SurfaceDetail& d = s.detail.emplace(map::SurfaceDetail{});
  const bool v6 = version >= 6;
  if (v6) {
    std::array<double, 4> plane{};
    get_reals(r, plane);
    s.plane = Plane3{{plane[0], plane[1], plane[2]}, plane[3]};
  } else {
    Plane3 plane;
    r.get_matrix(plane.normal);
    plane.offset = r.get<double>();
    s.plane = plane;
  }
  s.information = r.get<double>();
  r.get_matrix(d.moment_sum);
  r.get_matrix(d.moment_outer);
  map::CompactHistogram::Bins bins{};
  for (std::uint16_t& h : bins) h = r.get<std::uint16_t>();
  s.histogram = map::CompactHistogram(bins);
  if (v6) {
    get_areas_colour_bounds(r, s);
    get_basis(r, d.basis);
    s.observations = get_u32_varint(r, "observation count");
    const auto cells = r.get_varint();
    if (cells > size)
      throw StorageError(r.what() + ": cell count " + std::to_string(cells) + " exceeds the blob");
    s.cells.resize(cells);
    for (auto& c : s.cells) c = get_u32_varint(r, "cell id");
  } else {
    s.histogram_weight_m2 = static_cast<float>(r.get<double>());
    r.get_matrix(s.mean_rgb);
    s.observed_area_m2 = static_cast<float>(r.get<double>());
    s.area_m2 = static_cast<float>(r.get<double>());
    map::Aabb bounds;
    r.get_matrix(bounds.min);
    r.get_matrix(bounds.max);
    s.bounds = bounds;
    r.get_matrix(d.basis.origin);
    r.get_matrix(d.basis.u);
    r.get_matrix(d.basis.v);
    s.observations = r.get<std::uint32_t>();
    s.cells.resize(r.count(sizeof(std::uint32_t)));
    for (auto& c : s.cells) c = r.get<std::uint32_t>();
  }
  d.footprint = get_footprint(r, size, v6);
  r.expect_end();
  s.frames_observed = s.observations;  // before version 8: the observations stand in
  return s;
}

/// Version 7's raw surface encoding. Reals as in 6 (float groups where exact); the information Σw
/// as a double; the histogram as a 64-bit mask of its non-zero bins and those bins' u16 values;
/// counts, the last observed frame, (version 8) the frames that observed it and the cell ids as
/// varints (the ids as zigzag differences from the previous one); then a flag byte: 1 and the
/// detail (moment sums as 12 doubles, basis, footprint) for a live surface, 0 and its quiet
/// moments (9 floats) for a dormant one.
std::vector<std::uint8_t> encode_surface_v7(const map::Surface& s, int version) {
  Writer w;
  const Eigen::Vector3d n = s.plane.normal();
  put_reals(w, std::array{n.x(), n.y(), n.z(), s.plane.offset()});
  w.put(s.information);
  w.put(s.histogram.mask());
  for (std::uint16_t h : s.histogram.nonzero()) w.put(h);
  put_areas_colour_bounds(w, s);
  w.put_varint(s.observations);
  w.put_varint(s.last_observed_frame);
  if (version >= 8) w.put_varint(s.frames_observed);
  w.put_varint(s.cells.size());
  std::int64_t previous = 0;
  for (std::uint32_t id : s.cells) {
    w.put_varint(zigzag(std::int64_t{id} - previous));
    previous = id;
  }
  w.put(static_cast<std::uint8_t>(s.detail ? 1 : 0));
  if (s.detail) {
    const map::SurfaceDetail& d = *s.detail;
    w.put_matrix(d.moment_sum);
    w.put_matrix(d.moment_outer);
    put_basis(w, d.basis);
    put_footprint(w, d.footprint, true);
  } else {
    w.put_matrix(s.quiet_moments.mean);
    for (float c : s.quiet_moments.covariance) w.put(c);
  }
  return std::move(w.bytes);
}

map::Surface decode_surface_v7(std::uint32_t id, const void* data, std::size_t size,
                               const std::string& where, int version) {
  Reader r(data, size, where + ": surface " + std::to_string(id));
  map::Surface s;
  s.id = id;
  std::array<double, 4> plane{};
  get_reals(r, plane);
  s.plane = Plane3{{plane[0], plane[1], plane[2]}, plane[3]};
  s.information = r.get<double>();
  const auto mask = r.get<std::uint64_t>();
  map::CompactHistogram::Bins bins{};
  for (std::size_t q = 0; q < bins.size(); ++q)
    if ((mask >> q) & 1) {
      bins[q] = r.get<std::uint16_t>();
      if (bins[q] == 0)
        throw StorageError(r.what() + ": histogram bin " + std::to_string(q) +
                           " is marked non-zero but holds 0");
    }
  s.histogram = map::CompactHistogram(bins);
  get_areas_colour_bounds(r, s);
  s.observations = get_u32_varint(r, "observation count");
  s.last_observed_frame = r.get_varint();
  // Before version 8 a surface did not count its frames: its observations stand in (a surface
  // holding one observation is unconfirmed, as it was then).
  s.frames_observed = version >= 8 ? get_u32_varint(r, "frame count") : s.observations;
  const auto cells = r.get_varint();
  if (cells > size)
    throw StorageError(r.what() + ": cell count " + std::to_string(cells) + " exceeds the blob");
  s.cells.resize(cells);
  std::uint64_t previous = 0;  // unsigned: a corrupt difference wraps, no overflow
  for (auto& c : s.cells) {
    previous += static_cast<std::uint64_t>(unzigzag(r.get_varint()));
    if (previous > UINT32_MAX) throw StorageError(r.what() + ": cell id beyond 2^32");
    c = static_cast<std::uint32_t>(previous);
  }
  const auto has_detail = r.get<std::uint8_t>();
  if (has_detail > 1)
    throw StorageError(r.what() + ": detail flag " + std::to_string(has_detail) +
                       " is neither 0 nor 1");
  if (has_detail == 1) {
    map::SurfaceDetail& d = s.detail.emplace(map::SurfaceDetail{});
    r.get_matrix(d.moment_sum);
    r.get_matrix(d.moment_outer);
    get_basis(r, d.basis);
    d.footprint = get_footprint(r, size, true);
  } else {
    r.get_matrix(s.quiet_moments.mean);
    for (float& c : s.quiet_moments.covariance) c = r.get<float>();
  }
  r.expect_end();
  return s;
}

std::vector<std::uint8_t> encode_surface_raw(const map::Surface& s, int version) {
  return version >= 7 ? encode_surface_v7(s, version) : encode_surface_legacy(s, version);
}

map::Surface decode_surface_raw(std::uint32_t id, const void* data, std::size_t size,
                                const std::string& where, int version) {
  return version >= 7 ? decode_surface_v7(id, data, size, where, version)
                      : decode_surface_legacy(id, data, size, where, version);
}

/// Largest raw surface encoding a stored blob may claim (a corrupt size is refused, not allocated):
/// 64 MiB ≈ 490 000 footprint tiles, tens of km² at the default 10 cm footprint resolution.
constexpr std::uint32_t kMaxRawSurfaceBytes = 64u << 20;

}  // namespace

/// Versions 5 and 6: the raw encoding's size (u32, little-endian), then the raw encoding deflated
/// as a zlib stream (RFC 1950, what zlib's compress2/uncompress read and write). The footprint's
/// occupancy bits and the 64-bin histogram are mostly zeros and runs.
std::vector<std::uint8_t> encode_surface(const map::Surface& s, int version) {
  check_version(version);
  const std::vector<std::uint8_t> raw = encode_surface_raw(s, version);
  if (raw.size() > kMaxRawSurfaceBytes)
    throw StorageError("surface " + std::to_string(s.id) + ": encoding of " +
                       std::to_string(raw.size()) + " bytes exceeds the store's limit of " +
                       std::to_string(kMaxRawSurfaceBytes));
  if (version <= 4) return raw;
  std::vector<std::uint8_t> out(sizeof(std::uint32_t) +
                                compressBound(static_cast<uLong>(raw.size())));
  const auto raw_size = static_cast<std::uint32_t>(raw.size());
  std::memcpy(out.data(), &raw_size, sizeof(raw_size));
  auto deflated = static_cast<uLongf>(out.size() - sizeof(raw_size));
  if (compress2(out.data() + sizeof(raw_size), &deflated, raw.data(), raw.size(),
                Z_DEFAULT_COMPRESSION) != Z_OK)
    throw StorageError("surface " + std::to_string(s.id) + ": zlib cannot deflate its encoding");
  out.resize(sizeof(raw_size) + deflated);
  return out;
}

map::Surface decode_surface(std::uint32_t id, const void* data, std::size_t size,
                            const std::string& where, int version) {
  check_version(version);
  if (version <= 4) return decode_surface_raw(id, data, size, where, version);
  const std::string what = where + ": surface " + std::to_string(id);
  Reader r(data, size, what);
  const auto raw_size = r.get<std::uint32_t>();
  if (raw_size > kMaxRawSurfaceBytes)
    throw StorageError(what + ": claims " + std::to_string(raw_size) +
                       " bytes, beyond the limit of " + std::to_string(kMaxRawSurfaceBytes));
  std::vector<std::uint8_t> raw(raw_size);
  auto inflated = static_cast<uLongf>(raw.size());
  const int rc =
      uncompress(raw.data(), &inflated, static_cast<const Bytef*>(data) + sizeof(raw_size),
                 static_cast<uLong>(size - sizeof(raw_size)));
  if (rc != Z_OK || inflated != raw_size)
    throw StorageError(what + ": compressed data is corrupt (zlib: " +
                       (rc == Z_OK ? std::string("size mismatch") : std::string(zError(rc))) + ")");
  return decode_surface_raw(id, raw.data(), raw.size(), where, version);
}

std::vector<std::uint8_t> encode_plane(const Plane3& plane, int version) {
  check_version(version);
  Writer w;
  if (version >= 6) {
    put_reals(w, std::array{plane.normal.x(), plane.normal.y(), plane.normal.z(), plane.offset});
  } else {
    w.put_matrix(plane.normal);
    w.put(plane.offset);
  }
  return std::move(w.bytes);
}

Plane3 decode_plane(const void* data, std::size_t size, const std::string& what, int version) {
  check_version(version);
  Reader r(data, size, what);
  Plane3 plane;
  if (version >= 6) {
    std::array<double, 4> v{};
    get_reals(r, v);
    plane.normal = {v[0], v[1], v[2]};
    plane.offset = v[3];
  } else {
    r.get_matrix(plane.normal);
    plane.offset = r.get<double>();
  }
  r.expect_end();
  return plane;
}

std::vector<std::uint8_t> encode_vertices(const std::vector<Eigen::Vector3f>& vertices,
                                          int version) {
  check_version(version);
  Writer w;
  if (version >= 6) {
    std::vector<std::int64_t> mm;
    mm.reserve(3 * vertices.size());
    bool on_grid = true;
    for (const auto& v : vertices)
      for (int i = 0; i < 3 && on_grid; ++i) {
        const auto k = whole_mm(v(i));
        on_grid = k.has_value();
        if (on_grid) mm.push_back(*k);
      }
    w.put(static_cast<std::uint8_t>(on_grid ? 1 : 0));
    if (on_grid) {
      std::array<std::int64_t, 3> previous{};
      for (std::size_t k = 0; k < mm.size(); ++k) {
        w.put_varint(zigzag(mm[k] - previous[k % 3]));
        previous[k % 3] = mm[k];
      }
      return std::move(w.bytes);
    }
  }
  for (const auto& v : vertices) w.put_matrix(v);
  return std::move(w.bytes);
}

std::vector<Eigen::Vector3f> decode_vertices(const void* data, std::size_t size,
                                             const std::string& what, int version) {
  check_version(version);
  Reader r(data, size, what);
  std::uint8_t tag = 0;
  if (version >= 6) {
    tag = r.get<std::uint8_t>();
    if (tag > 1)
      throw StorageError(what + ": vertex encoding tag " + std::to_string(tag) +
                         " is neither 0 nor 1");
  }
  std::vector<Eigen::Vector3f> out;
  if (tag == 1) {
    std::array<std::uint64_t, 3> previous{};  // unsigned: a corrupt delta wraps, no overflow
    while (!r.at_end()) {
      Eigen::Vector3f v;
      for (int i = 0; i < 3; ++i) {
        previous[i] += static_cast<std::uint64_t>(unzigzag(r.get_varint()));
        v(i) = map::from_mm(static_cast<std::int64_t>(previous[i]));
      }
      out.push_back(v);
    }
    out.shrink_to_fit();  // the map keeps it: no growth slack (a cell's polygon never grows)
    return out;
  }
  const std::size_t rest = size - (version >= 6 ? 1 : 0);
  if (rest % sizeof(Eigen::Vector3f) != 0)
    throw StorageError(what + ": blob size " + std::to_string(rest) + " is not a multiple of " +
                       std::to_string(sizeof(Eigen::Vector3f)));
  out.resize(rest / sizeof(Eigen::Vector3f));
  for (auto& v : out) r.get_matrix(v);
  return out;
}

}  // namespace planecell::io::map_codec
