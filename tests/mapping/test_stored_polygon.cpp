/// The map's compact polygons (mapping/map/stored_polygon): vertices on the 1 mm grid come back
/// bit for bit from 6 bytes a vertex; anything else keeps its floats, also bit for bit.
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <vector>

#include "mapping/map/stored_polygon.hpp"

namespace planecell::map {
namespace {

/// Bit-for-bit equality of the decoded vertices with `expected`.
void expect_same_bits(const StoredPolygon& polygon, const std::vector<Eigen::Vector3f>& expected) {
  ASSERT_EQ(polygon.size(), expected.size());
  const std::vector<Eigen::Vector3f> back = polygon.vertices();
  for (std::size_t i = 0; i < expected.size(); ++i)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(std::bit_cast<std::uint32_t>(back[i][k]), std::bit_cast<std::uint32_t>(expected[i][k]))
          << "vertex " << i << " coordinate " << k << ": " << back[i][k] << " vs " << expected[i][k];
}

std::vector<Eigen::Vector3f> on_grid(std::vector<Eigen::Vector3f> vertices) {
  snap_to_mm(vertices);
  return vertices;
}

TEST(StoredPolygonTest, GridVerticesComeBackExactlyFromSixBytesEach) {
  // A 3 m × 2 m facade cell 1234 km out, snapped to the mm grid: x = float(k / 1000).
  const std::vector<Eigen::Vector3f> facade = on_grid({{1234567.891f, 1.5f, -20.25f},
                                                       {1234570.891f, 1.5f, -20.25f},
                                                       {1234570.891f, -0.5f, -20.251f},
                                                       {1234567.891f, -0.5f, -20.249f}});
  const StoredPolygon stored(facade);
  EXPECT_TRUE(stored.compact());
  EXPECT_EQ(stored.bytes(), 4u + 3 * 4u + 3 * 3 * 2u);  // header, anchor int32 ×3, int16 ×3 a vertex
  expect_same_bits(stored, facade);
  EXPECT_EQ(stored[2], facade[2]);
  EXPECT_EQ(stored.front(), facade.front());
  EXPECT_EQ(stored.back(), facade.back());
  std::vector<Eigen::Vector3f> iterated(stored.begin(), stored.end());
  EXPECT_EQ(iterated, facade);
  EXPECT_EQ(stored.bounds(), bounds_of(facade));
  const StoredPolygon copy = stored;
  EXPECT_EQ(copy, stored);
  EXPECT_NE(StoredPolygon(std::span(facade).first(3)), stored);
}

TEST(StoredPolygonTest, OffTheGridOrTooWideKeepsItsFloats) {
  const Eigen::Vector3f a(0.0f, 0.0f, 5.0f), b(1.0f, 0.0f, 5.0f), c(1.0f, 1.0f, 5.0f);
  // 1/3 m is no grid point; the −0 would come back +0 from millimetres.
  for (const Eigen::Vector3f& odd : {Eigen::Vector3f(1.0f / 3.0f, 1.0f, 5.0f),
                                     Eigen::Vector3f(-0.0f, 1.0f, 5.0f)}) {
    const std::vector<Eigen::Vector3f> polygon{a, b, c, odd};
    const StoredPolygon stored(polygon);
    EXPECT_FALSE(stored.compact());
    EXPECT_EQ(stored.bytes(), 4u + 4 * sizeof(Eigen::Vector3f));
    expect_same_bits(stored, polygon);
  }
  // Offsets from the first vertex fit an int16 up to ±32.767 m.
  const std::vector<Eigen::Vector3f> widest{a, {32.767f, 0.0f, 5.0f}, {0.0f, -32.767f, 5.0f}};
  EXPECT_TRUE(StoredPolygon(on_grid(widest)).compact());
  const std::vector<Eigen::Vector3f> wider = on_grid({a, {32.768f, 0.0f, 5.0f}, c});
  const StoredPolygon wide(wider);
  EXPECT_FALSE(wide.compact());
  expect_same_bits(wide, wider);
  // Beyond ±2000 km the millimetres would leave an int32: floats.
  const std::vector<Eigen::Vector3f> far{{3.0e6f, 0.0f, 0.0f}, {3.0e6f, 1.0f, 0.0f}, {3.0e6f, 1.0f, 1.0f}};
  EXPECT_FALSE(StoredPolygon(far).compact());
  expect_same_bits(StoredPolygon(far), far);
  EXPECT_TRUE(StoredPolygon().empty());
  EXPECT_EQ(StoredPolygon().bytes(), 0u);
  EXPECT_EQ(StoredPolygon(), StoredPolygon(std::vector<Eigen::Vector3f>{}));
}

TEST(StoredPolygonTest, OnMmGridSnapsThenStoresCompactly) {
  const std::vector<Eigen::Vector3f> raw{{0.1234f, 0.0f, 5.0f}, {1.0f, 0.0004f, 5.0f}, {1.0f, 1.0f, 5.0006f}};
  const StoredPolygon stored = on_mm_grid(raw);
  EXPECT_TRUE(stored.compact());
  const std::vector<Eigen::Vector3f> expected{{0.123f, 0.0f, 5.0f}, {1.0f, 0.0f, 5.0f}, {1.0f, 1.0f, 5.001f}};
  expect_same_bits(stored, expected);
}

}  // namespace
}  // namespace planecell::map
