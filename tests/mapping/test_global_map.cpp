/// Global map: pose transform, neighbourhood queries, planner queries and fusion, each against
/// hand-computed geometry of synthetic cells.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>
#include <set>

#include "core/error.hpp"
#include "mapping/map/global_map.hpp"
#include "mapping/map/pose_transform.hpp"
#include "support/expect_error.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::map {
namespace {

using test::kX;
using test::kY;
using test::kZ;

using test::rect_cell;

TEST(PoseTransform, MovesPlaneAndPolygonWithKnownPose) {
  // Camera-frame cell on the plane z = 5 (n = (0, 0, 1), e = −5).
  Planecell cam = rect_cell(7, {1, 0, 5}, kX, kY, 0);
  // T_world_cam: 90° about y (x_w = z_c, z_w = −x_c) then translate by (1, 2, 3).
  Pose pose = Pose::Identity();
  pose.linear() << 0, 0, 1, 0, 1, 0, -1, 0, 0;
  pose.translation() = Eigen::Vector3d(1, 2, 3);
  const Planecell world = to_world(cam, pose);
  // Vertex (1, 0, 5) → (5, 0, −1) + (1, 2, 3) = (6, 2, 2); (2, 1, 5) → (5, 1, −2) + t = (6, 3, 1).
  EXPECT_TRUE(world.vertices_m[0].isApprox(Eigen::Vector3f(6, 2, 2)));
  EXPECT_TRUE(world.vertices_m[2].isApprox(Eigen::Vector3f(6, 3, 1)));
  // Plane: n_w = R (0, 0, 1) = (1, 0, 0); the plane x = 6 → e = −6.
  EXPECT_TRUE(world.plane.normal.isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_NEAR(world.plane.offset, -6.0, 1e-12);
  for (const auto& v : world.vertices_m) EXPECT_NEAR(world.plane.signed_distance(v.cast<double>()), 0.0, 1e-5);
  EXPECT_EQ(world.vertices_px, cam.vertices_px);  // image-space fields unchanged
}

TEST(PoseTransform, RejectsBadPosesAndDropsPlanelessCells) {
  std::vector<Planecell> cells = {rect_cell(0, {0, 0, 5}, kX, kY, 0), rect_cell(1, {0, 0, 5}, kX, kY, 0)};
  cells[1].has_plane = false;
  EXPECT_EQ(to_world(cells, Pose::Identity()).size(), 1u);
  Pose nan_pose = Pose::Identity();
  nan_pose.translation().x() = std::nan("");
  EXPECT_THROW(to_world(cells, nan_pose), InputError);
  Pose skewed = Pose::Identity();
  skewed.linear()(0, 1) = 0.2;  // not orthonormal
  EXPECT_THROW(to_world(cells, skewed), InputError);
  Pose mirrored = Pose::Identity();
  mirrored.linear()(2, 2) = -1.0;  // det −1
  EXPECT_THROW(to_world(cells, mirrored), InputError);
  GlobalMap map;
  EXPECT_THROW(map.integrate(0, nan_pose, cells), InputError);
}

TEST(GlobalMapTest, NeighbourhoodQueryReturnsExactlyTheCellsInTheBox) {
  MapConfig config;
  config.max_range_m = 40.0;  // cells up to 20.6 m from the camera
  GlobalMap map(config);
  // Five 1 m cells of distinct colours, far apart (no merging), at x = −20, −10, 0, 10, 20.
  std::vector<Planecell> cells;
  for (std::uint32_t k = 0; k < 5; ++k)
    cells.push_back(rect_cell(k, {10.0f * k - 20.0f, 1.5f, 5}, kX, kZ, static_cast<int>(k)));
  const auto report = map.integrate(1, Pose::Identity(), cells);
  ASSERT_EQ(report.added_cells.size(), 5u);
  ASSERT_EQ(map.surfaces().size(), 5u);
  Aabb box;
  box.extend(Eigen::Vector3d(-10.5, 0, 0));
  box.extend(Eigen::Vector3d(0.5, 3, 10));  // holds cell 1 ([−10, −9]) and touches cell 2 ([0, 1])
  EXPECT_EQ(map.cells_near(box), (std::vector<std::uint32_t>{1, 2}));
  Aabb above;
  above.extend(Eigen::Vector3d(-30, -5, 0));
  above.extend(Eigen::Vector3d(50, 1.4, 10));  // everything is at y = 1.5
  EXPECT_TRUE(map.cells_near(above).empty());
  Aabb far;
  far.extend(Eigen::Vector3d(20.5, 1.5, 5.5));
  EXPECT_EQ(map.cells_near(far), (std::vector<std::uint32_t>{4}));
}

TEST(GlobalMapTest, RejectsCellsBeyondMaxRange) {
  MapConfig config;
  config.max_range_m = 20.0;
  GlobalMap map(config);
  const std::vector<Planecell> cells = {rect_cell(0, {0, 1.5f, 10}, kX, kZ, 0),
                                        rect_cell(1, {0, 1.5f, 30}, kX, kZ, 0)};
  const auto report = map.integrate(1, Pose::Identity(), cells);
  EXPECT_EQ(report.rejected_cells, 1u);
  EXPECT_EQ(map.cells().size(), 1u);
  EXPECT_EQ(report.cell_fates, (std::vector{CellFate::kNewSurface, CellFate::kRejected}));
}

/// Three cells at 10 m, apart from each other (x = 0, 5, −5 m).
std::vector<Planecell> three_cells_apart() {
  return {rect_cell(0, {0, 1.5f, 10}, kX, kZ, 0), rect_cell(1, {5, 1.5f, 10}, kX, kZ, 0),
          rect_cell(2, {-5, 1.5f, 10}, kX, kZ, 0)};
}

/// Integrates `cells` with a map gate set to `on` by `set_gate(config, value)`, then set to 0 (off):
/// exactly cell `gated` is rejected when on, none when off.
template <class SetGate>
void expect_gate_rejects_only(const std::vector<Planecell>& cells, SetGate set_gate, double on,
                              std::size_t gated) {
  for (const double gate : {on, 0.0}) {
    SCOPED_TRACE(gate);
    MapConfig config;
    set_gate(config, gate);
    GlobalMap map(config);
    const auto report = map.integrate(1, Pose::Identity(), cells);
    EXPECT_EQ(report.rejected_cells, gate > 0.0 ? 1u : 0u);
    EXPECT_EQ(map.cells().size(), gate > 0.0 ? 2u : 3u);
    for (std::size_t k = 0; k < cells.size(); ++k)
      EXPECT_EQ(report.cell_surfaces[k] == kNoSurface, gate > 0.0 && k == gated) << "cell " << k;
  }
}

TEST(GlobalMapTest, RejectsCellsNoisierThanMaxDepthSigma) {
  // σ_Z 0.5, 0.7 m and unknown (0): only the 0.7 m cell exceeds the 0.6 m gate.
  std::vector<Planecell> cells = three_cells_apart();
  cells[0].depth_sigma_m = 0.5f;
  cells[1].depth_sigma_m = 0.7f;
  expect_gate_rejects_only(cells, [](MapConfig& c, double v) { c.max_depth_sigma_m = v; }, 0.6, 1);
}

TEST(GlobalMapTest, RejectsCellsWithAWeakPlaneFit) {
  // RANSAC inlier ratios 0.6, 0.9 and unknown (0, never gated): only the 0.6 cell is below 0.8.
  std::vector<Planecell> cells = three_cells_apart();
  cells[0].inlier_ratio = 0.6f;
  cells[1].inlier_ratio = 0.9f;
  cells[2].inlier_ratio = 0.0f;
  expect_gate_rejects_only(cells, [](MapConfig& c, double v) { c.min_inlier_ratio = v; }, 0.8, 0);
  for (const double bad : {-0.1, 1.5, std::nan("")}) {
    MapConfig config;
    config.min_inlier_ratio = bad;
    EXPECT_THROW(GlobalMap{config}, ConfigError) << bad;
  }
}

/// Surfaces keep their colour histogram at 16 bits per bin: a round trip moves each bin by at most
/// half a quantum (2⁻¹⁷), and a surface's stored histogram is its only cell's, so compact.
/// A kerb seen from afar: a road (1 m tiles, x ∈ [−2, 2], z ∈ [10, 16], y = 1.65) is one surface;
/// a 1 m cell of the sidewalk 15 cm above it (y = 1.5) touches its edge at x = 2, z ∈ [15, 16],
/// with σ_Z = 0.3 m. Its depth noise along its normal is σ_n = 0.3 · 1.5 / |X̄ − C|
/// (≈ 2.9 cm at X̄ = (2.5, 1.5, 15.5)), so the CRF's range is max(8 cm, σ_n) and the step keeps it
/// apart; with σ_Z (range 0.3 m) it joins the road.
TEST(GlobalMapTest, AFarCellAboveTheRoadIsTestedWithItsNoiseAlongTheNormal) {
  for (const bool normal_noise : {true, false}) {
    MapConfig config;
    config.normal_depth_noise = normal_noise;
    GlobalMap map(config);
    std::vector<Planecell> road;
    test::tile(road, {-2, 1.65f, 10}, kX, kZ, 4, 6, 1, 0, 3);
    const auto first = map.integrate(0, Pose::Identity(), road);
    ASSERT_EQ(map.surfaces().size(), 1u);
    const std::uint32_t road_surface = first.cell_surfaces.front();
    Planecell kerb = rect_cell(0, {2, 1.5f, 15}, kX, kZ, 3);
    kerb.depth_sigma_m = 0.3f;
    const Eigen::Vector3d centroid(2.5, 1.5, 15.5);
    EXPECT_NEAR(normal_depth_sigma_m(kerb, Eigen::Vector3d::Zero()), 0.3 * 1.5 / centroid.norm(), 1e-7);
    const auto second = map.integrate(1, Pose::Identity(), std::vector<Planecell>{kerb});
    ASSERT_EQ(second.cell_surfaces.size(), 1u);
    if (normal_noise)
      EXPECT_NE(second.cell_surfaces[0], road_surface);
    else
      EXPECT_EQ(second.cell_surfaces[0], road_surface);
  }
}

TEST(GlobalMapTest, SurfaceHistogramsKeepSixteenBitsPerBin) {
  ColourHistogram h{};
  for (std::size_t q = 0; q < h.size(); ++q) h[q] = static_cast<float>(q + 1) / 2080.0f;  // Σ = 1
  const ColourHistogram back = expand(compact(h));
  for (std::size_t q = 0; q < h.size(); ++q) EXPECT_NEAR(back[q], h[q], 0.5 / 65535.0 + 1e-7) << q;
  EXPECT_EQ(compact(ColourHistogram{})[0], 0u);
  ColourHistogram one{};
  one[5] = 1.0f;
  EXPECT_EQ(compact(one)[5], 65535u);
  GlobalMap map;
  const Planecell cell = rect_cell(0, {0, 1.5f, 5}, kX, kZ, 7);
  map.integrate(0, Pose::Identity(), std::vector<Planecell>{cell});
  ASSERT_EQ(map.surfaces().size(), 1u);
  EXPECT_EQ(map.surfaces().begin()->second.histogram, compact(cell.histogram));
}

TEST(GlobalMapTest, SurfaceHistogramsKeepOnlyTheirNonZeroBins) {
  CompactHistogram::Bins bins{};
  bins[2] = 7, bins[40] = 65535, bins[63] = 1;
  const CompactHistogram h(bins);
  EXPECT_EQ(h.mask(), (std::uint64_t{1} << 2) | (std::uint64_t{1} << 40) | (std::uint64_t{1} << 63));
  EXPECT_EQ(h.nonzero().size(), 3u);
  EXPECT_EQ(h.bytes(), 3 * sizeof(std::uint16_t));
  EXPECT_EQ(h[2], 7u);
  EXPECT_EQ(h[40], 65535u);
  EXPECT_EQ(h[63], 1u);
  EXPECT_EQ(h[3], 0u);
  EXPECT_EQ(h[64], 0u);  // not a bin
  EXPECT_EQ(h.bins(), bins);
  // Copies are deep and compare by value.
  CompactHistogram copy = h;
  EXPECT_EQ(copy, h);
  bins[40] = 1;
  copy = CompactHistogram(bins);
  EXPECT_FALSE(copy == h);
  EXPECT_EQ(h[40], 65535u);
  EXPECT_EQ(CompactHistogram().bytes(), 0u);
  EXPECT_EQ(CompactHistogram().bins(), CompactHistogram::Bins{});
  EXPECT_EQ(CompactHistogram(CompactHistogram::Bins{}), CompactHistogram());
}

/// A new surface's footprint basis puts its first cell mid-tile: a 1 m cell (10 × 10 bits of
/// 10 cm) fills one 32 × 32-bit tile, not the corners of four around the basis origin.
TEST(GlobalMapTest, FirstCellOfASurfaceFillsOneFootprintTile) {
  GlobalMap map;
  map.integrate(0, Pose::Identity(), std::vector<Planecell>{rect_cell(0, {0, 1.5f, 5}, kX, kZ, 0)});
  ASSERT_EQ(map.surfaces().size(), 1u);
  const Surface& surface = map.surfaces().begin()->second;
  EXPECT_EQ(surface.detail->footprint.tiles().size(), 1u);
  EXPECT_NEAR(surface.area_m2, 1.0, 0.25);  // 10 cm bits along a 1 m square's edges
  // The cell's centre is half a tile (1.6 m) from the basis origin along both axes.
  const Eigen::Vector2d centre = surface.detail->basis.to_2d(Eigen::Vector3d(0.5, 1.5, 5.5));
  EXPECT_NEAR(std::abs(centre.x()), 1.6, 1e-6);
  EXPECT_NEAR(std::abs(centre.y()), 1.6, 1e-6);
}

TEST(GlobalMapQueries, NearestCellBeyondAnEdgeOfACellWhoseVerticesLieOffItsPlane) {
  // The distance beyond an edge is the edge's, not the plane's. The cell below is the square
  // y = 0, x, z ∈ [0, 2], stored with its plane tilted 12° about z through (1, 0, 1):
  // n = (−sin 12°, cos 12°, 0), so the edge x = 2 lies 0.208 m off the plane. From p = (2.2, −0.1, 1)
  // the plane is |n·(p − c)| = 0.348 m away, but p projects beyond that edge: its distance is the
  // edge's, √(0.2² + 0.1²) = 0.224 m (a search that skipped cells by |n·p + e| would miss it).
  Planecell cell = rect_cell(0, {0, 0, 0}, kX * 2, kZ * 2, 0);
  const double tilt = 12.0 * M_PI / 180.0;
  const Eigen::Vector3d normal(-std::sin(tilt), std::cos(tilt), 0.0);
  cell.plane = Plane3{normal, -normal.dot(Eigen::Vector3d(1, 0, 1))};
  GlobalMap map;
  map.integrate(1, Pose::Identity(), std::vector<Planecell>{cell});
  ASSERT_EQ(map.cells().size(), 1u);
  const Eigen::Vector3d p(2.2, -0.1, 1.0);
  ASSERT_NEAR(std::abs(map.cells().begin()->second.plane.signed_distance(p)), 0.348, 1e-3);
  const auto hit = map.nearest_cell(p, 0.3);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->distance_m, std::sqrt(0.05), 1e-6);
  EXPECT_FALSE(map.nearest_cell(p, 0.2).has_value());
}

TEST(GlobalMapQueries, DistanceToNearestCellInsideAndOutsideThePolygon) {
  GlobalMap map;
  // Ground square y = 0, x, z ∈ [0, 2].
  map.integrate(1, Pose::Identity(), std::vector<Planecell>{rect_cell(0, {0, 0, 0}, kX * 2, kZ * 2, 0)});
  // Inside: plain point-to-plane distance |n·p + e|.
  auto d = map.nearest_cell({1.0, -0.5, 1.0}, 10.0);
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->cell_id, 0u);
  EXPECT_NEAR(d->distance_m, 0.5, 1e-6);
  // Outside beyond the edge x = 2: distance to that edge, √(1² + 0.4²).
  d = map.nearest_cell({3.0, -0.4, 1.0}, 10.0);
  ASSERT_TRUE(d.has_value());
  EXPECT_NEAR(d->distance_m, std::sqrt(1.16), 1e-6);
  // Outside past the corner (2, 0, 2): √(1² + 1²).
  d = map.nearest_cell({3.0, 0.0, 3.0}, 10.0);
  ASSERT_TRUE(d.has_value());
  EXPECT_NEAR(d->distance_m, std::sqrt(2.0), 1e-6);
  // Nothing within 1 m of a point 5 m away.
  EXPECT_FALSE(map.nearest_cell({1.0, -5.0, 1.0}, 1.0).has_value());
  // Far point, large search radius: found by growing the search box.
  d = map.nearest_cell({1.0, -9.0, 1.0}, 20.0);
  ASSERT_TRUE(d.has_value());
  EXPECT_NEAR(d->distance_m, 9.0, 1e-6);
}

