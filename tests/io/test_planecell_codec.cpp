/// Planecell codec: round trip (exact lattice vertices, planes within the quantisation, 3D
/// recomputed), compactness (shared boundaries coded once), and clear errors on truncated,
/// corrupted, foreign or inconsistent bytes; PLY.
#include <gtest/gtest.h>

#include <bit>
#include <fstream>
#include <opencv2/core.hpp>
#include <random>
#include <sstream>

#include "core/error.hpp"
#include "io/planecell_codec.hpp"
#include "io/ply_export.hpp"
#include "mapping/planecell/vertex_extraction.hpp"
#include "support/expect_error.hpp"
#include "support/test_data.hpp"

namespace planecell::io {
namespace {

/// A deterministic set of cells: squares on a grid with slanted planes, one planeless.
std::vector<Planecell> make_cells(int n) {
  std::vector<Planecell> cells(n);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> slope(-0.01, 0.01);  // d > 4 px over the image
  std::uniform_real_distribution<double> offset(20.0, 80.0);
  StereoCamera camera;
  for (int k = 0; k < n; ++k) {
    Planecell& c = cells[k];
    c.id = static_cast<std::uint32_t>(k);
    const float x0 = 24.0f * (k % 50) - 0.5f, y0 = 24.0f * (k / 50) - 0.5f;
    c.vertices_px = {
        {x0, y0}, {x0 + 24, y0}, {x0 + 24, y0 + 24}, {x0 + 10, y0 + 30}, {x0, y0 + 24}};
    c.has_plane = k % 17 != 3;
    c.disparity_plane = {slope(rng), slope(rng), offset(rng)};
    c.mean_rgb = Eigen::Vector3f(k % 256, (3 * k) % 256, 200);
    c.area_px = 600 + k;
    c.inlier_count = 500;
    c.inlier_ratio = 0.8f;
    c.depth_sigma_m = 0.05f + 0.37f * static_cast<float>(k % 100);
    c.histogram.fill(0.0f);
    c.histogram[k % 64] = 0.75f;
    c.histogram[(k + 9) % 64] = 0.25f;
    if (c.has_plane) {
      c.plane = plane_from_disparity(c.disparity_plane, camera);
      for (const auto& p : c.vertices_px)
        c.vertices_m.push_back(
            camera.back_project(p.x(), p.y(), c.disparity_plane.at(p.x(), p.y())).cast<float>());
    }
  }
  return cells;
}

/// A cell on the pixel-corner lattice: `corners` are lattice points (x + ½, y + ½ of the pixel
/// coordinates), in polygon order.
Planecell lattice_cell(std::uint32_t id, std::vector<std::array<int, 2>> corners,
                       bool has_plane = true) {
  Planecell c;
  c.id = id;
  c.has_plane = has_plane;
  c.disparity_plane = {0.001 * id, -0.002, 30.0 + id};
  c.mean_rgb = Eigen::Vector3f(40.0f * id, 100, 200);
  for (const auto& q : corners)
    c.vertices_px.emplace_back(static_cast<float>(q[0]) - 0.5f, static_cast<float>(q[1]) - 0.5f);
  return c;
}

/// The geometry codes of the layout (planecell_codec.hpp), written by hand for expected streams
/// and corrupted ones: bits most significant first.
struct GeometryBits {
  std::vector<bool> bits;
  GeometryBits& put(std::uint64_t v, int n) {
    for (int k = n - 1; k >= 0; --k) bits.push_back((v >> k) & 1u);
    return *this;
  }
  GeometryBits& eg(std::uint64_t u, int k) {  // EG_k
    const std::uint64_t q = (u >> k) + 1;
    const int width = std::bit_width(q);
    return put(0, width - 1).put(q, width).put(u, k);
  }
  GeometryBits& seg(std::int64_t s, int k) {  // SEG_k
    return eg(s >= 0 ? 2 * static_cast<std::uint64_t>(s) : 2 * static_cast<std::uint64_t>(-s) - 1,
              k);
  }
  GeometryBits& count(std::uint64_t v, std::uint64_t c) {  // C_c (ranks below 15 only)
    const std::uint64_t rank = v < c ? 2 * (c - v) - 1 : v <= 2 * c ? 2 * (v - c) : v;
    EXPECT_LT(rank, 15u);
    return put((std::uint64_t{1} << rank) - 1, static_cast<int>(rank)).put(0, 1);
  }
  std::vector<std::uint8_t> bytes() const {
    std::vector<std::uint8_t> out((bits.size() + 7) / 8, 0);
    for (std::size_t k = 0; k < bits.size(); ++k)
      if (bits[k]) out[k / 8] |= static_cast<std::uint8_t>(0x80u >> (k % 8));
    return out;
  }
};

std::size_t skip_varint(const std::vector<std::uint8_t>& bytes, std::size_t pos) {
  while (bytes.at(pos) & 0x80) ++pos;
  return pos + 1;
}

/// Where a frame's geometry section lies: [begin, end) of its bit stream, and where its size
/// varint starts.
struct GeometrySection {
  std::size_t size_at, begin, end;
};
GeometrySection geometry_section(const std::vector<std::uint8_t>& frame) {
  std::size_t pos = skip_varint(frame, 5) + 20;  // magic, version, flags; frame id; camera
  for (int k = 0; k < 3; ++k) pos = skip_varint(frame, pos);  // width, height, cell count
  std::uint64_t size = 0;
  const std::size_t size_at = pos;
  for (int shift = 0;; shift += 7) {
    const std::uint8_t b = frame.at(pos++);
    size |= static_cast<std::uint64_t>(b & 0x7F) << shift;
    if (!(b & 0x80)) break;
  }
  return {size_at, pos, pos + size};
}
std::vector<std::uint8_t> geometry_of(const std::vector<std::uint8_t>& frame) {
  const GeometrySection g = geometry_section(frame);
  return {frame.begin() + static_cast<std::ptrdiff_t>(g.begin),
          frame.begin() + static_cast<std::ptrdiff_t>(g.end)};
}

/// `frame` with its geometry section replaced and the CRC made valid again: what a buggy or
/// hostile encoder could send.
std::vector<std::uint8_t> with_geometry(const std::vector<std::uint8_t>& frame,
                                        const std::vector<std::uint8_t>& geometry) {
  const GeometrySection g = geometry_section(frame);
  std::vector<std::uint8_t> out(frame.begin(),
                                frame.begin() + static_cast<std::ptrdiff_t>(g.size_at));
  std::size_t size = geometry.size();
  for (; size >= 0x80; size >>= 7) out.push_back(static_cast<std::uint8_t>(size | 0x80));
  out.push_back(static_cast<std::uint8_t>(size));
  out.insert(out.end(), geometry.begin(), geometry.end());
  out.insert(out.end(), frame.begin() + static_cast<std::ptrdiff_t>(g.end), frame.end() - 4);
  const std::uint32_t crc = planecell_codec_crc32(out);
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<std::uint8_t>(crc >> (8 * k)));
  return out;
}

/// A Voronoi tiling of a 240 × 120 image by jittered 20 px seeds, labels renumbered in raster
/// order of their first pixel and junction-only polygons, as extraction makes them; every 11th
/// cell planeless.
std::vector<Planecell> voronoi_cells() {
  const int w = 240, h = 120, step = 20;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-6.0, 6.0);
  std::vector<Eigen::Vector2d> seeds;
  for (int y = step / 2; y < h; y += step)
    for (int x = step / 2; x < w; x += step) seeds.emplace_back(x + jitter(rng), y + jitter(rng));
  cv::Mat labels(h, w, CV_32S);
  std::vector<int> renumber(seeds.size(), -1);
  int next = 0;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      std::size_t best = 0;
      for (std::size_t k = 1; k < seeds.size(); ++k)
        if ((seeds[k] - Eigen::Vector2d(u, v)).squaredNorm() <
            (seeds[best] - Eigen::Vector2d(u, v)).squaredNorm())
          best = k;
      if (renumber[best] < 0) renumber[best] = next++;
      labels.at<std::int32_t>(v, u) = renumber[best];
    }
  const auto polygons = extraction::extract_polygons(labels, next, 1.0, true);
  std::vector<Planecell> cells(next);
  for (int k = 0; k < next; ++k) {
    cells[k].id = static_cast<std::uint32_t>(k);
    cells[k].has_plane = k % 11 != 5;
    cells[k].disparity_plane = {0.01, -0.005, 20.0 + k % 7};
    cells[k].mean_rgb = Eigen::Vector3f(k % 256, 90, 30);
    cells[k].vertices_px = polygons[k];
  }
  return cells;
}

