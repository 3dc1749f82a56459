/// Polygon gaps of the map's geometry (mapping/map/geometry): hand-computed distances between
/// squares, and polygons_within_m deciding exactly polygon_gap_m ≤ max on random pairs.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mapping/map/geometry.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::map {
namespace {

using test::rect_cell;

using test::kX;
using test::kY;
using test::kZ;

TEST(MapGeometry, GapsBetweenHandPlacedSquares) {
  const Planecell a = rect_cell(0, {0, 0, 0}, kX, kZ, 0);          // y = 0, x, z ∈ [0, 1]
  const Planecell beside = rect_cell(1, {1.5f, 0, 0}, kX, kZ, 0);  // 0.5 m along x
  const Planecell above = rect_cell(2, {0.25f, -0.2f, 0.25f}, 0.5f * kX, 0.5f * kZ, 0);  // 0.2 m over a
  const Planecell wall = rect_cell(3, {0, -1, 1.3f}, kX, kY, 0);   // vertical, 0.3 m past a's edge
  EXPECT_NEAR(polygon_gap_m(a.plane, a.vertices_m, beside.plane, beside.vertices_m), 0.5, 1e-6);
  EXPECT_NEAR(polygon_gap_m(a.plane, a.vertices_m, above.plane, above.vertices_m), 0.2, 1e-6);
  EXPECT_NEAR(polygon_gap_m(a.plane, a.vertices_m, wall.plane, wall.vertices_m), 0.3, 1e-6);
  for (const auto& [other, gap] : {std::pair{&beside, 0.5}, {&above, 0.2}, {&wall, 0.3}}) {
    EXPECT_TRUE(polygons_within_m(a.plane, a.vertices_m, other->plane, other->vertices_m, gap + 1e-3));
    EXPECT_FALSE(polygons_within_m(a.plane, a.vertices_m, other->plane, other->vertices_m, gap - 1e-3));
  }
}

TEST(MapGeometry, PointToSegmentDistancesByHand) {
  const Eigen::Vector3d a(-1, 0, 0), b(1, 0, 0);
  // Foot of the perpendicular inside the segment: the distance is the height over it.
  EXPECT_DOUBLE_EQ(point_segment_squared_distance({0.5, 1, 2}, a, b), 5.0);
  EXPECT_DOUBLE_EQ(point_segment_distance({0.5, 3, 4}, a, b), 5.0);
  // Beyond an end the nearest point is that end: (3, 0, 0) is 2 m from b.
  EXPECT_DOUBLE_EQ(point_segment_squared_distance({3, 0, 0}, a, b), 4.0);
  EXPECT_DOUBLE_EQ(point_segment_squared_distance({-2, 1, 0}, a, b), 2.0);
  // A point segment: the distance to that point.
  EXPECT_DOUBLE_EQ(point_segment_squared_distance({1, 2, 2}, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), 9.0);
}

/// Random squares (sizes 0.2–2 m, any orientation, centres within 3 m): the pruned test agrees
/// with the full minimum at thresholds on both sides of every pair's gap.
TEST(MapGeometry, WithinTestAgreesWithTheFullGapOnRandomPairs) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> centre(-1.5f, 1.5f), size(0.2f, 2.0f), unit(-1.0f, 1.0f);
  auto random_square = [&](std::uint32_t id) {
    Eigen::Vector3f e1(unit(rng), unit(rng), unit(rng)), e2(unit(rng), unit(rng), unit(rng));
    e1.normalize();
    e2 = (e2 - e2.dot(e1) * e1).normalized();
    return rect_cell(id, {centre(rng), centre(rng), centre(rng)}, size(rng) * e1, size(rng) * e2, 0);
  };
  int near_pairs = 0, far_pairs = 0;  // at the fixed 0.3 m threshold
  for (int trial = 0; trial < 500; ++trial) {
    const Planecell a = random_square(0), b = random_square(1);
    const double gap = polygon_gap_m(a.plane, a.vertices_m, b.plane, b.vertices_m);
    for (const double max_m : {0.1, 0.3, 1.0, gap - 1e-4, gap + 1e-4}) {
      const bool expected = gap <= max_m;
      if (max_m == 0.3) (expected ? near_pairs : far_pairs) += 1;
      ASSERT_EQ(polygons_within_m(a.plane, a.vertices_m, b.plane, b.vertices_m, max_m), expected)
          << "trial " << trial << " gap " << gap << " max " << max_m;
    }
  }
  EXPECT_GT(near_pairs, 50);  // both outcomes are exercised
  EXPECT_GT(far_pairs, 50);
}