/// A 4 × 4 m ground square (y = 0, x, z ∈ [0, 4]) with a box 0.8 m wide and 1 m tall on it
/// (x, z ∈ [1.1, 1.9], top at y = −1 since up = −y).
class BoxScene : public ::testing::Test {
 protected:
  void SetUp() override {
    const float lo = 1.1f, w = 0.8f;
    std::vector<Planecell> cells = {
        rect_cell(0, {0, 0, 0}, kX * 4, kZ * 4, 0),          // ground
        rect_cell(1, {lo, -1, lo}, kX * w, kZ * w, 10),      // top
        rect_cell(2, {lo, -1, lo}, kX * w, kY, 20),          // wall z = 1.1
        rect_cell(3, {lo, -1, lo + w}, kX * w, kY, 20),      // wall z = 1.9
        rect_cell(4, {lo, -1, lo}, kZ * w, kY, 30),          // wall x = 1.1
        rect_cell(5, {lo + w, -1, lo}, kZ * w, kY, 30),      // wall x = 1.9
    };
    map.integrate(1, Pose::Identity(), cells);
  }
  GlobalMap map;
};

TEST_F(BoxScene, HeightMapShowsTheBoxOnFlatGround) {
  // 8 × 8 squares of 0.5 m over x, z ∈ [0, 4]: heights are up·X = −y.
  const HeightMap hm = map.height_map({0.0, 0.0}, 8, 8, 0.5);
  ASSERT_EQ(hm.height_m.rows, 8);
  EXPECT_TRUE(hm.axis_a.isApprox(Eigen::Vector3d::UnitX()));
  EXPECT_TRUE(hm.axis_b.isApprox(Eigen::Vector3d::UnitZ()));
  for (int row = 0; row < 8; ++row)
    for (int col = 0; col < 8; ++col) {
      // Squares [1, 1.5] and [1.5, 2] in x and z hold the box (walls and top: 1 m); others ground.
      const bool box = (col == 2 || col == 3) && (row == 2 || row == 3);
      EXPECT_NEAR(hm.height_m.at<float>(row, col), box ? 1.0f : 0.0f, 1e-5) << row << "," << col;
    }
  // Outside the mapped area: no data.
  const HeightMap outside = map.height_map({10.0, 10.0}, 2, 2, 0.5);
  EXPECT_TRUE(std::isnan(outside.height_m.at<float>(0, 0)));
  EXPECT_THROW(map.height_map({0, 0}, 0, 4, 0.5), InputError);
}

TEST_F(BoxScene, GroundUnderAPointIsTheClosestHorizontalSurfaceBelow) {
  const std::uint32_t ground = map.cells().at(0).surface, top = map.cells().at(1).surface;
  auto hit = map.ground_under({3.0, -2.0, 3.0});
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->surface_id, ground);
  EXPECT_NEAR(hit->height_above_m, 2.0, 1e-9);
  EXPECT_TRUE(hit->ground_point.isApprox(Eigen::Vector3d(3.0, 0.0, 3.0)));
  hit = map.ground_under({1.5, -2.0, 1.5});  // above the box: its top is closest below
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->surface_id, top);
  EXPECT_NEAR(hit->height_above_m, 1.0, 1e-6);
  EXPECT_FALSE(map.ground_under({10.0, -2.0, 10.0}).has_value());  // outside every footprint
  EXPECT_FALSE(map.ground_under({3.0, 1.0, 3.0}).has_value());     // below the ground
  EXPECT_FALSE(map.ground_under({3.0, -20.0, 3.0}, 5.0).has_value());  // ground beyond max drop
}

/// map_bytes splits into its parts: one 1 m square cell holds its 4 vertices (on the mm grid: the
/// count in a 4-byte header, the first as 3 int32, the others as 3 int16 offsets), one
/// footprint tile, one surface listing one cell id, and index entries; the parts add up.
TEST(GlobalMapTest, MapBytesSplitIntoTheirParts) {
  GlobalMap map;
  map.integrate(0, Pose::Identity(), std::vector<Planecell>{rect_cell(0, {0, 1.5f, 5}, kX, kZ, 0)});
  ASSERT_EQ(map.cells().size(), 1u);
  const MapBytes bytes = map.map_bytes_by_part();
  EXPECT_EQ(bytes.vertices, sizeof(std::uint32_t) + 3 * sizeof(std::int32_t) + 3 * 3 * sizeof(std::int16_t));
  EXPECT_EQ(bytes.footprints, sizeof(FootprintTile));
  EXPECT_GE(bytes.cells, sizeof(MapCell));
  EXPECT_GE(bytes.surfaces, sizeof(Surface) + sizeof(std::uint32_t));
  EXPECT_GE(bytes.index, sizeof(std::uint32_t));
  EXPECT_EQ(bytes.total(), bytes.cells + bytes.vertices + bytes.surfaces + bytes.footprints + bytes.index);
  EXPECT_EQ(map.map_bytes(), bytes.total());
}

TEST(Fusion, SameCellObservedTwiceDoesNotGrowTheMap) {
  GlobalMap map;
  const std::vector<Planecell> frame = {rect_cell(0, {0, 1.5f, 5}, kX, kZ, 3),
                                        rect_cell(1, {1, 1.5f, 5}, kX, kZ, 3)};
  map.integrate(1, Pose::Identity(), frame);
  const std::size_t bytes1 = map.map_bytes();
  EXPECT_GT(bytes1, 2 * sizeof(Planecell));
  const auto r2 = map.integrate(2, Pose::Identity(), frame);
  EXPECT_EQ(r2.fused_cells, 2u);
  EXPECT_TRUE(r2.added_cells.empty());
  EXPECT_EQ(map.cells().size(), 2u);
  EXPECT_LE(map.map_bytes(), bytes1 + bytes1 / 50);  // ≤ 2 % growth
}

/// A 4 m × 2 m road (8 cells of one colour, one surface) with, in frame 0 only, a 1 m panel
/// standing on it across the road (plane z = 5) and a 1 m panel along it (plane x = 2.5,
/// seen again in `panel_frames`). Both panels hold one observation when first stored.
struct PruneScene {
  std::vector<Planecell> road() const {
    std::vector<Planecell> cells;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 2; ++j)
        cells.push_back(rect_cell(static_cast<std::uint32_t>(cells.size()),
                                  {-2.0f + i, 1.5f, 4.0f + j}, kX, kZ, 3));
    return cells;
  }
  Planecell across() const { return rect_cell(20, {-1.0f, 0.5f, 5.0f}, kX, kY, 9); }
  Planecell along() const { return rect_cell(21, {2.5f, 0.5f, 4.0f}, kZ, kY, 12); }
};

TEST(Fusion, ASingleViewSurfaceNotSeenAgainIsPrunedWhenItsPlaceIsRevisited) {
  const PruneScene scene;
  MapConfig config;
  ASSERT_EQ(config.unconfirmed_max_age_frames, 3);
  GlobalMap map(config);
  std::vector<Planecell> first = scene.road();
  first.push_back(scene.across());
  first.push_back(scene.along());
  const auto r0 = map.integrate(0, Pose::Identity(), first);
  ASSERT_EQ(r0.added_cells.size(), 10u);
  ASSERT_EQ(map.surfaces().size(), 3u);  // road, panel across, panel along
  const std::uint32_t across_surface = r0.cell_surfaces[8];
  const std::uint32_t along_surface = r0.cell_surfaces[9];
  const std::uint32_t across_cell = r0.added_cells[8];
  ASSERT_EQ(map.surface(across_surface)->observations, 1u);
  // Frames 1–3 see the road again; frame 1 also sees the panel along the road again.
  for (std::uint64_t f = 1; f <= 3; ++f) {
    std::vector<Planecell> cells = scene.road();
    if (f == 1) cells.push_back(scene.along());
    const auto r = map.integrate(f, Pose::Identity(), cells);
    EXPECT_TRUE(r.added_cells.empty()) << "frame " << f;
    if (f < 3) {
      // Younger than unconfirmed_max_age_frames: kept.
      EXPECT_TRUE(r.pruned_surfaces.empty()) << "frame " << f;
      EXPECT_NE(map.surface(across_surface), nullptr) << "frame " << f;
    } else {
      // Three frames old, its place seen again, never confirmed: gone with its cell.
      EXPECT_EQ(r.pruned_surfaces, (std::vector<std::uint32_t>{across_surface}));
      EXPECT_EQ(r.removed_surfaces, (std::vector<std::uint32_t>{across_surface}));
      EXPECT_EQ(r.removed_cells, (std::vector<std::uint32_t>{across_cell}));
    }
  }
  EXPECT_EQ(map.surface(across_surface), nullptr);
  EXPECT_EQ(map.cell(across_cell), nullptr);
  // The panel seen twice and the road stay.
  ASSERT_NE(map.surface(along_surface), nullptr);
  EXPECT_EQ(map.surface(along_surface)->observations, 2u);
  EXPECT_EQ(map.surfaces().size(), 2u);
  EXPECT_EQ(map.cells().size(), 9u);
}