class PlanecellCodec : public ::testing::TestWithParam<PlanecellCodecOptions> {};

TEST_P(PlanecellCodec, RoundTripKeepsGeometryWithinQuantisation) {
  const StereoCamera camera;
  const auto cells = make_cells(120);
  const auto bytes = encode_planecells(cells, camera, 42, GetParam());
  const DecodedPlanecells decoded = decode_planecells(bytes);
  EXPECT_EQ(decoded.frame_id, 42u);
  EXPECT_NEAR(decoded.camera.fx, camera.fx, 1e-4);
  EXPECT_NEAR(decoded.camera.baseline_m, camera.baseline_m, 1e-6);
  EXPECT_EQ(decoded.camera.width, camera.width);
  ASSERT_EQ(decoded.cells.size(), cells.size());
  for (std::size_t k = 0; k < cells.size(); ++k) {
    const Planecell& a = cells[k];
    const Planecell& b = decoded.cells[k];
    EXPECT_EQ(b.id, a.id);
    EXPECT_EQ(b.frame_id, 42u);
    EXPECT_EQ(b.has_plane, a.has_plane);
    // RGB 5-6-5: within half a step (4.1 for red/blue, 2.0 for green).
    EXPECT_NEAR(b.mean_rgb.x(), a.mean_rgb.x(), 4.2f);
    EXPECT_NEAR(b.mean_rgb.y(), a.mean_rgb.y(), 2.1f);
    EXPECT_NEAR(b.mean_rgb.z(), a.mean_rgb.z(), 4.2f);
    if (!a.has_plane && !GetParam().include_planeless_polygons) {
      EXPECT_TRUE(b.vertices_px.empty());  // planeless cells travel without geometry
      EXPECT_TRUE(b.vertices_m.empty());
      continue;
    }
    ASSERT_EQ(b.vertices_px.size(), a.vertices_px.size());
    for (std::size_t j = 0; j < a.vertices_px.size(); ++j)
      EXPECT_EQ(b.vertices_px[j], a.vertices_px[j]);  // lattice vertices are exact
    if (!a.has_plane) {
      EXPECT_TRUE(b.vertices_m.empty());
      continue;
    }
    // The plane agrees within 0.02 px over the cell.
    for (const auto& p : a.vertices_px)
      EXPECT_NEAR(b.disparity_plane.at(p.x(), p.y()), a.disparity_plane.at(p.x(), p.y()), 0.02);
    ASSERT_EQ(b.vertices_m.size(), a.vertices_m.size());
    for (std::size_t j = 0; j < a.vertices_m.size(); ++j) {
      EXPECT_NEAR(b.plane.signed_distance(b.vertices_m[j].cast<double>()), 0.0, 1e-4);
      EXPECT_LT((b.vertices_m[j] - a.vertices_m[j]).norm(), 2e-3 * a.vertices_m[j].norm());
    }
    if (GetParam().include_statistics) {
      EXPECT_EQ(b.area_px, a.area_px);
      EXPECT_EQ(b.inlier_count, a.inlier_count);
      EXPECT_NEAR(b.inlier_ratio, a.inlier_ratio, 1.0 / 255);
      EXPECT_NEAR(b.depth_sigma_m, a.depth_sigma_m, 0.005 + 1e-6);  // centimetre quantum
    }
    if (GetParam().include_histogram) {
      for (int bin = 0; bin < kColourHistogramBins; ++bin)
        EXPECT_NEAR(b.histogram[bin], a.histogram[bin], 0.5 / 255 + 1e-6);
    }
  }
}

