/// The map store's blob encodings (io/map_codec): lossless in every version, compact where the map
/// rounded its values to storage precision, and corrupt blobs named, never misread.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <zlib.h>

#include "core/error.hpp"
#include "io/map_codec.hpp"
#include "mapping/map/geometry.hpp"
#include "support/expect_error.hpp"

namespace planecell::io {
namespace {

/// The message of the StorageError `fn` throws; a failure when it throws none.
template <class Fn>
std::string storage_error_of(Fn&& fn) {
  return test::error_of<StorageError>(std::forward<Fn>(fn));
}

/// A surface whose double reals (information, moments, basis) a float cannot hold: seeded random doubles (irregular mantissas, which
/// deflate cannot shorten, as in a real map).
map::Surface awkward_surface() {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> real(-10.0, 10.0);
  const auto vec = [&] { return Eigen::Vector3d(real(rng), real(rng), real(rng)); };
  map::Surface s;
  s.id = 7;
  s.plane = Plane3{vec().normalized(), real(rng)};  // kept as floats (map::StoredPlane)
  s.information = std::abs(real(rng));
  map::SurfaceDetail& d = s.detail.emplace(map::SurfaceDetail{});
  d.moment_sum = vec();
  d.moment_outer << vec(), vec(), vec();
  map::CompactHistogram::Bins bins{};
  for (std::size_t q = 0; q < bins.size(); ++q) bins[q] = static_cast<std::uint16_t>(q * q % 97);
  s.histogram = map::CompactHistogram(bins);
  s.histogram_weight_m2 = std::abs(real(rng));
  s.mean_rgb = {10.5f, 20.25f, 200.0f};
  s.observed_area_m2 = std::abs(real(rng));
  s.area_m2 = std::abs(real(rng));
  const Eigen::Vector3d lo = vec();
  s.bounds = map::Aabb{lo, lo + vec().cwiseAbs()};
  d.basis.origin = vec();
  d.basis.u = vec().normalized();
  d.basis.v = d.basis.u.unitOrthogonal();
  s.cells = {3, 900, 70000, 5};
  s.observations = 300;
  s.last_observed_frame = 123456789;
  s.frames_observed = 41;
  d.footprint = map::Footprint(0.1);
  const std::vector<Eigen::Vector2d> square{{0.0, 0.0}, {2.0, 0.0}, {2.0, 1.5}, {0.0, 1.5}};
  d.footprint.add_polygon(square);
  return s;
}

/// The same surface at the map's storage precision (what GlobalMap keeps).
map::Surface rounded(map::Surface s) {
  s.detail->basis = map::to_float_precision(s.detail->basis);  // plane, areas, bounds: floats already
  return s;
}

TEST(MapCodecTest, SurfaceRoundTripsExactlyInEveryVersion) {
  for (const map::Surface& s : {awkward_surface(), rounded(awkward_surface())})
    for (int version = map_codec::kOldestVersion; version <= map_codec::kCurrentVersion;
         ++version) {
      SCOPED_TRACE(version);
      const auto blob = map_codec::encode_surface(s, version);
      map::Surface expected = s;
      if (version < 7) expected.last_observed_frame = 0;  // not stored before version 7
      if (version < 8) expected.frames_observed = expected.observations;  // counted from 8 on
      EXPECT_TRUE(map::same_surface(
          map_codec::decode_surface(s.id, blob.data(), blob.size(), "test", version), expected));
    }
}

/// Inflates a deflated surface blob (versions 5–7) to its raw encoding.
std::vector<std::uint8_t> inflate_blob(const std::vector<std::uint8_t>& blob) {
  std::uint32_t raw_size = 0;
  std::memcpy(&raw_size, blob.data(), sizeof(raw_size));
  std::vector<std::uint8_t> raw(raw_size);
  auto size = static_cast<uLongf>(raw.size());
  EXPECT_EQ(uncompress(raw.data(), &size, blob.data() + sizeof(raw_size),
                       static_cast<uLong>(blob.size() - sizeof(raw_size))),
            Z_OK);
  return raw;
}

/// The deflated blob of a raw encoding (what encode_surface writes).
std::vector<std::uint8_t> deflate_blob(const std::vector<std::uint8_t>& raw) {
  std::vector<std::uint8_t> blob(sizeof(std::uint32_t) + compressBound(static_cast<uLong>(raw.size())));
  const auto raw_size = static_cast<std::uint32_t>(raw.size());
  std::memcpy(blob.data(), &raw_size, sizeof(raw_size));
  auto size = static_cast<uLongf>(blob.size() - sizeof(raw_size));
  EXPECT_EQ(compress2(blob.data() + sizeof(raw_size), &size, raw.data(), raw.size(), Z_DEFAULT_COMPRESSION),
            Z_OK);
  blob.resize(sizeof(raw_size) + size);
  return blob;
}

TEST(MapCodecTest, DormantSurfaceKeepsItsDescriptorOnlyAndNeedsVersion7) {
  map::Surface live = rounded(awkward_surface());
  map::Surface dormant = live;
  dormant.quiet_moments = map::quiet_moments_of(map::moments_of(live));
  dormant.detail.reset();
  const auto blob = map_codec::encode_surface(dormant);
  const map::Surface back = map_codec::decode_surface(dormant.id, blob.data(), blob.size(), "test");
  EXPECT_TRUE(map::same_surface(back, dormant));
  EXPECT_FALSE(back.detail.has_value());
  EXPECT_EQ(back.quiet_moments, dormant.quiet_moments);
  // The detail is most of a surface's bytes: 12 moment doubles, the basis and a footprint tile,
  // against 9 floats of quiet moments.
  const auto live_raw = inflate_blob(map_codec::encode_surface(live));
  const auto dormant_raw = inflate_blob(blob);
  EXPECT_EQ(live_raw.size() - dormant_raw.size(),
            12 * sizeof(double) + (1 + 3 * 4) + (1 + 6 * 4) + sizeof(double) + 1 +
                live.detail->footprint.tiles().size() * sizeof(map::FootprintTile) -
                9 * sizeof(float));
  // Versions before 7 had no dormant surfaces: refused, not written without its detail.
  EXPECT_CONTAINS(storage_error_of([&] { (void)map_codec::encode_surface(dormant, 6); }),
                  "surface 7 is dormant: store version 6 cannot hold it");
  // A flag byte other than 0 or 1 is named.
  auto bad_flag = dormant_raw;
  const std::size_t flag_at = bad_flag.size() - 1 - 9 * sizeof(float);
  ASSERT_EQ(bad_flag[flag_at], 0);
  bad_flag[flag_at] = 2;
  const auto bad_blob = deflate_blob(bad_flag);
  EXPECT_CONTAINS(storage_error_of([&] {
                    (void)map_codec::decode_surface(7, bad_blob.data(), bad_blob.size(), "store");
                  }),
                  "store: surface 7: detail flag 2 is neither 0 nor 1");
}

TEST(MapCodecTest, HistogramTakesTwoBytesPerNonZeroBin) {
  map::Surface s = rounded(awkward_surface());
  s.detail.reset();
  s.histogram = map::CompactHistogram();
  const auto empty = inflate_blob(map_codec::encode_surface(s));
  map::CompactHistogram::Bins bins{};
  bins[0] = 65535, bins[17] = 1, bins[63] = 300;
  s.histogram = map::CompactHistogram(bins);
  const auto blob = map_codec::encode_surface(s);
  const auto raw = inflate_blob(blob);
  EXPECT_EQ(raw.size(), empty.size() + 3 * sizeof(std::uint16_t));
  const map::Surface back = map_codec::decode_surface(s.id, blob.data(), blob.size(), "test");
  EXPECT_EQ(back.histogram.bins(), bins);
  // A bin the mask marks but that holds 0 is corrupt: named, not read as an empty bin. The mask
  // follows the plane's real group (1 flag byte, 4 floats) and the information (a double).
  auto zero_bin = raw;
  const std::size_t first_value = 1 + 4 * sizeof(float) + sizeof(double) + sizeof(std::uint64_t);
  zero_bin[first_value] = 0, zero_bin[first_value + 1] = 0;
  const auto bad = deflate_blob(zero_bin);
  EXPECT_CONTAINS(storage_error_of([&] {
                    (void)map_codec::decode_surface(7, bad.data(), bad.size(), "store");
                  }),
                  "store: surface 7: histogram bin 0 is marked non-zero but holds 0");
}

/// At storage precision the plane, areas, bounds and basis (22 reals) go as floats: 88 bytes
/// fewer before deflate, which cannot shorten irregular IEEE mantissas.
TEST(MapCodecTest, SurfaceAtStoragePrecisionTakesTheShortForm) {
  const auto full = map_codec::encode_surface(awkward_surface());
  const auto compact = map_codec::encode_surface(rounded(awkward_surface()));
  // Plane, areas and bounds are floats in both (map::Surface keeps them so); the rounded
  // basis's nine reals take 4 bytes instead of 8: 36 bytes less before deflate.
  EXPECT_LT(compact.size() + 24, full.size()) << compact.size() << " vs " << full.size();
  const auto v5 = map_codec::encode_surface(rounded(awkward_surface()), 5);
  // Version 5 wrote those floats as doubles: their zero low mantissa bytes deflate, but not to
  // nothing.
  EXPECT_LT(compact.size(), v5.size());
}

TEST(MapCodecTest, PlaneRoundTripsExactlyAndShortWhenFloat) {
  const Plane3 awkward{Eigen::Vector3d(0.0, 0.6, 0.8), -1.0 / 3.0};  // 0.6, 0.8, 1/3: no floats
  for (const Plane3& p : {awkward, map::to_float_precision(awkward)})
    for (int version : {5, 6}) {
      const auto blob = map_codec::encode_plane(p, version);
      const Plane3 back = map_codec::decode_plane(blob.data(), blob.size(), "test", version);
      EXPECT_EQ(back.normal, p.normal);
      EXPECT_EQ(back.offset, p.offset);
    }
  EXPECT_EQ(map_codec::encode_plane(awkward).size(), 1u + 4 * sizeof(double));
  EXPECT_EQ(map_codec::encode_plane(map::to_float_precision(awkward)).size(),
            1u + 4 * sizeof(float));
}

TEST(MapCodecTest, MillimetreVerticesTakeVarintsOthersStayRaw) {
  // A 3 m × 2 m cell 250 m away, snapped to the millimetre grid: first vertex 3 × 3 varint
  // bytes (±250 000 mm), then differences of ≤ 3 000 mm (2 bytes each).
  std::vector<Eigen::Vector3f> cell{{250.123f, -12.5f, 1.7f},
                                    {253.123f, -12.5f, 1.7f},
                                    {253.123f, -12.5f, 3.7f},
                                    {250.123f, -12.5f, 3.7f}};
  map::snap_to_mm(cell);
  const auto blob = map_codec::encode_vertices(cell);
  EXPECT_EQ(blob[0], 1);
  EXPECT_LT(blob.size(), 1 + 9 + 3 * 6 + 1);
  EXPECT_EQ(map_codec::decode_vertices(blob.data(), blob.size(), "test"), cell);

  // Off the grid, negative zero, beyond ±10⁹ m or NaN: raw floats, bit for bit.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (const Eigen::Vector3f odd : {Eigen::Vector3f(0.1234567f, 1, 2), Eigen::Vector3f(-0.0f, 1, 2),
                                    Eigen::Vector3f(2e9f, 1, 2), Eigen::Vector3f(nan, 1, 2)}) {
    std::vector<Eigen::Vector3f> with_odd = cell;
    with_odd.push_back(odd);
    const auto raw = map_codec::encode_vertices(with_odd);
    EXPECT_EQ(raw[0], 0);
    EXPECT_EQ(raw.size(), 1 + with_odd.size() * sizeof(Eigen::Vector3f));
    const auto back = map_codec::decode_vertices(raw.data(), raw.size(), "test");
    ASSERT_EQ(back.size(), with_odd.size());
    EXPECT_EQ(std::memcmp(back.data(), with_odd.data(), back.size() * sizeof(Eigen::Vector3f)), 0);
  }
  // Version 5 wrote raw floats with no tag.
  const auto v5 = map_codec::encode_vertices(cell, 5);
  EXPECT_EQ(v5.size(), cell.size() * sizeof(Eigen::Vector3f));
  EXPECT_EQ(map_codec::decode_vertices(v5.data(), v5.size(), "test", 5), cell);
}