TEST(Fusion, ASingleViewSurfaceNothingComesNearIsPrunedAfterTheTimeout) {
  // A panel 40 m off the road: no later cell comes near it, so only the time-out removes it.
  const PruneScene scene;
  MapConfig config;
  config.max_range_m = 100.0;
  config.max_depth_sigma_m = 0.0;
  // Consolidation (after 10 frames by default) would unite the road's cells in frame 10 too.
  config.consolidate_after_frames = 0;
  ASSERT_EQ(config.unconfirmed_timeout_frames, 10);
  const Planecell far_panel = rect_cell(30, {40.0f, 0.5f, 5.0f}, kX, kY, 9);
  GlobalMap map(config);
  std::vector<Planecell> first = scene.road();
  first.push_back(far_panel);
  first.push_back(scene.along());
  const auto r0 = map.integrate(0, Pose::Identity(), first);
  ASSERT_EQ(r0.added_cells.size(), 10u);
  const std::uint32_t far_surface = r0.cell_surfaces[8];
  const std::uint32_t far_cell = r0.added_cells[8];
  const std::uint32_t along_surface = r0.cell_surfaces[9];
  ASSERT_EQ(map.surface(far_surface)->observations, 1u);
  // The panel along the road is seen again in frame 1: confirmed, never timed out.
  map.integrate(1, Pose::Identity(), std::vector<Planecell>{scene.along()});
  // Frames 2–10 see the road only. `resumed` is restored half-way (from what the store holds
  // after frame 4) and must resume the same clock.
  auto check = [&](GlobalMap& m, std::uint64_t f, const char* which) {
    const auto r = m.integrate(f, Pose::Identity(), scene.road());
    if (f < 10) {
      // Younger than the time-out and nothing near it: kept.
      EXPECT_TRUE(r.pruned_surfaces.empty()) << which << " frame " << f;
      EXPECT_NE(m.surface(far_surface), nullptr) << which << " frame " << f;
    } else {
      // Stored in frame 0, still one observation in frame 10: gone with its cell.
      EXPECT_EQ(r.pruned_surfaces, (std::vector<std::uint32_t>{far_surface})) << which;
      EXPECT_EQ(r.removed_cells, (std::vector<std::uint32_t>{far_cell})) << which;
    }
  };
  GlobalMap resumed;
  for (std::uint64_t f = 2; f <= 10; ++f) {
    if (f == 5) {
      std::vector<MapCell> cells;
      std::vector<Surface> surfaces;
      for (const auto& [id, c] : map.cells()) cells.push_back(c);
      for (const auto& [id, s] : map.surfaces()) surfaces.push_back(s);
      resumed = GlobalMap::restore(config, cells, surfaces, map.next_cell_id(), map.next_surface_id());
    }
    if (f >= 5) check(resumed, f, "resumed");
    check(map, f, "uninterrupted");
  }
  EXPECT_EQ(map.cell(far_cell), nullptr);
  ASSERT_NE(map.surface(along_surface), nullptr);
  EXPECT_EQ(map.surface(along_surface)->observations, 2u);
  EXPECT_TRUE(map.same_content(resumed));
}

/// A panel across the road of four 1 m cells at z (one surface once the CRF has merged them).
std::vector<Planecell> panel_cells(float z, std::uint32_t first_id, int bin) {
  std::vector<Planecell> cells;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      cells.push_back(rect_cell(first_id + static_cast<std::uint32_t>(cells.size()),
                                {-1.0f + i, -0.5f + j, z}, kX, kY, bin));
  return cells;
}

TEST(Fusion, ASurfaceOfManyCellsSeenInOneFrameOnlyIsUnconfirmed) {
  // Two panels of four cells each: one seen in frame 0 only, one in frames 0 and 1. Cells of one
  // frame confirm nothing: the first goes when its place is seen again three frames later, though
  // it holds four observations; the second, seen by a second frame, stays.
  const PruneScene scene;
  MapConfig config;
  ASSERT_EQ(config.confirm_frames, 2);
  ASSERT_EQ(config.unconfirmed_max_age_frames, 3);
  GlobalMap map(config);
  std::vector<Planecell> first = scene.road();
  for (const auto& c : panel_cells(5.0f, 20, 9)) first.push_back(c);   // once
  for (const auto& c : panel_cells(4.5f, 30, 12)) first.push_back(c);  // twice
  const auto r0 = map.integrate(0, Pose::Identity(), first);
  const std::uint32_t once = r0.cell_surfaces[8], twice = r0.cell_surfaces[12];
  ASSERT_NE(once, twice);
  for (std::size_t k = 8; k < 12; ++k) ASSERT_EQ(r0.cell_surfaces[k], once);
  for (std::size_t k = 12; k < 16; ++k) ASSERT_EQ(r0.cell_surfaces[k], twice);
  EXPECT_EQ(map.surface(once)->observations, 4u);
  EXPECT_EQ(map.surface(once)->frames_observed, 1u);
  std::vector<Planecell> second = scene.road();
  for (const auto& c : panel_cells(4.5f, 30, 12)) second.push_back(c);
  map.integrate(1, Pose::Identity(), second);
  EXPECT_EQ(map.surface(twice)->observations, 8u);
  EXPECT_EQ(map.surface(twice)->frames_observed, 2u);
  EXPECT_TRUE(map.integrate(2, Pose::Identity(), scene.road()).pruned_surfaces.empty());
  const auto r3 = map.integrate(3, Pose::Identity(), scene.road());
  EXPECT_EQ(r3.pruned_surfaces, (std::vector<std::uint32_t>{once}));
  EXPECT_EQ(map.surface(once), nullptr);
  EXPECT_NE(map.surface(twice), nullptr);
}

TEST(Fusion, ConfirmFramesSetsHowManyFramesMustSeeASurface) {
  // With confirm_frames 3 a panel seen in frames 0 and 1 times out 10 frames after frame 1; one
  // seen in frames 0, 1 and 2 stays. Panels 40 m off the road: no later cell comes near them.
  const PruneScene scene;
  MapConfig config;
  config.confirm_frames = 3;
  config.max_range_m = 100.0;
  config.max_depth_sigma_m = 0.0;
  config.consolidate_after_frames = 0;
  const auto panel = [](float x, std::uint32_t id, int bin) { return rect_cell(id, {x, 0.5f, 5.0f}, kX, kY, bin); };
  GlobalMap map(config);
  std::uint32_t two = kNoSurface, three = kNoSurface;
  for (std::uint64_t f = 0; f <= 12; ++f) {
    std::vector<Planecell> cells = scene.road();
    if (f <= 1) cells.push_back(panel(40.0f, 40, 9));
    if (f <= 2) cells.push_back(panel(-40.0f, 41, 12));
    const auto r = map.integrate(f, Pose::Identity(), cells);
    if (f == 0) two = r.cell_surfaces[8], three = r.cell_surfaces[9];
    if (f == 11) {
      EXPECT_EQ(r.pruned_surfaces, (std::vector<std::uint32_t>{two}));
    } else {
      EXPECT_TRUE(r.pruned_surfaces.empty()) << "frame " << f;
    }
  }
  EXPECT_EQ(map.surface(two), nullptr);
  ASSERT_NE(map.surface(three), nullptr);
  EXPECT_EQ(map.surface(three)->frames_observed, 3u);
}

TEST(Fusion, UnconfirmedSurfacesStayWhenPruningIsOff) {
  const PruneScene scene;
  MapConfig config;
  config.unconfirmed_max_age_frames = 0;
  config.unconfirmed_timeout_frames = 0;
  config.consolidate_after_frames = 0;  // keeps the road's 8 cells as they are (counted below)
  GlobalMap map(config);
  std::vector<Planecell> first = scene.road();
  first.push_back(scene.across());
  map.integrate(0, Pose::Identity(), first);
  for (std::uint64_t f = 1; f <= 10; ++f)
    EXPECT_TRUE(map.integrate(f, Pose::Identity(), scene.road()).pruned_surfaces.empty());
  EXPECT_EQ(map.surfaces().size(), 2u);
  EXPECT_EQ(map.cells().size(), 9u);
}

TEST(Fusion, LoopedDriveSecondPassGrowsMapByLessThan15Percent) {
  // A 4 m wide road along z, seen in 1 m × 2 m cells; pass 2 drives the same road with the
  // segmentation shifted by 0.7 m along the road (as a real re-observation would be) and 2 cm of plane noise.
  GlobalMap map;
  auto pass = [&](float shift, float lift, std::uint64_t first_frame) {
    for (int f = 0; f < 20; ++f) {
      std::vector<Planecell> cells;
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 2; ++j)
          cells.push_back(rect_cell(static_cast<std::uint32_t>(cells.size()),
                                    {-2.0f + i, 1.5f + lift, 2.0f * (f + j) + shift}, kX,
                                    kZ * 2, 3));
      Pose pose = Pose::Identity();
      pose.translation().z() = 2.0 * f;
      map.integrate(first_frame + f, pose, cells);
    }
  };
  pass(0.0f, 0.0f, 0);
  const std::size_t bytes_pass1 = map.map_bytes();
  const std::size_t cells_pass1 = map.cells().size();
  pass(0.7f, 0.02f, 100);
  EXPECT_EQ(map.surfaces().size(), 1u);  // one road surface
  EXPECT_LT(static_cast<double>(map.map_bytes()), 1.15 * static_cast<double>(bytes_pass1))
      << "pass 1: " << bytes_pass1 << " B, " << cells_pass1 << " cells; pass 2: " << map.map_bytes()
      << " B, " << map.cells().size() << " cells";
}

/// A 2 m × 2 m road patch at z ∈ [10, 12] (four 1 m cells of one colour), seen in frames 0 and 1
/// and again, its tiling shifted by 0.3 m, from frame `revisit` on; every frame also sees a wall
/// 40 m away, which keeps the map busy but never comes near the patch.
struct QuietPatch {
  static constexpr std::uint64_t kRevisit = 9;
  static std::vector<Planecell> patch(float shift) {
    std::vector<Planecell> cells;
    test::tile(cells, {0.0f, 1.5f, 10.0f}, kX, kZ, 2.0f, 2.0f, 1.0f, shift, 3);
    return cells;
  }
  static std::vector<Planecell> frame(std::uint64_t f) {
    std::vector<Planecell> cells;
    if (f <= 1) cells = patch(0.0f);
    if (f >= kRevisit) cells = patch(0.3f);
    test::tile(cells, {40.0f, -1.0f, 10.0f}, kZ, kY, 2.0f, 2.0f, 1.0f, 0.0f, 9);
    return cells;
  }
  static MapConfig config() {
    MapConfig c;
    c.max_range_m = 100.0;
    c.max_depth_sigma_m = 0.0;
    c.consolidate_after_frames = 0;
    c.dormant_after_frames = 5;
    return c;
  }
};