TEST_P(PlanecellCodec, TruncatedOrCorruptedBytesThrowInputError) {
  const auto bytes = encode_planecells(make_cells(20), StereoCamera{}, 7, GetParam());
  for (std::size_t cut = 0; cut < bytes.size(); cut += 3) {
    const std::span<const std::uint8_t> prefix(bytes.data(), cut);
    EXPECT_THROW(decode_planecells(prefix), InputError) << "cut at " << cut;
  }
  for (std::size_t k = 0; k < bytes.size(); k += 5) {
    auto flipped = bytes;
    flipped[k] ^= 0x24;
    EXPECT_THROW(decode_planecells(flipped), InputError) << "flipped byte " << k;
  }
  auto longer = bytes;
  longer.push_back(0);
  EXPECT_THROW(decode_planecells(longer), InputError);
}

INSTANTIATE_TEST_SUITE_P(Options, PlanecellCodec,
                         ::testing::Values(PlanecellCodecOptions{false, false, false},
                                           PlanecellCodecOptions{true, true, true}));

TEST(PlanecellCodecErrors, ChecksumIsTheIeeeCrc32) {
  // The CRC-32 check value of the ASCII digits "123456789" (IEEE 802.3, as zlib computes it).
  const std::string digits = "123456789";
  const std::vector<std::uint8_t> bytes(digits.begin(), digits.end());
  EXPECT_EQ(planecell_codec_crc32(bytes), 0xCBF43926u);
  EXPECT_EQ(planecell_codec_crc32({}), 0u);
}