TEST(MapCodecTest, SnapToMmIsTheGridTheCodecReads) {
  EXPECT_EQ(map::snap_to_mm(1.23449f), 1.234f);
  EXPECT_EQ(map::snap_to_mm(-7.0006f), -7.001f);
  EXPECT_EQ(map::snap_to_mm(3e9f), 3e9f);  // beyond ±10⁹ m: unchanged
  EXPECT_EQ(map::to_float_precision(0.1), static_cast<double>(0.1f));
}

TEST(MapCodecTest, CorruptBlobsAreNamedNotMisread) {
  std::vector<Eigen::Vector3f> cell{{1.0f, 2.0f, 3.0f}, {1.5f, 2.0f, 3.0f}, {1.5f, 2.5f, 3.0f}};
  auto blob = map_codec::encode_vertices(cell);
  ASSERT_EQ(blob[0], 1);
  auto bad_tag = blob;
  bad_tag[0] = 2;
  EXPECT_CONTAINS(storage_error_of([&] {
                    (void)map_codec::decode_vertices(bad_tag.data(), bad_tag.size(),
                                                     "cell 4 vertices_m");
                  }),
                  "cell 4 vertices_m: vertex encoding tag 2");
  auto cut = blob;
  cut.back() |= 0x80;  // the last varint now claims a byte that is not there
  EXPECT_CONTAINS(storage_error_of([&] {
                    (void)map_codec::decode_vertices(cut.data(), cut.size(), "cell 4 vertices_m");
                  }),
                  "truncated");
  auto plane = map_codec::encode_plane(Plane3{});
  plane[0] = 9;
  EXPECT_CONTAINS(storage_error_of([&] {
                    (void)map_codec::decode_plane(plane.data(), plane.size(), "cell 4 plane");
                  }),
                  "cell 4 plane: real group flag 9");
  EXPECT_CONTAINS(storage_error_of([&] { (void)map_codec::encode_plane(Plane3{}, 9); }),
                  "store version 9");
}

}  // namespace
}  // namespace planecell::io