TEST(Dormancy, AQuietSurfaceDropsItsDetailAndIsWokenWhenSeenAgain) {
  GlobalMap map(QuietPatch::config()), resumed(QuietPatch::config());
  std::uint32_t patch = kNoSurface;
  Surface before;
  for (std::uint64_t f = 0; f <= QuietPatch::kRevisit; ++f) {
    if (f == 7) {  // restored from what a store holds after frame 6 (the patch dormant)
      std::vector<MapCell> cells;
      std::vector<Surface> surfaces;
      for (const auto& [id, c] : map.cells()) cells.push_back(c);
      for (const auto& [id, sf] : map.surfaces()) surfaces.push_back(sf);
      resumed = GlobalMap::restore(QuietPatch::config(), cells, surfaces, map.next_cell_id(),
                                   map.next_surface_id(), 6);
    }
    const std::size_t bytes = map.map_bytes();
    const auto report = map.integrate(f, Pose::Identity(), QuietPatch::frame(f));
    if (f >= 7) resumed.integrate(f, Pose::Identity(), QuietPatch::frame(f));
    if (f == 0) patch = report.cell_surfaces[0];
    ASSERT_NE(map.surface(patch), nullptr) << "frame " << f;
    const Surface& s = *map.surface(patch);
    if (f == 1) {
      ASSERT_EQ(s.last_observed_frame, 1u);
      ASSERT_TRUE(s.detail.has_value());
      before = s;
    }
    if (f < 6) {
      EXPECT_TRUE(report.dormant_surfaces.empty()) << "frame " << f;
      EXPECT_TRUE(s.detail.has_value()) << "frame " << f;
    } else if (f == 6) {
      // Last observed in frame 1: dormant five frames later, its descriptor as it was and its
      // moments kept at float precision.
      EXPECT_EQ(report.dormant_surfaces, (std::vector<std::uint32_t>{patch}));
      EXPECT_TRUE(std::find(report.updated_surfaces.begin(), report.updated_surfaces.end(), patch) ==
                  report.updated_surfaces.end());
      EXPECT_FALSE(s.detail.has_value());
      EXPECT_EQ(dormant_surface_count(map), 1u);  // the far wall is seen every frame
      Surface expected = before;
      expected.quiet_moments = quiet_moments_of(moments_of(before));
      expected.detail.reset();
      EXPECT_TRUE(same_surface(s, expected));
      EXPECT_NE(s.quiet_moments, QuietMoments{});
      EXPECT_EQ(bytes - map.map_bytes(),
                sizeof(SurfaceDetail) + before.detail->footprint.bytes() +
                    sizeof(std::pair<std::uint64_t, std::uint32_t>));  // and its clock entry
      // Queries do not need the detail: the ground under the patch is found through its cells.
      const auto ground = map.ground_under({1.0, 0.0, 11.0});
      ASSERT_TRUE(ground.has_value());
      EXPECT_EQ(ground->surface_id, patch);
      EXPECT_NEAR(ground->height_above_m, 1.5, 1e-5);
      // Its detail on demand is rebuilt: the 2 m × 2 m footprint of its four cells (10 cm bits
      // whose centres lie inside) and the moments it had, to float precision.
      const SurfaceDetail rebuilt = map.surface_detail(patch);
      EXPECT_NEAR(rebuilt.footprint.area_m2(), 4.0, 0.45);
      const PlaneMoments was = moments_of(before);
      EXPECT_TRUE(rebuilt.moment_sum.isApprox(was.sum, 1e-6));
      EXPECT_TRUE(rebuilt.moment_outer.isApprox(was.sum_outer, 1e-6));
      EXPECT_NEAR((was.sum / was.weight - Eigen::Vector3d(1.0, 1.5, 11.0)).norm(), 0.0, 1e-5);
    } else if (f < QuietPatch::kRevisit) {
      EXPECT_FALSE(s.detail.has_value()) << "frame " << f;
    } else {
      // Seen again: woken, the re-observation fused into it (no new surface, no new cell).
      EXPECT_TRUE(s.detail.has_value());
      EXPECT_EQ(dormant_surface_count(map), 0u);
      EXPECT_EQ(s.quiet_moments, QuietMoments{});
      EXPECT_EQ(s.last_observed_frame, QuietPatch::kRevisit);
      EXPECT_EQ(s.observations, before.observations + 4);
      EXPECT_EQ(s.cells, before.cells);
      EXPECT_EQ(map.surfaces().size(), 2u);
      EXPECT_TRUE(std::find(report.updated_surfaces.begin(), report.updated_surfaces.end(), patch) !=
                  report.updated_surfaces.end());
      // The footprint rebuilt from the four cells, and the shifted view's bits added to it.
      EXPECT_GT(s.detail->footprint.area_m2(), 4.0 - 0.45);
      EXPECT_LT(s.detail->footprint.area_m2(), 2.3 * 2.3 + 0.5);
    }
  }
  // Restored while the patch slept, the map wakes it the same way.
  EXPECT_TRUE(map.same_content(resumed));
}

/// Three 0.5 m squares of their own colours seen with the quiet patch in frames 0 and 1: one
/// 5 cm above the patch (within fragment_redundant_m of its cells: redundant), one 30 cm above it
/// and one 3 m beside it (isolated). Dormant in frame 6, the first is pruned, the others sleep.
TEST(Dormancy, ASmallFragmentBesideAnotherSurfaceIsPrunedInsteadOfGoingDormant) {
  const MapConfig config = QuietPatch::config();
  ASSERT_EQ(config.fragment_max_area_m2, 1.0);
  ASSERT_EQ(config.fragment_redundant_m, 0.10);
  auto frame = [](std::uint64_t f) {
    std::vector<Planecell> cells = QuietPatch::frame(f);
    if (f <= 1) {
      const auto id = [&] { return static_cast<std::uint32_t>(cells.size()); };
      cells.push_back(rect_cell(id(), {0.5f, 1.45f, 10.5f}, 0.5f * kX, 0.5f * kZ, 12));  // 5 cm above
      cells.push_back(rect_cell(id(), {1.2f, 1.2f, 10.5f}, 0.5f * kX, 0.5f * kZ, 14));   // 30 cm above
      cells.push_back(rect_cell(id(), {5.0f, 1.5f, 10.5f}, 0.5f * kX, 0.5f * kZ, 16));   // 3 m beside
    }
    return cells;
  };
  GlobalMap map(config);
  MapConfig keep_config = config;
  keep_config.fragment_max_area_m2 = 0.0;
  GlobalMap keep(keep_config);
  std::array<std::uint32_t, 3> fragment{}, fragment_cell{};
  std::uint32_t patch = kNoSurface;
  for (std::uint64_t f = 0; f <= 6; ++f) {
    const auto cells = frame(f);
    const auto report = map.integrate(f, Pose::Identity(), cells);
    const auto kept = keep.integrate(f, Pose::Identity(), cells);
    if (f == 0) {
      patch = report.cell_surfaces[0];
      for (std::size_t k = 0; k < 3; ++k) {
        fragment[k] = report.cell_surfaces[cells.size() - 3 + k];
        fragment_cell[k] = report.added_cells[report.added_cells.size() - 3 + k];
      }
      ASSERT_EQ(std::set<std::uint32_t>(fragment.begin(), fragment.end()).size(), 3u);
    }
    if (f == 1)
      for (std::size_t k = 0; k < 3; ++k) {
        ASSERT_NE(map.surface(fragment[k]), nullptr) << k;
        EXPECT_EQ(map.surface(fragment[k])->cells.size(), 1u) << k;
        EXPECT_EQ(map.surface(fragment[k])->observations, 2u) << k;  // confirmed: no unconfirmed prune
      }
    if (f < 6) {
      EXPECT_TRUE(report.pruned_surfaces.empty()) << "frame " << f;
      continue;
    }
    // Frame 6: everything last seen in frame 1 goes quiet. The redundant fragment leaves the map
    // with its cell; the map without the prune keeps it dormant.
    EXPECT_EQ(report.pruned_surfaces, (std::vector<std::uint32_t>{fragment[0]}));
    EXPECT_EQ(report.removed_cells, (std::vector<std::uint32_t>{fragment_cell[0]}));
    EXPECT_EQ(map.surface(fragment[0]), nullptr);
    EXPECT_EQ(map.cell(fragment_cell[0]), nullptr);
    for (std::size_t k : {1u, 2u}) {
      ASSERT_NE(map.surface(fragment[k]), nullptr) << k;
      EXPECT_FALSE(map.surface(fragment[k])->detail.has_value()) << k;
      EXPECT_TRUE(std::binary_search(report.dormant_surfaces.begin(), report.dormant_surfaces.end(), fragment[k]));
    }
    EXPECT_FALSE(std::binary_search(report.dormant_surfaces.begin(), report.dormant_surfaces.end(), fragment[0]));
    EXPECT_TRUE(kept.pruned_surfaces.empty());
    EXPECT_TRUE(std::binary_search(kept.dormant_surfaces.begin(), kept.dormant_surfaces.end(), fragment[0]));
    EXPECT_EQ(keep.surfaces().size(), map.surfaces().size() + 1);
    EXPECT_LT(map.map_bytes(), keep.map_bytes());
  }
  // Queries: the point 2 cm above the pruned fragment's centre now finds the patch, 7 cm below.
  const auto near = map.nearest_cell({0.75, 1.43, 10.75}, 1.0);
  ASSERT_TRUE(near.has_value());
  EXPECT_NEAR(near->distance_m, 0.07, 1e-5);
  EXPECT_EQ(map.cell(near->cell_id)->surface, patch);
  // Settings checked.
  MapConfig bad = config;
  bad.fragment_max_area_m2 = -1.0;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.fragment_max_area_m2");
  bad.fragment_max_area_m2 = 1.0;
  bad.fragment_redundant_m = 0.0;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.fragment_redundant_m");
}

