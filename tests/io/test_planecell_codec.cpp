/// Planecell codec: round trip (exact lattice vertices, planes within the quantisation, 3D
/// recomputed), compactness, and clear errors on truncated, corrupted or foreign bytes; PLY.
#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <sstream>

#include "core/error.hpp"
#include "io/planecell_codec.hpp"
#include "io/ply_export.hpp"
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
    c.vertices_px = {{x0, y0}, {x0 + 24, y0}, {x0 + 24, y0 + 24}, {x0 + 10, y0 + 30}, {x0, y0 + 24}};
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
        c.vertices_m.push_back(camera.back_project(p.x(), p.y(), c.disparity_plane.at(p.x(), p.y()))
                                   .cast<float>());
    }
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
  bytes[3] = 99;
  try {
    decode_planecells(bytes);
    FAIL() << "version 99 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("version 99"), std::string::npos) << e.what();
  }
}

TEST(PlanecellCodecSize, CompactFormCostsAboutNineteenBytesPerCell) {
  // Per planar cell: 1 (count|flag) + 5 vertices × 2 (paired 24 px deltas) + 6 (plane) + 2
  // (colour) = 19 bytes; a planeless cell: 1 + 2 = 3 bytes; header 32 + CRC 4. The very first
  // vertex costs one byte less, each of the 15 jumps to a new row of cells two more.
  const auto cells = make_cells(800);
  std::size_t planeless = 0;
  for (const auto& c : cells) planeless += !c.has_plane;
  const auto bytes = encode_planecells(cells, StereoCamera{}, 1);
  const std::size_t base = 36 + (800 - planeless) * 19 + planeless * 3;
  EXPECT_EQ(bytes.size(), base - 1 + 15 * 2);
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

TEST(PlyExport, WritesFansThatMatchTheHeader) {
  test::ScratchDir dir;
  const auto cells = make_cells(10);
  int with_plane = 0;
  for (const auto& c : cells) with_plane += c.has_plane;
  const std::size_t triangles = write_planecells_ply(dir / "cells.ply", cells, false);
  EXPECT_EQ(triangles, static_cast<std::size_t>(with_plane) * 5);
  std::ifstream in(dir / "cells.ply");
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  EXPECT_NE(s.find("element vertex " + std::to_string(with_plane * 6)), std::string::npos);
  EXPECT_NE(s.find("element face " + std::to_string(triangles)), std::string::npos);
  const std::size_t binary_triangles = write_planecells_ply(dir / "cells_bin.ply", cells, true);
  EXPECT_EQ(binary_triangles, triangles);
  std::ifstream bin(dir / "cells_bin.ply", std::ios::binary);
  std::stringstream bin_text;
  bin_text << bin.rdbuf();
  const auto header_end = bin_text.str().find("end_header\n") + 11;
  // Binary body: 15 bytes per vertex, 13 per face.
  EXPECT_EQ(std::filesystem::file_size(dir / "cells_bin.ply"),
            header_end + with_plane * 6 * 15 + triangles * 13);
  EXPECT_THROW(write_planecells_ply("/proc/no/such/dir/cells.ply", cells), StorageError);
}

}  // namespace
}  // namespace planecell::io
