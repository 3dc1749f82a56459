/// Map accuracy: stored cells at hand-computed distances from one GT square, scored by area.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/error.hpp"
#include "services/eval/map_accuracy.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::services::eval {
namespace {

/// The GT square x, y ∈ [−5, 5] on the plane z = 5 (n = u × v = +z, e = −5).
std::vector<GtPolygon> gt_square() {
  const io::SyntheticSurface s =
      io::make_rectangle(1, io::SurfaceKind::kFacade, {-5.0, -5.0, 5.0}, Eigen::Vector3d::UnitX(),
                         Eigen::Vector3d::UnitY(), 10.0, 10.0, io::SurfaceTexture{});
  return gt_polygons(std::vector<io::SyntheticSurface>{s});
}

TEST(MapAccuracy, DistanceToAGtPolygonIsToItsPlaneInsideAndToItsEdgeOutside) {
  const auto gt = gt_square();
  ASSERT_EQ(gt.size(), 1u);
  EXPECT_NEAR(distance_to_gt_polygon({0.0, 0.0, 5.05}, gt[0]), 0.05, 1e-12);   // above the inside
  EXPECT_NEAR(distance_to_gt_polygon({1.0, -2.0, 4.7}, gt[0]), 0.30, 1e-12);   // behind it
  EXPECT_NEAR(distance_to_gt_polygon({6.0, 0.0, 5.0}, gt[0]), 1.0, 1e-12);     // in the plane, 1 m past x = 5
  EXPECT_NEAR(distance_to_gt_polygon({6.0, 7.0, 5.3}, gt[0]), std::sqrt(1.0 + 4.0 + 0.09), 1e-12);  // past a corner
}

TEST(MapAccuracy, SharesWeighTheStoredCellsByAreaAndDistance) {
  using test::kX;
  using test::kY;
  map::GlobalMap map;
  // A: 1 m² on the square; B: 1 m² 15 cm in front of it; C: 2 m² a metre behind it; each seen
  // from the origin, far enough apart not to cover one another.
  const std::vector<Planecell> cells = {
      test::rect_cell(0, {0.0f, 0.0f, 5.0f}, kX, kY, 0),
      test::rect_cell(1, {2.0f, 0.0f, 4.85f}, kX, kY, 5),
      test::rect_cell(2, {-3.0f, -3.0f, 6.0f}, 2.0f * kX, kY, 9),
  };
  map.integrate(0, Pose::Identity(), cells);
  ASSERT_EQ(map.cells().size(), 3u);
  const MapAccuracy a = map_accuracy(map, gt_square());
  EXPECT_EQ(a.cells, 3u);
  EXPECT_NEAR(a.area_m2, 4.0, 1e-6);
  EXPECT_NEAR(a.within[0], 1.0 / 4.0, 1e-9);  // A
  EXPECT_NEAR(a.within[1], 2.0 / 4.0, 1e-9);  // A, B
  EXPECT_NEAR(a.within[2], 2.0 / 4.0, 1e-9);  // C is 1 m off
  // Without GT every cell is off every surface; without cells nothing is scored.
  EXPECT_EQ(map_accuracy(map, {}).within[2], 0.0);
  EXPECT_EQ(map_accuracy(map::GlobalMap{}, gt_square()).area_m2, 0.0);
}

TEST(MapAccuracy, ACellAcrossTheEdgeOfAGtSurfaceCountsItsPointsOneByOne) {
  using test::kX;
  using test::kY;
  map::GlobalMap map;
  // 2 m × 1 m on the square's plane from x = 4 to x = 6: the half with x ≤ 5 lies on the square,
  // the rest at its 2D distance x − 5 from the edge x = 5.
  const std::vector<Planecell> cells = {test::rect_cell(0, {4.0f, 0.0f, 5.0f}, 2.0f * kX, kY, 0)};
  map.integrate(0, Pose::Identity(), cells);
  ASSERT_EQ(map.cells().size(), 1u);
  const MapAccuracy a = map_accuracy(map, gt_square());
  // Shares of the x-range: ≤ 5.1 → 0.55, ≤ 5.2 → 0.60, ≤ 5.5 → 0.75, within one grid column
  // (64 squares over 2 m²: 0.177 m wide, 0.09 of the width).
  EXPECT_NEAR(a.within[0], 0.55, 0.09);
  EXPECT_NEAR(a.within[1], 0.60, 0.09);
  EXPECT_NEAR(a.within[2], 0.75, 0.09);
  EXPECT_LT(a.within[0], a.within[2]);
}

TEST(VoxelMapAccuracy, CountsTheVoxelsWhoseCentreLiesNearAGtSurface) {
  const std::vector<Eigen::Vector3d> centres = {
      {0.05, 0.05, 5.05},  // 5 cm in front of the square
      {0.05, 0.05, 5.15},  // 15 cm
      {0.05, 0.05, 7.05},  // 2.05 m
      {6.05, 0.05, 5.05},  // beyond the edge x = 5: √(1.05² + 0.05²) m
  };
  const VoxelAccuracy a = voxel_accuracy(centres, gt_square());
  EXPECT_EQ(a.voxels, 4u);
  EXPECT_DOUBLE_EQ(a.within[0], 0.25);
  EXPECT_DOUBLE_EQ(a.within[1], 0.50);
  EXPECT_DOUBLE_EQ(a.within[2], 0.50);
  EXPECT_EQ(voxel_accuracy({}, gt_square()).voxels, 0u);
}

TEST(VoxelMapCompleteness, AGtPointIsHeldByTheNearestOccupiedVoxelCube) {
  // Two 10 cm voxels: [0, 0.1]³ and [1, 1.1] × [0, 0.1]².
  const std::vector<Eigen::Vector3d> centres = {{0.05, 0.05, 0.05}, {1.05, 0.05, 0.05}};
  const std::vector<Eigen::Vector3d> points = {
      {0.02, 0.03, 0.04},  // inside the first: 0
      {0.17, 0.05, 0.05},  // 7 cm past its face x = 0.1
      {0.05, 0.05, 0.28},  // 18 cm past its face z = 0.1
      {0.85, 0.05, 0.05},  // 15 cm from the second's face x = 1, 75 cm from the first's
      {0.05, 0.05, 0.45},  // 35 cm above the first
      {0.50, 0.05, 1.50},  // √(0.4² + 1.4²) m from the first's nearest edge: held by neither
  };
  const MapCompleteness c = voxel_completeness(centres, 0.1, points);
  EXPECT_EQ(c.points, 6u);
  EXPECT_DOUBLE_EQ(c.within[0], 2.0 / 6.0);
  EXPECT_DOUBLE_EQ(c.within[1], 4.0 / 6.0);
  EXPECT_DOUBLE_EQ(c.within[2], 5.0 / 6.0);
  EXPECT_THROW(voxel_completeness(centres, 0.0, points), InputError);
  const std::vector<Eigen::Vector3d> nan_point = {{std::nan(""), 0.0, 0.0}, {0.02, 0.03, 0.04}};
  EXPECT_DOUBLE_EQ(voxel_completeness(centres, 0.1, nan_point).within[2], 0.5);  // scored, not held
  EXPECT_EQ(voxel_completeness(centres, 0.1, {}).points, 0u);
}

}  // namespace
}  // namespace planecell::services::eval