/// A 4 m × 2 m wall at z = 10 (1 m cells, colour bin 3) seen in every frame, and three 0.5 m
/// squares above its top edge seen in frames 0 and 1 only, each tilted about its centre line
/// y = −0.25 (which lies in the wall's plane) towards the camera: 20° and the wall's colour,
/// 40° and the wall's colour, 20° and another colour. The CRF keeps all three apart (10°); going
/// dormant in frame 6, only the first joins the wall.
TEST(Dormancy, AFragmentGoingDormantJoinsTheLargerNeighbourItLiesOn) {
  MapConfig config = QuietPatch::config();
  ASSERT_EQ(config.fragment_join_max_area_m2, 20.0);
  ASSERT_EQ(config.fragment_join_distance_m, 0.10);
  ASSERT_EQ(config.fragment_join_angle_deg, 30.0);
  ASSERT_EQ(config.max_normal_angle_deg, 10.0);
  auto tilted = [](std::uint32_t id, float x, float deg, int bin) {
    const float t = deg * static_cast<float>(M_PI) / 180.0f;
    return rect_cell(id, {x, -0.5f, 10.0f - 0.25f * std::sin(t)}, 0.5f * kX,
                     Eigen::Vector3f(0.0f, 0.5f * std::cos(t), 0.5f * std::sin(t)), bin);
  };
  auto frame = [&](std::uint64_t f) {
    std::vector<Planecell> cells;
    test::tile(cells, {0.0f, 0.0f, 10.0f}, kX, kY, 4.0f, 2.0f, 1.0f, 0.0f, 3);
    if (f <= 1) {
      cells.push_back(tilted(static_cast<std::uint32_t>(cells.size()), 0.2f, 20.0f, 3));
      cells.push_back(tilted(static_cast<std::uint32_t>(cells.size()), 1.7f, 40.0f, 3));
      cells.push_back(tilted(static_cast<std::uint32_t>(cells.size()), 3.2f, 20.0f, 12));
    }
    return cells;
  };
  GlobalMap map(config);
  std::uint32_t wall = kNoSurface;
  std::array<std::uint32_t, 3> fragment{}, fragment_cell{};
  for (std::uint64_t f = 0; f <= 6; ++f) {
    const auto cells = frame(f);
    const auto report = map.integrate(f, Pose::Identity(), cells);
    if (f == 0) {
      wall = report.cell_surfaces[0];
      for (std::size_t k = 0; k < 8; ++k) ASSERT_EQ(report.cell_surfaces[k], wall) << k;
      for (std::size_t k = 0; k < 3; ++k) {
        fragment[k] = report.cell_surfaces[8 + k];
        fragment_cell[k] = report.added_cells[report.added_cells.size() - 3 + k];
        ASSERT_NE(fragment[k], wall) << k;  // the CRF's 10° keeps each apart
      }
      ASSERT_EQ(std::set<std::uint32_t>(fragment.begin(), fragment.end()).size(), 3u);
    }
    if (f < 6) {
      EXPECT_TRUE(report.surface_merges.empty()) << "frame " << f;
      continue;
    }
    // The first fragment joins the wall (the older surface keeps its id) with its cell.
    EXPECT_EQ(report.surface_merges, (std::vector<SurfaceMerge>{{6, fragment[0], wall}}));
    EXPECT_EQ(report.removed_surfaces, (std::vector<std::uint32_t>{fragment[0]}));
    EXPECT_EQ(report.relabelled_cells, (std::vector<std::uint32_t>{fragment_cell[0]}));
    EXPECT_TRUE(std::binary_search(report.updated_surfaces.begin(), report.updated_surfaces.end(), wall));
    EXPECT_TRUE(report.pruned_surfaces.empty());
    EXPECT_EQ(map.surface(fragment[0]), nullptr);
    ASSERT_NE(map.cell(fragment_cell[0]), nullptr);
    EXPECT_EQ(map.cell(fragment_cell[0])->surface, wall);
    const Surface& joined = *map.surface(wall);
    EXPECT_EQ(joined.cells.back(), fragment_cell[0]);
    EXPECT_EQ(joined.observations, 7u * 8u + 2u);
    // Its plane stays the wall's: the fragment's points weigh little and straddle it.
    EXPECT_GT(std::abs(joined.plane.normal().z()), std::cos(1.0 * M_PI / 180.0));
    EXPECT_NEAR(std::abs(joined.plane.offset()), 10.0, 0.01);
    // Too steep, or another colour: dormant, each on its own.
    for (std::size_t k : {1u, 2u}) {
      ASSERT_NE(map.surface(fragment[k]), nullptr) << k;
      EXPECT_FALSE(map.surface(fragment[k])->detail.has_value()) << k;
      EXPECT_EQ(map.cell(fragment_cell[k])->surface, fragment[k]) << k;
    }
    EXPECT_EQ(report.dormant_surfaces, (std::vector<std::uint32_t>{fragment[1], fragment[2]}));
  }
  MapConfig off = config;
  off.fragment_join_max_area_m2 = 0.0;
  GlobalMap apart(off);
  for (std::uint64_t f = 0; f <= 6; ++f)
    EXPECT_TRUE(apart.integrate(f, Pose::Identity(), frame(f)).surface_merges.empty()) << f;
  EXPECT_EQ(apart.surfaces().size(), map.surfaces().size() + 1);
  MapConfig bad = config;
  bad.fragment_join_angle_deg = 120.0;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.fragment_join_angle_deg (120");
  bad.fragment_join_angle_deg = 30.0;
  bad.fragment_join_max_area_m2 = std::nan("");
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.fragment_join_max_area_m2");
}

/// The wall above and one 0.5 m square over its top edge tilted 20° (the CRF's 10° keeps it apart),
/// its histogram half the wall's bin 3 (levels (0, 0, 3)) and half reddish (levels (2, 1, 0)):
/// intersection 0.5 passes the colour test, but its mean chromaticity (0.33, 0.22, 0.45) lies 0.42
/// from the wall's (0.11, 0.11, 0.78): another paint (MapConfig::max_chromaticity_distance), it
/// stays apart going dormant; with the test off it joins the wall.
TEST(Dormancy, AFragmentOfAnotherPaintDoesNotJoinTheNeighbourItLiesOn) {
  const auto frame = [](std::uint64_t f) {
    std::vector<Planecell> cells;
    test::tile(cells, {0.0f, 0.0f, 10.0f}, kX, kY, 4.0f, 2.0f, 1.0f, 0.0f, 3);
    if (f <= 1) {
      const float t = 20.0f * static_cast<float>(M_PI) / 180.0f;
      Planecell fragment = rect_cell(static_cast<std::uint32_t>(cells.size()), {0.2f, -0.5f, 10.0f - 0.25f * std::sin(t)},
                                     0.5f * kX, Eigen::Vector3f(0.0f, 0.5f * std::cos(t), 0.5f * std::sin(t)), 3);
      fragment.histogram[3] = 0.5f;
      fragment.histogram[16 * 2 + 4 * 1 + 0] = 0.5f;
      cells.push_back(fragment);
    }
    return cells;
  };
  for (const double max_chromaticity : {0.06, 0.0}) {
    SCOPED_TRACE("max chromaticity distance " + std::to_string(max_chromaticity));
    MapConfig config = QuietPatch::config();
    config.max_chromaticity_distance = max_chromaticity;
    GlobalMap map(config);
    std::uint32_t wall = kNoSurface, fragment = kNoSurface;
    for (std::uint64_t f = 0; f <= 6; ++f) {
      const auto report = map.integrate(f, Pose::Identity(), frame(f));
      if (f == 0) {
        wall = report.cell_surfaces[0];
        fragment = report.cell_surfaces[8];
        ASSERT_NE(fragment, wall);
      }
      if (f < 6) EXPECT_TRUE(report.surface_merges.empty()) << "frame " << f;
      else if (max_chromaticity > 0.0) EXPECT_TRUE(report.surface_merges.empty());
      else EXPECT_EQ(report.surface_merges, (std::vector<SurfaceMerge>{{6, fragment, wall}}));
    }
    EXPECT_EQ(map.surface(fragment) != nullptr, max_chromaticity > 0.0);
  }
}

/// The same 4 m × 2 m wall at z = 10 (colour bin 3) and three 0.5 m squares parallel to it just
/// above its top edge, 15 cm nearer the camera (z = 9.85), seen in frames 0 and 1: beyond the
/// CRF's fixed 8 cm range (depth_sigma_factor 0) and fragment_join_distance_m (10 cm). With a
/// modelled depth noise σ_Z = 0.2 m (the wall's cells too) the first, of the wall's colour, lies
/// within its own noise and joins the wall going dormant; the second, of another colour, does not;
/// the third, the wall's colour but σ_Z = 0.05 m, lies 3 σ off and stays apart.
TEST(Dormancy, AFragmentWithinItsOwnDepthNoiseJoinsANeighbourOfItsColour) {
  MapConfig config = QuietPatch::config();
  config.depth_sigma_factor = 0.0;
  ASSERT_EQ(config.fragment_join_sigma_factor, 1.0);
  ASSERT_EQ(config.fragment_join_noise_colour, 0.8);
  ASSERT_EQ(config.fragment_join_distance_m, 0.10);
  auto square = [](std::uint32_t id, float x, int bin, float sigma_m) {
    Planecell cell = rect_cell(id, {x, -0.5f, 9.85f}, 0.5f * kX, 0.5f * kY, bin);
    cell.depth_sigma_m = sigma_m;
    return cell;
  };
  auto frame = [&](std::uint64_t f) {
    std::vector<Planecell> cells;
    test::tile(cells, {0.0f, 0.0f, 10.0f}, kX, kY, 4.0f, 2.0f, 1.0f, 0.0f, 3);
    for (auto& cell : cells) cell.depth_sigma_m = 0.2f;
    if (f <= 1) {
      cells.push_back(square(static_cast<std::uint32_t>(cells.size()), 0.2f, 3, 0.2f));
      cells.push_back(square(static_cast<std::uint32_t>(cells.size()), 1.7f, 12, 0.2f));
      cells.push_back(square(static_cast<std::uint32_t>(cells.size()), 3.2f, 3, 0.05f));
    }
    return cells;
  };
  auto run = [&](const MapConfig& c, std::array<std::uint32_t, 3>& fragment, std::uint32_t& wall) {
    GlobalMap map(c);
    std::vector<SurfaceMerge> merges;
    for (std::uint64_t f = 0; f <= 6; ++f) {
      const auto report = map.integrate(f, Pose::Identity(), frame(f));
      if (f == 0) {
        wall = report.cell_surfaces[0];
        for (std::size_t k = 0; k < 3; ++k) fragment[k] = report.cell_surfaces[8 + k];
      }
      merges.insert(merges.end(), report.surface_merges.begin(), report.surface_merges.end());
    }
    return std::pair{std::move(map), merges};
  };
  std::array<std::uint32_t, 3> fragment{};
  std::uint32_t wall = kNoSurface;
  const auto [map, merges] = run(config, fragment, wall);
  for (std::size_t k = 0; k < 3; ++k) ASSERT_NE(fragment[k], wall) << k;  // apart in the CRF
  EXPECT_EQ(merges, (std::vector<SurfaceMerge>{{6, fragment[0], wall}}));
  EXPECT_EQ(map.surface(fragment[0]), nullptr);
  for (std::size_t k : {1u, 2u}) ASSERT_NE(map.surface(fragment[k]), nullptr) << k;
  // The wall's plane stays put: the fragment weighs 2 · 0.25 m² against 7 · 8 m².
  EXPECT_NEAR(std::abs(map.surface(wall)->plane.offset()), 10.0, 0.01);
  // Off: the fragment keeps to itself.
  MapConfig off = config;
  off.fragment_join_sigma_factor = 0.0;
  const auto [apart, none] = run(off, fragment, wall);
  EXPECT_TRUE(none.empty());
  EXPECT_EQ(apart.surfaces().size(), map.surfaces().size() + 1);
  MapConfig bad = config;
  bad.fragment_join_noise_colour = 1.5;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.fragment_join_noise_colour");
  bad.fragment_join_noise_colour = 0.9;
  bad.fragment_join_sigma_factor = -1.0;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.fragment_join_sigma_factor");
}

/// The wall and a 20° fragment above its top edge (as above) going quiet in the same frame, the
/// wall first: the fragment's join wakes the wall again, or absorbs it when the fragment is the
/// older surface. Either way the wall must not be reported dormant (the store rewrites every
/// reported surface and refuses one that is gone; a consumer would drop a live surface's detail).
TEST(Dormancy, ASurfaceAFragmentJoinsInTheFrameItWentQuietIsNotReportedDormant) {
  const MapConfig config = QuietPatch::config();  // dormant after 5 quiet frames
  auto wall = [] {
    std::vector<Planecell> cells;
    test::tile(cells, {0.0f, 0.0f, 10.0f}, kX, kY, 4.0f, 2.0f, 1.0f, 0.0f, 3);
    return cells;
  };
  const float t = 20.0f * static_cast<float>(M_PI) / 180.0f;
  auto with_fragment = [&](std::vector<Planecell> cells) {
    cells.push_back(rect_cell(static_cast<std::uint32_t>(cells.size()), {0.2f, -0.5f, 10.0f - 0.25f * std::sin(t)},
                              0.5f * kX, Eigen::Vector3f(0.0f, 0.5f * std::cos(t), 0.5f * std::sin(t)), 3));
    return cells;
  };
  // Every reported dormant surface is in the map without its detail; every updated one is in it.
  auto check = [](const GlobalMap& map, const MergeReport& report) {
    for (std::uint32_t id : report.dormant_surfaces) {
      ASSERT_NE(map.surface(id), nullptr) << "dormant " << id;
      EXPECT_FALSE(map.surface(id)->detail.has_value()) << "dormant " << id;
    }
    for (std::uint32_t id : report.updated_surfaces) EXPECT_NE(map.surface(id), nullptr) << "updated " << id;
  };
  {  // The wall is older (smaller id): woken as the merged surface.
    GlobalMap map(config);
    const auto first = map.integrate(0, Pose::Identity(), with_fragment(wall()));
    const std::uint32_t wall_id = first.cell_surfaces[0], fragment_id = first.cell_surfaces[8];
    ASSERT_LT(wall_id, fragment_id);
    map.integrate(1, Pose::Identity(), with_fragment(wall()));
    const auto report = map.integrate(6, Pose::Identity(), {});  // both quiet since frame 1
    check(map, report);
    EXPECT_EQ(report.surface_merges, (std::vector<SurfaceMerge>{{6, fragment_id, wall_id}}));
    EXPECT_TRUE(report.dormant_surfaces.empty());
    ASSERT_NE(map.surface(wall_id), nullptr);
    EXPECT_TRUE(map.surface(wall_id)->detail.has_value());
    EXPECT_TRUE(std::binary_search(report.updated_surfaces.begin(), report.updated_surfaces.end(), wall_id));
  }
  {  // The fragment is older and seen last: the wall goes quiet first and is then absorbed.
    GlobalMap map(config);
    const auto first = map.integrate(0, Pose::Identity(), with_fragment({}));
    const std::uint32_t fragment_id = first.cell_surfaces[0];
    const auto second = map.integrate(1, Pose::Identity(), with_fragment(wall()));
    const std::uint32_t wall_id = second.cell_surfaces[0];
    ASSERT_LT(fragment_id, wall_id);
    ASSERT_EQ(second.cell_surfaces[8], fragment_id);  // the CRF's 10° keeps it apart
    map.integrate(2, Pose::Identity(), with_fragment({}));
    map.integrate(5, Pose::Identity(), {});  // the fragment's clock moves on to frame 2
    const auto report = map.integrate(8, Pose::Identity(), {});  // the wall quiet since 1, the fragment since 2
    check(map, report);
    EXPECT_EQ(report.surface_merges, (std::vector<SurfaceMerge>{{8, wall_id, fragment_id}}));
    EXPECT_EQ(map.surface(wall_id), nullptr);
    EXPECT_TRUE(report.dormant_surfaces.empty());
    EXPECT_EQ(map.surface(fragment_id)->cells.size(), 9u);
    // The merged surface, observed at frame 8, is back on the dormancy clock (its entry was the
    // one taken at frame 8): quiet five frames later, it goes dormant like any other.
    const auto later = map.integrate(13, Pose::Identity(), {});
    check(map, later);
    EXPECT_EQ(later.dormant_surfaces, (std::vector<std::uint32_t>{fragment_id}));
    EXPECT_FALSE(map.surface(fragment_id)->detail.has_value());
  }
}

TEST(Dormancy, NeverWhenOffAndNotBeforeConsolidation) {
  MapConfig off = QuietPatch::config();
  off.dormant_after_frames = 0;
  GlobalMap map(off);
  for (std::uint64_t f = 0; f < QuietPatch::kRevisit; ++f)
    EXPECT_TRUE(map.integrate(f, Pose::Identity(), QuietPatch::frame(f)).dormant_surfaces.empty());
  for (const auto& [id, s] : map.surfaces()) EXPECT_TRUE(s.detail.has_value());
  MapConfig early;
  early.consolidate_after_frames = 30;
  early.dormant_after_frames = 29;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{early}; }),
                  "map.dormant_after_frames (29) must be >= map.consolidate_after_frames (30)");
  early.dormant_after_frames = -1;
  EXPECT_THROW(GlobalMap{early}, ConfigError);
  early.dormant_after_frames = 30;
  EXPECT_NO_THROW(GlobalMap{early});
}