TEST(PlanecellCodecErrors, GarbageAndForeignVersionsAreRejectedWithReasons) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<std::uint8_t> garbage(1 + rng() % 300);
    for (auto& b : garbage) b = static_cast<std::uint8_t>(rng());
    if (trial % 2 == 0 && garbage.size() > 4) {  // looks like ours up to the version
      garbage[0] = 'P';
      garbage[1] = 'C';
      garbage[2] = 'L';
      garbage[3] = 1;
    }
    EXPECT_THROW(decode_planecells(garbage), InputError);
  }
  auto bytes = encode_planecells(make_cells(3), StereoCamera{}, 1);
  // Version 2 (pairwise vertex deltas, no shared boundaries) is refused by name.
  bytes[3] = 2;
  EXPECT_CONTAINS(test::input_error_of([&] { decode_planecells(bytes); }),
                  "unsupported version 2 (this build reads 3)");
  bytes[3] = 99;
  try {
    decode_planecells(bytes);
    FAIL() << "version 99 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("version 99"), std::string::npos) << e.what();
  }
}

TEST(PlanecellCodecSize, CompactFormCostsAboutFifteenBytesPerCell) {
  // Records: 6 (plane) + 2 (colour) bytes per planar cell, 2 per planeless one; header 32, the
  // geometry size 2, CRC 4. Geometry: 1 bit per planeless cell; a planar cell inside the grid
  // (these pentagons overlap their neighbours, so little is shared) takes 65 bits: has_plane 1,
  // u = 3 (its top-left is 1 frontier place after its left neighbour's) 3, b = 0 (the oldest
  // open edge out of it leads to the above-left cell's point, not down) 4, f = 0 2, m = 4 5,
  // fresh (24, 0) (0, 24) (−14, 6) (−10, −6) 12 + 12 + 14 + 12 (v2: 88 bits).
  const auto cells = make_cells(800);
  std::size_t planeless = 0;
  for (const auto& c : cells) planeless += !c.has_plane;
  const std::size_t planar = 800 - planeless;
  const auto bytes = encode_planecells(cells, StereoCamera{}, 1);
  const std::size_t geometry = geometry_of(bytes).size();
  EXPECT_EQ(bytes.size(), 32 + 2 + geometry + planar * 8 + planeless * 2 + 4);
  // The first row and the cells after a planeless one have less to code, nothing has more.
  EXPECT_LE(geometry * 8, planar * 65 + planeless + 7);
  EXPECT_GE(geometry * 8, planar * 60);
  const auto full = encode_planecells(cells, StereoCamera{}, 1, {true, true, true});
  EXPECT_GT(full.size(), bytes.size() + 800 * 6);
  // Non-sequential ids are stored (one byte each for gaps of 1).
  auto shuffled = cells;
  for (auto& c : shuffled) c.id = 2 * c.id;
  EXPECT_EQ(encode_planecells(shuffled, StereoCamera{}, 1).size(), bytes.size() + 800);
  EXPECT_EQ(decode_planecells(encode_planecells(shuffled, StereoCamera{}, 1)).cells[7].id, 14u);
}