TEST(MapGeometry, StoredPlaneKeepsAFloatPlaneExactlyAndRoundsOthersToFloat) {
  const Plane3 awkward{Eigen::Vector3d(0.0, 0.6, 0.8), -1.0 / 3.0};  // no float among them
  const Plane3 rounded = to_float_precision(awkward);
  const Plane3 back = StoredPlane(rounded);
  EXPECT_EQ(back.normal, rounded.normal);
  EXPECT_EQ(back.offset, rounded.offset);
  const StoredPlane stored(awkward);
  EXPECT_EQ(stored.normal(), rounded.normal);
  EXPECT_EQ(stored.offset(), rounded.offset);
  EXPECT_NE(stored.offset(), awkward.offset);
  // n·X + e at X = (0, 0, 1/0.8 · 1/3): zero for the exact plane, float rounding for the stored.
  const Eigen::Vector3d on_plane(0.0, 0.0, 1.0 / 3.0 / 0.8);
  EXPECT_NEAR(stored.signed_distance(on_plane), 0.0, 1e-7);
  EXPECT_NEAR(stored.signed_distance(on_plane + 2.0 * awkward.normal), 2.0, 1e-7);
}

TEST(MapGeometry, StoredBoxKeepsAFloatBoxExactlyAndRoundsOthersOutwards) {
  const Aabb floats{Eigen::Vector3d(-1.5, 0.25, 3.0), Eigen::Vector3d(2.0, 0.75, 1e6)};
  EXPECT_EQ(Aabb(StoredBox(floats)), floats);
  // 1/3 and 2/3 are no floats: the stored box must still contain the exact one, by one float
  // step at most.
  const Aabb thirds{Eigen::Vector3d::Constant(1.0 / 3.0), Eigen::Vector3d::Constant(2.0 / 3.0)};
  const Aabb stored = StoredBox(thirds);
  for (int k = 0; k < 3; ++k) {
    EXPECT_LE(stored.min[k], thirds.min[k]);
    EXPECT_GE(stored.max[k], thirds.max[k]);
    EXPECT_LT(thirds.min[k] - stored.min[k], 6e-8);
    EXPECT_LT(stored.max[k] - thirds.max[k], 6e-8);
  }
  EXPECT_TRUE(StoredBox().empty());
  EXPECT_TRUE(Aabb(StoredBox()).empty());
  StoredBox grown;
  grown.extend(floats);
  grown.extend(Aabb{Eigen::Vector3d(-4.0, 0.5, 2.0), Eigen::Vector3d(0.0, 8.0, 2.5)});
  EXPECT_EQ(grown.min(), Eigen::Vector3d(-4.0, 0.25, 2.0));
  EXPECT_EQ(grown.max(), Eigen::Vector3d(2.0, 8.0, 1e6));
}

TEST(MapGeometry, StoredColourRoundsEachChannelToAByteAndClamps) {
  const Eigen::Vector3f back = StoredColour(Eigen::Vector3f(10.49f, 10.5f, 254.6f));
  EXPECT_EQ(back, Eigen::Vector3f(10.0f, 11.0f, 255.0f));
  EXPECT_EQ(Eigen::Vector3f(StoredColour(Eigen::Vector3f(-3.0f, 300.0f, std::nanf("")))),
            Eigen::Vector3f(0.0f, 255.0f, 0.0f));
  const StoredColour grey(Eigen::Vector3f(128.0f, 128.0f, 128.0f));
  EXPECT_EQ(grey[1], 128.0f);
  EXPECT_EQ(grey, StoredColour(Eigen::Vector3f(127.6f, 128.4f, 128.0f)));
  EXPECT_EQ(StoredColour(), StoredColour(Eigen::Vector3f::Zero()));
}

}  // namespace
}  // namespace planecell::map