/// Bridging over an occlusion gap: a wall at z = 10 seen in two segments 3 m apart, x ∈ [−8, −2]
/// × y ∈ [−2, 2] in frame 0 (24 cells of 1 m: large and mature) and x ∈ [1, 3] × y ∈ [0, 2] in
/// frame 1 (four cells: mature). Optionally a back wall at z = 14 (colour bin 5) seen through the
/// gap, the second segment `step_m` nearer than the first and tilted about its centre line x = 2
/// (z = 10 − step_m + slope·(x − 2)), or the first one only 2 m × 2 m (as small as the side of a
/// parked car).
struct BridgeCase {
  MapConfig config;
  bool back_wall = false;
  float step_m = 0.0f;
  float slope = 0.0f;
  bool small_first = false;
  std::vector<MergeReport> run() const {
    GlobalMap map(config);
    std::vector<Planecell> first, second;
    if (small_first)
      test::tile(first, {-4, 0, 10}, kX, kY, 2, 2, 1, 0, 0);
    else
      test::tile(first, {-8, -2, 10}, kX, kY, 6, 4, 1, 0, 0);
    if (back_wall) test::tile(first, {-6, -1, 14}, kX, kY, 12, 4, 2, 0, 5);
    const Eigen::Vector3f along = Eigen::Vector3f(1, 0, slope).normalized();
    test::tile(second, {1, 0, 10 - step_m - slope}, along, kY, 2 * std::sqrt(1 + slope * slope), 2, 1, 0, 0);
    std::vector<MergeReport> reports;
    reports.push_back(map.integrate(0, Pose::Identity(), first));
    reports.push_back(map.integrate(1, Pose::Identity(), second));
    surfaces_after = map.surfaces().size();
    return reports;
  }
  mutable std::size_t surfaces_after = 0;
};

TEST(Bridge, MatureSegmentsOfOnePlaneMergeAcrossAHiddenGap) {
  BridgeCase c;
  ASSERT_EQ(c.config.bridge_gap_m, 5.0);  // on by default
  ASSERT_EQ(c.config.bridge_min_area_m2, 20.0);
  const auto reports = c.run();
  EXPECT_EQ(c.surfaces_after, 1u);
  ASSERT_EQ(reports[1].surface_merges.size(), 1u);
  // The older surface (frame 0's, the smaller id) absorbs the newer one.
  EXPECT_LT(reports[1].surface_merges[0].into, reports[1].surface_merges[0].absorbed);
  EXPECT_EQ(reports[1].removed_surfaces, std::vector<std::uint32_t>{reports[1].surface_merges[0].absorbed});
}

TEST(Bridge, NoMergeWhenOffOutOfReachSmallSeenThroughOrNotOnOnePlane) {
  BridgeCase off;  // bridge_gap_m = 0: the 3 m gap keeps them apart
  off.config.bridge_gap_m = 0.0;
  off.run();
  EXPECT_EQ(off.surfaces_after, 2u);
  BridgeCase short_reach;
  short_reach.config.bridge_gap_m = 2.5;  // the segments' cells are 3 m apart
  short_reach.run();
  EXPECT_EQ(short_reach.surfaces_after, 2u);
  // Two segments of 4 m² each: more likely two objects than one surface behind an occluder.
  BridgeCase small;
  small.small_first = true;
  small.run();
  EXPECT_EQ(small.surfaces_after, 2u);
  small.config.bridge_min_area_m2 = 0.0;  // any size
  small.run();
  EXPECT_EQ(small.surfaces_after, 1u);
  BridgeCase seen_through;  // the back wall shows through the gap: it is not hidden
  seen_through.back_wall = true;
  const auto reports = seen_through.run();
  EXPECT_EQ(seen_through.surfaces_after, 3u);
  EXPECT_TRUE(reports[1].surface_merges.empty());
  BridgeCase stepped;  // 15 cm apart: a curb, not one plane (max_plane_distance_m 8 cm)
  stepped.step_m = 0.15f;
  stepped.run();
  EXPECT_EQ(stepped.surfaces_after, 2u);
}

TEST(Bridge, NoMergeWhenACellLiesOffTheOtherPlaneThoughThePlanesMeetInTheGap) {
  // The second segment 20 cm nearer and tilted 4.6° (slope −0.08): its plane reaches the first's
  // (z = 10) at x = −0.5, the midpoint between the cells of the two segments closest to each other
  // (x = 1.5 and −2.5), so the CRF's step there is 0. Its own cells lie 12.8–19.2 cm in front of
  // the first segment's plane (z = 9.88 at x = 1 to 9.72 at x = 3), and the first segment's
  // nearest cell (x = −2.5) 16 cm behind the second's plane.
  BridgeCase tilted;
  tilted.step_m = 0.2f;
  tilted.slope = -0.08f;
  ASSERT_EQ(tilted.config.bridge_max_cell_distance_m, 0.12);  // on by default
  tilted.run();
  EXPECT_EQ(tilted.surfaces_after, 2u);
  tilted.config.bridge_max_cell_distance_m = 0.0;  // off: the midpoint step alone bridges them
  tilted.run();
  EXPECT_EQ(tilted.surfaces_after, 1u);
  tilted.config.bridge_max_cell_distance_m = 0.25;  // both cells within 25 cm of the other plane
  tilted.run();
  EXPECT_EQ(tilted.surfaces_after, 1u);
  BridgeCase flat;  // one plane: the default bridges it as before
  flat.run();
  EXPECT_EQ(flat.surfaces_after, 1u);
  flat.config.bridge_max_cell_distance_m = -0.1;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { flat.run(); }), "map.bridge_max_cell_distance_m");
}

/// The defaults, with cells mapped out to 100 m whatever their depth noise (the long-gap cases
/// lie 10–40 m from the camera).
MapConfig far_reach_config() {
  MapConfig c;
  c.max_range_m = 100.0;
  c.max_depth_sigma_m = 0.0;
  return c;
}

/// A long bridge: two 6 m × 4 m floor patches at y = 1.5 (x ∈ [−3, 3]), z ∈ [8, 12] in frame 0
/// and z ∈ [22, 26] in frame 1, 10 m apart (beyond the 5 m bridge, within the 15 m one). Frame 0
/// optionally holds an occluder between the camera and the gap (a 4 m × 0.7 m board at z = 5,
/// y ∈ [0.2, 0.9], which every camera ray to the gap crosses) and a road strip in the gap, 15 cm
/// below the floor (y = 1.65, z ∈ [13, 21]); the second patch may be raised or of another colour.
struct LongBridgeCase {
  MapConfig config = far_reach_config();
  bool occluder = true;
  bool road_in_gap = false;
  float first_from_z = 8.0f;  ///< where the first patch begins (it ends at z = 12)
  float raise_m = 0.0f;
  int second_bin = 0;
  std::vector<MergeReport> reports;
  std::size_t run() {
    GlobalMap map(config);
    std::vector<Planecell> first, second;
    test::tile(first, {-3, 1.5f, first_from_z}, kX, kZ, 6, 12.0f - first_from_z, 1, 0, 0);
    if (occluder) test::tile(first, {-2, 0.2f, 5}, kX, kY, 4, 0.7f, 1, 0, 7);
    if (road_in_gap) test::tile(first, {-3, 1.65f, 13}, kX, kZ, 6, 8, 2, 0, 9);
    test::tile(second, {-3, 1.5f - raise_m, 22}, kX, kZ, 6, 4, 1, 0, second_bin);
    reports = {map.integrate(0, Pose::Identity(), first), map.integrate(1, Pose::Identity(), second)};
    return map.surfaces().size();
  }
};

TEST(Bridge, LargeSurfacesOfOnePlaneMergeAcrossALongGapAnOccluderHides) {
  LongBridgeCase c;
  ASSERT_EQ(c.config.bridge_long_gap_m, 15.0);  // on by default
  ASSERT_EQ(c.config.bridge_long_max_step_m, 0.04);
  EXPECT_EQ(c.run(), 2u);  // the floor and the occluder
  ASSERT_EQ(c.reports[1].surface_merges.size(), 1u);
  const SurfaceMerge merge = c.reports[1].surface_merges[0];
  EXPECT_EQ(merge.into, c.reports[0].cell_surfaces[0]);  // the older patch absorbs the newer
  EXPECT_EQ(merge.absorbed, c.reports[1].cell_surfaces[0]);
}

TEST(Bridge, ALongBridgeFindsTheNearEndOfASurfaceThatRunsFarBack) {
  // The first patch runs back 70 m (z ∈ [−58, 12], 420 cells in one surface): the long bridge
  // finds its cells near the second patch among the stored cells within reach of this frame.
  LongBridgeCase c;
  c.first_from_z = -58.0f;
  EXPECT_EQ(c.run(), 2u);
  ASSERT_EQ(c.reports[1].surface_merges.size(), 1u);
  EXPECT_EQ(c.reports[1].surface_merges[0].into, c.reports[0].cell_surfaces[0]);
  c.occluder = false;  // and still not across a gap the camera saw open
  EXPECT_EQ(c.run(), 2u);
  EXPECT_TRUE(c.reports[1].surface_merges.empty());
}