TEST(PlanecellCodecErrors, VertexOffTheImageLatticeIsRejected) {
  auto cells = make_cells(1);
  cells[0].vertices_px[1] = {-7.0f, 3.0f};
  EXPECT_THROW(encode_planecells(cells, StereoCamera{}, 1), InputError);
}

TEST(PlanecellCodecSharing, TwoSquaresSharingAnEdgeCodeAsTheLayoutSays) {
  // Lattice squares A = (0,0) (10,0) (10,10) (0,10) and B = (10,0) (20,0) (20,10) (10,10): B's
  // edge (10,10) → (10,0) runs A's edge (10,0) → (10,10) backwards.
  const std::vector<Planecell> cells = {lattice_cell(0, {{0, 0}, {10, 0}, {10, 10}, {0, 10}}),
                                        lattice_cell(1, {{10, 0}, {20, 0}, {20, 10}, {10, 10}})};
  GeometryBits expected;
  // A, nothing known yet: has_plane, u = 0 (explicit), n = 4, v_0 − (0, 0), three fresh deltas:
  // 1 + 3 + 5 + 2·6 + 3·10 = 51 bits.
  expected.put(1, 1).eg(0, 2).count(4, 2).seg(0, 5).seg(0, 5);
  expected.seg(10, 3).seg(0, 3).seg(0, 3).seg(10, 3).seg(-10, 3).seg(0, 3);
  ASSERT_EQ(expected.bits.size(), 51u);
  // B: the frontier is (0,0) (10,0) (0,10) (10,10) in (y, x) order; v_0 = (10,0) is 1 place after
  // A's v_0: u = zig-zag(1) + 1 = 3. Backward run b = 1 ((10,10) along A's open edge), forward
  // run f = 0 (the open edge into (10,0) comes from (0,0), not (20,0)), m = 2 fresh vertices:
  // 1 + 3 + 2 + 2 + 1 + 2·10 = 29 bits (51 coded alone).
  expected.put(1, 1).eg(3, 2).count(1, 2).count(0, 1).count(2, 2);
  expected.seg(10, 3).seg(0, 3).seg(0, 3).seg(10, 3);
  ASSERT_EQ(expected.bits.size(), 80u);

  const auto bytes = encode_planecells(cells, StereoCamera{}, 3);
  EXPECT_EQ(geometry_of(bytes), expected.bytes());  // 10 bytes
  const auto alone = encode_planecells({lattice_cell(0, {{10, 0}, {20, 0}, {20, 10}, {10, 10}})},
                                       StereoCamera{}, 3);
  EXPECT_EQ(geometry_of(alone).size(), 7u);  // 1 + 3 + 5 + 12 + 30 = 51 bits
  const DecodedPlanecells decoded = decode_planecells(bytes);
  ASSERT_EQ(decoded.cells.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) EXPECT_EQ(decoded.cells[k].vertices_px, cells[k].vertices_px);
}

TEST(PlanecellCodecSharing, ExtractedTilingRoundTripsExactlyInLessThanHalfTheStandaloneBits) {
  const std::vector<Planecell> cells = voronoi_cells();
  ASSERT_GE(cells.size(), 60u);
  for (const PlanecellCodecOptions options :
       {PlanecellCodecOptions{}, PlanecellCodecOptions{false, false, true}}) {
    std::size_t vertices = 0;
    for (const auto& c : cells)
      if (c.has_plane || options.include_planeless_polygons) vertices += c.vertices_px.size();
    ASSERT_GT(vertices, 4 * cells.size());
    const auto bytes = encode_planecells(cells, StereoCamera{}, 5, options);
    const DecodedPlanecells decoded = decode_planecells(bytes);
    ASSERT_EQ(decoded.cells.size(), cells.size());
    for (std::size_t k = 0; k < cells.size(); ++k) {
      ASSERT_EQ(decoded.cells[k].has_plane, cells[k].has_plane);
      if (cells[k].has_plane || options.include_planeless_polygons)
        EXPECT_EQ(decoded.cells[k].vertices_px, cells[k].vertices_px) << "cell " << k;
      else
        EXPECT_TRUE(decoded.cells[k].vertices_px.empty());
    }
    // Each polygon in a frame of its own (nothing shared) against the tiling: geometry bytes.
    std::size_t standalone = 0;
    for (const Planecell& c : cells) {
      Planecell alone = c;
      alone.id = 0;
      standalone += geometry_of(encode_planecells({alone}, StereoCamera{}, 5, options)).size();
    }
    const std::size_t shared = geometry_of(bytes).size();
    EXPECT_LT(2 * shared, standalone);
    // Under a byte per vertex (v2: two on most), though a third of these cells touch the border,
    // whose edges nobody shares (real frames: 6.5 bits).
    EXPECT_LT(shared, vertices);
  }
}

TEST(PlanecellCodecErrors, ReferencesToMissingVerticesOrEdgesAreInputErrors) {
  // Frames of planeless cells with polygons: the records are 2 colour bytes each, so a hand-made
  // geometry section (with a valid CRC) is all the decoder sees.
  auto frame_of = [](int n_cells, const GeometryBits& geometry) {
    std::vector<Planecell> cells;
    for (int k = 0; k < n_cells; ++k) cells.push_back(lattice_cell(k, {}, false));
    return with_geometry(encode_planecells(cells, StereoCamera{}, 9, {false, false, true}),
                         geometry.bytes());
  };
  // Cell 0: the explicit triangle (0,0) (8,0) (0,8); its three edges are open.
  auto triangle = [] {
    GeometryBits g;
    g.put(0, 1).eg(0, 2).count(3, 2).seg(0, 5).seg(0, 5).seg(8, 3).seg(0, 3).seg(-8, 3).seg(8, 3);
    return g;
  };
  {
    GeometryBits ok = triangle();
    ok.put(0, 1).eg(1, 2).count(2, 2).count(0, 1).count(0, 2);  // cell 1 = the same triangle
    const DecodedPlanecells decoded = decode_planecells(frame_of(2, ok));
    ASSERT_EQ(decoded.cells.size(), 2u);
    const std::vector<Eigen::Vector2f> expected = {{-0.5f, -0.5f}, {-0.5f, 7.5f}, {7.5f, -0.5f}};
    EXPECT_EQ(decoded.cells[1].vertices_px, expected);  // (0,0), then b = 2 back: (0,8), (8,0)
  }
  struct Case {
    const char* what;
    GeometryBits geometry;
    int cells;
    const char* message;
  };
  std::vector<Case> cases;
  cases.push_back({"a first vertex while none is known", GeometryBits{}.put(0, 1).eg(1, 2), 1,
                   "first vertex refers to no vertex"});
  cases.push_back({"a first vertex past the frontier", triangle().put(0, 1).eg(11, 2), 2,
                   "first vertex refers to no vertex"});
  cases.push_back({"a first vertex reference too far", triangle().put(0, 1).eg(5000, 2), 2,
                   "first vertex reference out of range"});
  cases.push_back({"a backward run longer than the shared boundary",
                   triangle().put(0, 1).eg(1, 2).count(9, 2), 2, "backward run longer"});
  cases.push_back({"a forward run longer than the shared boundary",
                   triangle().put(0, 1).eg(1, 2).count(0, 2).count(9, 1), 2, "forward run longer"});
  cases.push_back({"a vertex off the lattice",
                   GeometryBits{}.put(0, 1).eg(0, 2).count(1, 2).seg(-5, 5).seg(0, 5), 1,
                   "first vertex outside the lattice"});
  cases.push_back(
      {"a fresh vertex off the lattice",
       triangle().put(0, 1).eg(1, 2).count(0, 2).count(0, 1).count(1, 2).seg(-3, 3).seg(0, 3), 2,
       "fresh vertex outside the lattice"});
  cases.push_back({"more vertices than bits",
                   GeometryBits{}.put(0, 1).eg(0, 2).put(0xFFFF, 15).eg(5000, 0), 1,
                   "vertex count too large"});
  cases.push_back({"more fresh vertices than bits",
                   triangle().put(0, 1).eg(1, 2).count(0, 2).count(0, 1).put(0x7FFF, 15).eg(900, 0),
                   2, "fresh vertex count too large"});
  cases.push_back({"a code with 41 leading zeros", GeometryBits{}.put(0, 1).put(0, 41).put(1, 1), 1,
                   "over-long code in first vertex"});
  cases.push_back({"too few cells in the stream", GeometryBits{}.put(0, 1).eg(0, 2).count(0, 2), 2,
                   "truncated geometry while reading has-plane bit"});
  cases.push_back({"a byte past the last polygon",
                   GeometryBits{}.put(0, 1).eg(0, 2).count(0, 2).put(0, 8), 1,
                   "1 bytes past the last polygon"});
  cases.push_back({"set padding bits",
                   GeometryBits{}.put(0, 1).eg(0, 2).count(1, 2).seg(0, 5).seg(0, 5).put(1, 6), 1,
                   "non-zero padding"});
  for (const Case& c : cases) {
    const std::string message =
        test::input_error_of([&] { decode_planecells(frame_of(c.cells, c.geometry)); });
    EXPECT_CONTAINS(message, c.message) << c.what;
    EXPECT_CONTAINS(message, "at byte") << c.what;
  }
}