TEST(Bridge, NoLongBridgeWhenOffSeenOpenlyFilledSteppedOrOfAnotherColour) {
  LongBridgeCase off;
  off.config.bridge_long_gap_m = 0.0;
  EXPECT_EQ(off.run(), 3u);
  LongBridgeCase open;  // nothing in front of the gap: the camera would have seen it
  open.occluder = false;
  EXPECT_EQ(open.run(), 2u);
  LongBridgeCase filled;  // the gap holds a road 15 cm lower: two surfaces beside a road
  filled.road_in_gap = true;
  EXPECT_EQ(filled.run(), 4u);
  LongBridgeCase stepped;  // 10 cm higher: not one plane
  stepped.raise_m = 0.10f;
  EXPECT_EQ(stepped.run(), 3u);
  LongBridgeCase other_colour;
  other_colour.second_bin = 12;
  EXPECT_EQ(other_colour.run(), 3u);
  for (const auto* c : {&off, &open, &filled, &stepped, &other_colour})
    EXPECT_TRUE(c->reports[1].surface_merges.empty());
  MapConfig bad;
  bad.bridge_long_gap_m = 3.0;  // not beyond bridge_gap_m (5)
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.bridge_long_gap_m (3");
  bad.bridge_long_gap_m = 15.0;
  bad.bridge_long_min_colour = 2.0;
  EXPECT_THROW(GlobalMap{bad}, ConfigError);
}

/// Ground across a long gap: two 6 m × 4 m floor patches at y = 1.5 (x ∈ [−3, 3]; up is −y),
/// z ∈ [8, 12] seen in frames 0 and 1, z ∈ [37, 41] in frames 1 and 2: 25 m apart, beyond the
/// long bridge (15 m), nothing in front of the gap. Both go quiet after frame 2, and at frame 13
/// (dormant_after_frames 10) the first one due, going dormant, meets the other. Optionally the gap
/// holds a road strip 15 cm below the floor (y = 1.65, z ∈ [14, 35], large), or a small floor
/// fragment 8 cm off it (2 m × 2 m at z ∈ [24, 26]); the second patch may be raised, or both
/// patches stood up as walls (z = 8 and z = 37 swapped for x = 8, the same 25 m apart). The far
/// patch's colour histogram holds `far_colour_share` of its weight in the near one's bin (0) and
/// the rest in `far_other_bin`, by default 21, the same grey brighter (one chromaticity, one
/// paint): the two surfaces' colour similarity δ is that share.
struct GroundGapCase {
  MapConfig config = far_reach_config();
  bool road_in_gap = false;
  bool fragment_in_gap = false;
  float raise_m = 0.0f;
  bool walls = false;
  float far_colour_share = 1.0f;
  int far_other_bin = 21;  ///< where the rest of the far patch's colour weight goes
  float far_width_m = 6.0f;  ///< the far patch's extent along x (4 m along z)
  std::vector<MergeReport> reports;
  std::size_t run() {
    GlobalMap map(config);
    std::vector<Planecell> first, second, extra;
    if (walls) {
      test::tile(first, {8, -2.5f, 8}, kZ, kY, 6, 4, 1, 0, 0);
      test::tile(second, {8 - raise_m, -2.5f, 37}, kZ, kY, 6, 4, 1, 0, 0);
    } else {
      test::tile(first, {-3, 1.5f, 8}, kX, kZ, 6, 4, 1, 0, 0);
      test::tile(second, {-3, 1.5f - raise_m, 37}, kX, kZ, far_width_m, 4, 1, 0, 0);
    }
    for (Planecell& cell : second) {
      cell.histogram[0] = far_colour_share;
      cell.histogram[far_other_bin] = 1.0f - far_colour_share;
    }
    if (road_in_gap) test::tile(extra, {-3, 1.65f, 14}, kX, kZ, 6, 21, 1, 0, 9);
    if (fragment_in_gap) test::tile(extra, {-1, 1.58f, 24}, kX, kZ, 2, 2, 1, 0, 0);
    const auto frame = [](std::initializer_list<const std::vector<Planecell>*> parts) {
      std::vector<Planecell> cells;
      for (const auto* part : parts) cells.insert(cells.end(), part->begin(), part->end());
      for (std::size_t i = 0; i < cells.size(); ++i) cells[i].id = static_cast<std::uint32_t>(i);
      return cells;
    };
    reports = {map.integrate(0, Pose::Identity(), frame({&first, &extra})),
               map.integrate(1, Pose::Identity(), frame({&first, &second, &extra})),
               map.integrate(2, Pose::Identity(), frame({&second})),
               map.integrate(13, Pose::Identity(), {})};
    return map.surfaces().size();
  }
};

TEST(GroundJoin, LargeGroundSurfacesOfOnePlaneJoinAcrossALongGapWhenOneGoesDormant) {
  GroundGapCase c;
  ASSERT_EQ(c.config.ground_join_gap_m, 40.0);  // on by default
  ASSERT_EQ(c.config.bridge_long_gap_m, 15.0);
  EXPECT_EQ(c.run(), 1u);
  for (std::size_t f = 0; f < 3; ++f) EXPECT_TRUE(c.reports[f].surface_merges.empty()) << "frame " << f;
  const std::uint32_t near = c.reports[0].cell_surfaces[0], far = c.reports[2].cell_surfaces[0];
  ASSERT_NE(near, far);
  // The older surface (the near patch) absorbs the far one, at frame 13.
  EXPECT_EQ(c.reports[3].surface_merges, (std::vector<SurfaceMerge>{{13, far, near}}));
  GroundGapCase fragment;  // a 4 m² piece of the floor 8 cm off it, seen between occluders
  fragment.fragment_in_gap = true;
  EXPECT_EQ(fragment.run(), 2u);  // the floor and the fragment
  EXPECT_EQ(fragment.reports[3].surface_merges.size(), 1u);
}

TEST(GroundJoin, NoJoinWhenOffTooFarARoadLiesBetweenSteppedOrNotGround) {
  GroundGapCase off;
  off.config.ground_join_gap_m = 0.0;
  EXPECT_EQ(off.run(), 2u);
  GroundGapCase near_reach;  // 25 m between the patches' edges, more between their cells' centres
  near_reach.config.ground_join_gap_m = 20.0;
  EXPECT_EQ(near_reach.run(), 2u);
  GroundGapCase road;  // two sidewalks with a road between them, 15 cm below
  road.road_in_gap = true;
  EXPECT_EQ(road.run(), 3u);
  GroundGapCase stepped;  // 10 cm higher: not one plane (bridge_long_max_step_m 4 cm)
  stepped.raise_m = 0.10f;
  EXPECT_EQ(stepped.run(), 2u);
  GroundGapCase walls;  // coplanar walls 25 m apart: as often two buildings as one
  walls.walls = true;
  EXPECT_EQ(walls.run(), 2u);
  for (const auto* c : {&off, &near_reach, &road, &stepped, &walls}) EXPECT_TRUE(c->reports[3].surface_merges.empty());
  MapConfig bad;
  bad.ground_join_gap_m = -1.0;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.ground_join_gap_m");
}

/// A sidewalk's pieces mapped from 10 m and from 40 m differ in colour (distance blurs the
/// texture): the ground join's own colour test (ground_join_min_colour, 0.5) passes δ = 0.6, which
/// the long bridge's (bridge_long_min_colour, 0.75) would not; δ = 0.3, or δ = 0.6 of another
/// paint, stays apart.
TEST(GroundJoin, JoinsGroundOfAnotherLookWithinItsOwnColourTest) {
  GroundGapCase alike;
  ASSERT_EQ(alike.config.ground_join_min_colour, 0.5);
  ASSERT_EQ(alike.config.bridge_long_min_colour, 0.75);
  alike.far_colour_share = 0.6f;
  EXPECT_EQ(alike.run(), 1u);
  EXPECT_EQ(alike.reports[3].surface_merges.size(), 1u);
  GroundGapCase strict;  // the long bridge's colour test: apart
  strict.far_colour_share = 0.6f;
  strict.config.ground_join_min_colour = 0.75;
  EXPECT_EQ(strict.run(), 2u);
  GroundGapCase unlike;
  unlike.far_colour_share = 0.3f;
  EXPECT_EQ(unlike.run(), 2u);
  // δ = 0.6 again, the rest green (levels (0, 3, 0)): chromaticity (0.19, 0.63, 0.19), 0.36 from
  // the near grey's (MapConfig::max_chromaticity_distance): another paint, apart.
  GroundGapCase painted;
  painted.far_colour_share = 0.6f;
  painted.far_other_bin = 12;
  EXPECT_EQ(painted.run(), 2u);
  for (const auto* c : {&strict, &unlike, &painted}) EXPECT_TRUE(c->reports[3].surface_merges.empty());
  MapConfig bad;
  bad.ground_join_min_colour = 1.5;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.ground_join_min_colour");
}

/// A well-observed 12 m² piece of ground joins a large one across the gap (one of the pair at
/// least bridge_long_min_area_m2, 20, the other at least ground_join_min_area_m2, 10); an 8 m²
/// piece, or both under 20 m², or 12 m² with ground_join_min_area_m2 at 20, stay apart.
TEST(GroundJoin, ASmallerPieceJoinsALargeOneButTwoSmallOnesStayApart) {
  GroundGapCase smaller;
  ASSERT_EQ(smaller.config.ground_join_min_area_m2, 10.0);
  ASSERT_EQ(smaller.config.bridge_long_min_area_m2, 20.0);
  smaller.far_width_m = 3.0f;  // 12 m²
  EXPECT_EQ(smaller.run(), 1u);
  EXPECT_EQ(smaller.reports[3].surface_merges.size(), 1u);
  GroundGapCase too_small;
  too_small.far_width_m = 2.0f;  // 8 m²
  EXPECT_EQ(too_small.run(), 2u);
  GroundGapCase old_rule;  // both at least 20 m²
  old_rule.far_width_m = 3.0f;
  old_rule.config.ground_join_min_area_m2 = 20.0;
  EXPECT_EQ(old_rule.run(), 2u);
  GroundGapCase both_small;  // the near patch under 20 m² too
  both_small.far_width_m = 3.0f;
  both_small.config.bridge_long_min_area_m2 = 30.0;
  EXPECT_EQ(both_small.run(), 2u);
  GroundGapCase thresholds_swapped;  // 24 m² and 12 m² against 10 and 20 m² the other way round
  thresholds_swapped.far_width_m = 3.0f;
  thresholds_swapped.config.bridge_long_min_area_m2 = 10.0;
  thresholds_swapped.config.ground_join_min_area_m2 = 20.0;
  EXPECT_EQ(thresholds_swapped.run(), 1u);
  for (const auto* c : {&too_small, &old_rule, &both_small}) EXPECT_TRUE(c->reports[3].surface_merges.empty());
  MapConfig bad;
  bad.ground_join_min_area_m2 = -1.0;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.ground_join_min_area_m2");
}

TEST(Bridge, NegativeGapOrAreaIsAConfigError) {
  MapConfig config;
  config.bridge_gap_m = -1.0;
  EXPECT_THROW(GlobalMap{config}, ConfigError);
  config.bridge_gap_m = 5.0;
  config.bridge_min_area_m2 = -1.0;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{config}; }),
                  "map.bridge_min_area_m2: must be >= 0");
}

/// Frame f of a drive along a 4 m wide road (y = 1.5, x ∈ [−2, 2]): the row z ∈ [2f, 2f + 2] in
/// four 1 m × 2 m cells, all new; the camera 5 m behind the row.
std::vector<Planecell> road_row(int f) {
  std::vector<Planecell> cells;
  for (int i = 0; i < 4; ++i)
    cells.push_back(
        rect_cell(static_cast<std::uint32_t>(i), {-2.0f + i, 1.5f, 2.0f * f}, kX, kZ * 2, 3));
  return cells;
}

Pose road_pose(int f) {
  Pose pose = Pose::Identity();
  pose.translation().z() = 2.0 * f - 5.0;
  return pose;
}

TEST(Consolidation, OldCellsOfARoadBecomeFewerCellsCoveringTheSameRoad) {
  MapConfig config;
  config.consolidate_after_frames = 5;
  MapConfig off_config;
  off_config.consolidate_after_frames = 0;
  GlobalMap map(config), off(off_config), resumed(config);
  constexpr int kFrames = 40;
  std::size_t consolidated = 0, removed = 0;
  for (int f = 0; f < kFrames; ++f) {
    if (f == 20) {  // restored from what a store holds after frame 19
      std::vector<MapCell> cells;
      std::vector<Surface> surfaces;
      for (const auto& [id, c] : map.cells()) cells.push_back(c);
      for (const auto& [id, s] : map.surfaces()) surfaces.push_back(s);
      resumed = GlobalMap::restore(config, cells, surfaces, map.next_cell_id(),
                                   map.next_surface_id(), 19);
    }
    const auto report = map.integrate(static_cast<std::uint64_t>(f), road_pose(f), road_row(f));
    if (f >= 20) resumed.integrate(static_cast<std::uint64_t>(f), road_pose(f), road_row(f));
    off.integrate(static_cast<std::uint64_t>(f), road_pose(f), road_row(f));
    // Only cells 5 frames old or older are consolidated, and they leave the map.
    for (std::uint32_t id : report.removed_cells) EXPECT_EQ(map.cell(id), nullptr);
    consolidated += report.consolidated_cells;
    removed += report.removed_cells.size();
  }
  ASSERT_EQ(off.cells().size(), 4u * kFrames);
  ASSERT_EQ(map.surfaces().size(), 1u);
  EXPECT_EQ(consolidated, removed);  // nothing else left the map
  // Frames 35–39 are younger than 5 frames: their 20 cells are as stored. An older cell stays as
  // stored only in an 8 m square of the surface's basis that also holds a young cell (a square is
  // consolidated once all its cells are old); every other one went into a union of two or more
  // (the road is one surface, its old cells touch): a cell of 4 m² or more (its outline half a
  // 5 cm bit inside), as old as its newest member.
  const Surface& road = *map.surface(map.cells().begin()->second.surface);
  auto square_of = [&](const MapCell& cell) {
    const Eigen::Vector2d st =
        road.detail->basis.to_2d(vertex_centroid(cell.vertices_m)) / config.consolidate_tile_m;
    return std::pair(std::floor(st.x()), std::floor(st.y()));
  };
  std::set<std::pair<double, double>> young_squares;
  std::size_t young = 0;
  for (const auto& [id, cell] : map.cells())
    if (cell.frame_id >= 35) {
      young +=
          cell.vertices_m.size() == 4 && std::abs(polygon_area_m2(cell.vertices_m) - 2.0) < 1e-4;
      young_squares.insert(square_of(cell));
    }
  EXPECT_EQ(young, 20u);
  std::size_t waiting = 0;
  for (const auto& [id, cell] : map.cells()) {
    if (cell.frame_id >= 35) continue;
    const double area = polygon_area_m2(cell.vertices_m);
    if (std::abs(area - 2.0) < 1e-4) {
      EXPECT_TRUE(young_squares.contains(square_of(cell)))
          << "cell " << id << " of frame " << cell.frame_id;
      ++waiting;
    } else {
      EXPECT_GE(area, 4.0 - 0.5) << "cell " << id << " of frame " << cell.frame_id;
    }
  }
  // At most the two squares along the road that the young cells reach (10 m) hold waiting cells:
  // 2 · 4 rows of 2 m of 4 cells. A union re-united with later cells of its square counts again.
  EXPECT_LE(waiting, 32u);
  EXPECT_GE(consolidated, 4u * 35 - waiting);
  young = 20 + waiting;
  // The consolidated road, 70 m × 4 m less the waiting rows (2 m per 4 cells), is now a handful of
  // cells: at least one per 8 m square along it, at most two per square across it, plus the two
  // squares at its ends.
  const std::size_t pieces = map.cells().size() - young;
  const double consolidated_m = 70.0 - 2.0 * static_cast<double>(waiting / 4);
  EXPECT_GE(pieces, static_cast<std::size_t>(consolidated_m / 8.0));
  EXPECT_LE(pieces, 2u * (70 / 8 + 2));
  // The same road: every point 0.5 m inside a cell lies on a stored cell (point-to-plane
  // distance 0), and every vertex stays on the road plane, within a raster bit plus the
  // tolerance of its edges.
  for (double z = 0.5; z < 2.0 * kFrames; z += 1.0)
    for (double x = -1.5; x <= 1.5; x += 1.0) {
      const auto hit = map.nearest_cell(Eigen::Vector3d(x, 1.5, z), 0.5);
      ASSERT_TRUE(hit.has_value()) << x << ", " << z;
      EXPECT_NEAR(hit->distance_m, 0.0, 1e-4) << x << ", " << z;
    }
  const double margin = config.consolidate_resolution_m + config.consolidate_tolerance_m + 1e-4;
  for (const auto& [id, cell] : map.cells())
    for (const auto& v : cell.vertices_m) {
      EXPECT_NEAR(v.y(), 1.5f, 1e-4f);
      EXPECT_LE(std::abs(v.x()), 2.0 + margin);
      EXPECT_GE(v.z(), -margin);
      EXPECT_LE(v.z(), 2.0 * kFrames + margin);
    }
  EXPECT_LT(map.map_bytes(), off.map_bytes());
  // Restored half-way with the last frame it had seen, it consolidates what the uninterrupted map
  // did.
  EXPECT_TRUE(map.same_content(resumed));
}

TEST(Consolidation, ATurnedAndSlopedRoadIsConsolidatedSquareBySquare) {
  // The road above moved by a rigid motion: turned 35° about the vertical and sloped 8°, so the
  // consolidation squares of the surface's basis run askew to the road.
  // Driven 40 frames with 8 m squares, the map finds a square's cells by scanning the road's;
  // driven 120 frames with 3 m squares, the road holds far more cells than the due squares, and
  // the map finds them through its spatial index instead.
  for (const auto& [kFrames, tile_m] : {std::pair{40, 8.0}, std::pair{120, 3.0}}) {
    SCOPED_TRACE(std::to_string(kFrames) + " frames, " + std::to_string(tile_m) + " m squares");
    MapConfig config;
    config.consolidate_after_frames = 5;
    config.consolidate_tile_m = tile_m;
    GlobalMap map(config);
    Pose motion = Pose::Identity();
    motion.linear() = (Eigen::AngleAxisd(35.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()) *
                       Eigen::AngleAxisd(8.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()))
                          .toRotationMatrix();
    motion.translation() = Eigen::Vector3d(3.0, -1.0, 7.0);
    std::vector<Eigen::Vector3d> centroids;  // of every cell handed in, frame by frame
    for (int f = 0; f < kFrames; ++f) {
      const std::vector<Planecell> row = to_world(road_row(f), motion);
      for (const Planecell& cell : row) centroids.push_back(vertex_centroid(cell.vertices_m));
      map.integrate(static_cast<std::uint64_t>(f), motion * road_pose(f), row);
    }
    ASSERT_EQ(map.surfaces().size(), 1u);
    const Surface& road = *map.surface(map.cells().begin()->second.surface);
    using Square = std::pair<double, double>;
    auto square_of = [&](const Eigen::Vector3d& centroid) {
      const Eigen::Vector2d st = road.detail->basis.to_2d(centroid) / config.consolidate_tile_m;
      return Square(std::floor(st.x()), std::floor(st.y()));
    };
    // The rule, counted from the cells handed in: a square is united once all its cells are 5
    // frames old (all but the last 5 frames), and only when it holds two or more; a cell alone in
    // its square, or in a square a cell of the last 5 frames shares, stays as stored.
    std::map<Square, int> cells_in;
    std::set<Square> young;
    for (std::size_t i = 0; i < centroids.size(); ++i) {
      ++cells_in[square_of(centroids[i])];
      if (i >= 4u * (kFrames - 5)) young.insert(square_of(centroids[i]));
    }
    std::size_t expected_kept = 0;
    for (std::size_t i = 0; i < 4u * (kFrames - 5); ++i) {
      const Square square = square_of(centroids[i]);
      expected_kept += young.contains(square) || cells_in.at(square) == 1;
    }
    // the askew squares still unite most of the road
    ASSERT_LT(expected_kept, 4u * (kFrames - 5) / 2);
    std::size_t kept = 0;
    for (const auto& [id, cell] : map.cells()) {
      if (cell.frame_id + 5 >= static_cast<std::uint64_t>(kFrames)) continue;
      const double area = polygon_area_m2(cell.vertices_m);
      if (std::abs(area - 2.0) < 0.01) {  // as stored (its vertices on the millimetre grid)
        const Square square = square_of(vertex_centroid(cell.vertices_m));
        EXPECT_TRUE(young.contains(square) || cells_in.at(square) == 1)
            << "cell " << id << " of frame " << cell.frame_id;
        ++kept;
      } else {
        EXPECT_GE(area, 4.0 - 0.5) << "cell " << id << " of frame " << cell.frame_id;
      }
    }
    EXPECT_EQ(kept, expected_kept);
  }
}

TEST(Consolidation, BadSettingsAreConfigErrors) {
  for (const auto& set : std::vector<std::function<void(MapConfig&)>>{
           [](MapConfig& c) { c.consolidate_tile_m = 0.0; },
           [](MapConfig& c) { c.consolidate_resolution_m = -0.05; },
           [](MapConfig& c) { c.consolidate_square_reach_m = 0.0; },
           [](MapConfig& c) { c.consolidate_tolerance_m = std::nan(""); },
           [](MapConfig& c) { c.consolidate_max_distance_m = -1.0; }}) {
    MapConfig config;
    set(config);
    EXPECT_THROW(GlobalMap{config}, ConfigError);
    config.consolidate_after_frames = 0;  // off: the other settings are not used
    EXPECT_NO_THROW(GlobalMap{config});
  }
}

/// Settling at the end of a session: the 4 m road of road_row driven for 12 frames (consolidation
/// and dormancy after 5 frames) and a 1 m × 1 m sign 6 m beside it seen in the last frame only.
struct SettleDrive {
  static constexpr int kFrames = 12;
  static MapConfig config() {
    MapConfig c;
    c.consolidate_after_frames = 5;
    c.dormant_after_frames = 5;
    return c;
  }
  static std::vector<Planecell> frame(int f) {
    std::vector<Planecell> cells = road_row(f);
    if (f == kFrames - 1)
      cells.push_back(rect_cell(4, {6.0f, -1.0f, 2.0f * f}, kZ, kY, 12));  // the sign
    return cells;
  }
};

TEST(Settle, EveryCellIsConsolidatedAndEverySurfaceSleepsASingleViewToo) {
  const MapConfig config = SettleDrive::config();
  ASSERT_EQ(config.unconfirmed_timeout_frames, 10);
  GlobalMap map(config);
  std::uint32_t road = kNoSurface, sign = kNoSurface;
  for (int f = 0; f < SettleDrive::kFrames; ++f) {
    const auto report = map.integrate(static_cast<std::uint64_t>(f), road_pose(f), SettleDrive::frame(f));
    if (f == 0) road = report.cell_surfaces[0];
    if (f == SettleDrive::kFrames - 1) sign = report.cell_surfaces[4];
  }
  ASSERT_NE(sign, road);
  ASSERT_EQ(map.surfaces().size(), 2u);
  ASSERT_TRUE(map.surface(road)->detail.has_value());
  // Frames 7–11 are not consolidated yet: their 20 road cells are as stored (1 m × 2 m).
  auto stored_as_seen = [&] {
    std::size_t n = 0;
    for (const auto& [id, cell] : map.cells())
      n += cell.surface == road && std::abs(polygon_area_m2(cell.vertices_m) - 2.0) < 1e-4;
    return n;
  };
  ASSERT_GE(stored_as_seen(), 20u);
  const std::size_t live_bytes = map.map_bytes();
  const std::set<std::uint32_t> before_ids = [&] {
    std::set<std::uint32_t> ids;
    for (const auto& [id, cell] : map.cells()) ids.insert(id);
    return ids;
  }();

  const MergeReport report = map.settle(SettleDrive::kFrames - 1);
  EXPECT_EQ(report.frame_id, static_cast<std::uint64_t>(SettleDrive::kFrames - 1));
  // The road and the sign sleep. The sign, a single view, is not pruned: a later session may
  // confirm it (the unconfirmed timeout still runs then).
  EXPECT_TRUE(report.pruned_surfaces.empty());
  EXPECT_EQ(report.dormant_surfaces, (std::vector<std::uint32_t>{std::min(road, sign), std::max(road, sign)}));
  ASSERT_EQ(map.surfaces().size(), 2u);
  EXPECT_FALSE(map.surface(road)->detail.has_value());
  EXPECT_FALSE(map.surface(sign)->detail.has_value());
  EXPECT_EQ(map.surface(sign)->cells.size(), 1u);
  // Every road cell went into a union of two or more (the road's cells touch): none is left as
  // seen, and every removed cell and every added one is reported.
  EXPECT_EQ(stored_as_seen(), 0u);
  EXPECT_GT(report.consolidated_cells, 0u);
  for (std::uint32_t id : report.removed_cells) {
    EXPECT_TRUE(before_ids.contains(id)) << id;
    EXPECT_EQ(map.cell(id), nullptr) << id;
  }
  for (std::uint32_t id : report.added_cells) EXPECT_NE(map.cell(id), nullptr) << id;
  for (const auto& [id, cell] : map.cells())
    EXPECT_TRUE(before_ids.contains(id) || std::find(report.added_cells.begin(), report.added_cells.end(), id) !=
                                               report.added_cells.end()) << id;
  // The same road: every point 0.5 m inside a seen cell lies on a stored cell.
  for (double z = 0.5; z < 2.0 * SettleDrive::kFrames; z += 1.0)
    for (double x = -1.5; x <= 1.5; x += 1.0) {
      const auto hit = map.nearest_cell(Eigen::Vector3d(x, 1.5, z), 0.5);
      ASSERT_TRUE(hit.has_value()) << x << ", " << z;
      EXPECT_NEAR(hit->distance_m, 0.0, 1e-4) << x << ", " << z;
    }
  EXPECT_LT(map.map_bytes(), live_bytes);
  // Settled once, settling again changes nothing.
  const GlobalMap settled = map;
  const MergeReport again = map.settle(SettleDrive::kFrames - 1);
  EXPECT_TRUE(again.added_cells.empty() && again.removed_cells.empty() && again.updated_surfaces.empty() &&
              again.dormant_surfaces.empty() && again.surface_merges.empty() && again.pruned_surfaces.empty());
  EXPECT_TRUE(map.same_content(settled));
}

TEST(Settle, ASettledMapRestoredAsSettledDrivesOnAsTheOneInMemory) {
  const MapConfig config = SettleDrive::config();
  GlobalMap map(config);
  for (int f = 0; f < SettleDrive::kFrames; ++f)
    map.integrate(static_cast<std::uint64_t>(f), road_pose(f), SettleDrive::frame(f));
  map.settle(SettleDrive::kFrames - 1);
  std::vector<MapCell> cells;
  std::vector<Surface> surfaces;
  for (const auto& [id, c] : map.cells()) cells.push_back(c);
  for (const auto& [id, s] : map.surfaces()) surfaces.push_back(s);
  GlobalMap resumed = GlobalMap::restore(config, cells, surfaces, map.next_cell_id(), map.next_surface_id(),
                                         SettleDrive::kFrames - 1, true);
  ASSERT_TRUE(resumed.same_content(map));
  // The drive goes on along the road: the new rows wake the sleeping road and join it.
  for (int f = SettleDrive::kFrames; f < SettleDrive::kFrames + 8; ++f) {
    const auto report = map.integrate(static_cast<std::uint64_t>(f), road_pose(f), road_row(f));
    resumed.integrate(static_cast<std::uint64_t>(f), road_pose(f), road_row(f));
    if (f == SettleDrive::kFrames) {
      ASSERT_EQ(map.surfaces().size(), 2u);  // the road, woken, and the sign
      const std::uint32_t road = report.cell_surfaces[0];
      ASSERT_NE(map.surface(road), nullptr);
      EXPECT_TRUE(map.surface(road)->detail.has_value());
      EXPECT_GT(map.surface(road)->cells.size(), 1u);
    }
  }
  EXPECT_TRUE(resumed.same_content(map));
}

}  // namespace
}  // namespace planecell::map