TEST(PlanecellCodecErrors, MutatedGeometryWithAValidChecksumDecodesOrThrowsInputError) {
  // The checksum stops random corruption; a stream that passes it (a buggy or hostile encoder)
  // must still decode to something or fail cleanly — and whatever decodes must re-encode.
  std::vector<Planecell> cells = voronoi_cells();
  cells.resize(30);
  const auto bytes = encode_planecells(cells, StereoCamera{}, 5, {false, false, true});
  const std::vector<std::uint8_t> geometry = geometry_of(bytes);
  std::mt19937 rng(17);
  int decoded = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    std::vector<std::uint8_t> mutated = geometry;
    for (int flips = 1 + static_cast<int>(rng() % 3); flips > 0; --flips)
      mutated[rng() % mutated.size()] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
    if (trial % 5 == 0) mutated.resize(rng() % mutated.size());
    try {
      const DecodedPlanecells d = decode_planecells(with_geometry(bytes, mutated));
      ++decoded;
      const auto again = encode_planecells(d.cells, d.camera, d.frame_id, d.options);
      ASSERT_EQ(decode_planecells(again).cells.size(), cells.size());
    } catch (const InputError&) {
    }
  }
  EXPECT_LT(decoded, 3000);
}

TEST(PlyExport, WritesTrianglesThatMatchTheHeader) {
  test::ScratchDir dir;
  const auto cells = make_cells(10);
  int with_plane = 0;
  for (const auto& c : cells) with_plane += c.has_plane;
  const std::size_t triangles = write_planecells_ply(dir / "cells.ply", cells, false);
  EXPECT_EQ(triangles, static_cast<std::size_t>(with_plane) * 3);  // pentagons: n − 2 each
  std::ifstream in(dir / "cells.ply");
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  EXPECT_NE(s.find("element vertex " + std::to_string(with_plane * 5)), std::string::npos);
  EXPECT_NE(s.find("element face " + std::to_string(triangles)), std::string::npos);
  const std::size_t binary_triangles = write_planecells_ply(dir / "cells_bin.ply", cells, true);
  EXPECT_EQ(binary_triangles, triangles);
  std::ifstream bin(dir / "cells_bin.ply", std::ios::binary);
  std::stringstream bin_text;
  bin_text << bin.rdbuf();
  const auto header_end = bin_text.str().find("end_header\n") + 11;
  // Binary body: 15 bytes per vertex, 13 per face.
  EXPECT_EQ(std::filesystem::file_size(dir / "cells_bin.ply"),
            header_end + with_plane * 5 * 15 + triangles * 13);
  EXPECT_THROW(write_planecells_ply("/proc/no/such/dir/cells.ply", cells), StorageError);
}

}  // namespace
}  // namespace planecell::io
