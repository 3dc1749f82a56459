/// CRF merger (paper Eq. CRFFunction): energy terms against hand-computed values, label adjacency,
/// union-find, and merging decisions on synthetic cells with known geometry.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "support/planecell_fixtures.hpp"
#include "core/error.hpp"
#include "mapping/map/crf_merger.hpp"
#include "mapping/map/global_map.hpp"

namespace planecell::map {
namespace {

using test::rect_cell;

const Eigen::Vector3f kX(1, 0, 0), kY(0, 1, 0), kZ(0, 0, 1);

TEST(LabelAdjacency, CountsSharedBoundaryPixelPairs) {
  // 0 0 1 1
  // 0 0 1 1
  // 2 2 2 1
  cv::Mat labels = (cv::Mat_<int>(3, 4) << 0, 0, 1, 1, 0, 0, 1, 1, 2, 2, 2, 1);
  const auto edges = label_adjacency(labels);
  ASSERT_EQ(edges.size(), 3u);
  EXPECT_EQ(edges[0], (LabelEdge{0, 1, 2}));  // two horizontal pairs in rows 0 and 1
  EXPECT_EQ(edges[1], (LabelEdge{0, 2, 2}));  // two vertical pairs between rows 1 and 2
  EXPECT_EQ(edges[2], (LabelEdge{1, 2, 2}));  // (row 1, col 2)-(row 2, col 2) and (2,2)-(2,3)
}

TEST(LabelAdjacency, IgnoresNegativeLabelsAndRejectsWrongType) {
  cv::Mat labels = (cv::Mat_<int>(1, 3) << 0, -1, 1);
  EXPECT_TRUE(label_adjacency(labels).empty());
  EXPECT_THROW(label_adjacency(cv::Mat(2, 2, CV_8U, cv::Scalar(0))), InputError);
  EXPECT_THROW(label_adjacency(cv::Mat()), InputError);
}

TEST(EnergyTerms, MatchHandComputedValues) {
  ColourHistogram a{}, b{};
  a[0] = 0.5f, a[1] = 0.5f;
  b[0] = 0.25f, b[1] = 0.75f;
  EXPECT_NEAR(colour_similarity(a, b), 0.25 + 0.5, 1e-6);
  EXPECT_NEAR(colour_similarity(a, a), 1.0, 1e-6);

  Plane3 ground;  // y = 0
  ground.normal = Eigen::Vector3d::UnitY();
  const std::vector<Eigen::Vector3f> vertices = {{0, 0.1f, 0}, {1, -0.1f, 0}, {1, 0.1f, 1}, {0, -0.1f, 1}};
  // RMS distance 0.1 m, σ = 0.05 m → θ' = 2.
  EXPECT_NEAR(plane_residual(ground, vertices, 0.05), 2.0, 1e-6);
  EXPECT_NEAR(pose_potential(1.0, 1.0, 2.0, 2.0), 2.0 / 9.0, 1e-12);
  EXPECT_NEAR(pose_potential(1.5, 0.5, 0.0, 0.0), 2.0, 1e-12);
  EXPECT_NEAR(boundary_potential(3.0, 1.0), 1.5, 1e-12);
}

TEST(UnionFindTest, SmallerLabelBecomesRoot) {
  UnionFind uf;
  EXPECT_EQ(uf.find(9), 9u);
  EXPECT_EQ(uf.unite(5, 3), 3u);
  EXPECT_EQ(uf.find(5), 3u);
  EXPECT_EQ(uf.unite(7, 5), 3u);
  EXPECT_EQ(uf.find(7), 3u);
  EXPECT_EQ(uf.unite(1, 7), 1u);
  EXPECT_EQ(uf.find(5), 1u);
  EXPECT_EQ(uf.find(9), 9u);
}

TEST(PlaneMomentsTest, FitRecoversTiltedPlane) {
  // Plane y = 0.5 x + 2 through two rectangles: normal ∝ (0.5, −1, 0).
  PlaneMoments m;
  const std::vector<Eigen::Vector3f> p1 = {{0, 2, 0}, {1, 2.5f, 0}, {1, 2.5f, 1}, {0, 2, 1}};
  const std::vector<Eigen::Vector3f> p2 = {{2, 3, 0}, {3, 3.5f, 0}, {3, 3.5f, 2}, {2, 3, 2}};
  m.add_polygon(p1, 1.0);
  m.add_polygon(p2, 2.0);
  const Plane3 plane = m.fit(Eigen::Vector3d(0, -1, 0));
  const Eigen::Vector3d expected = Eigen::Vector3d(0.5, -1, 0).normalized();
  EXPECT_NEAR(plane.normal.dot(expected), 1.0, 1e-9);
  EXPECT_NEAR(plane.signed_distance({4.0, 4.0, 7.0}), 0.0, 1e-9);  // 0.5·4 + 2 = 4
}

/// Merging decisions on one frame of synthetic cells; runs both neighbour routes (3D proximity,
/// image adjacency).
class PairMerge : public ::testing::TestWithParam<bool> {
 protected:
  /// Integrates two cells in one frame; returns whether they ended on one surface.
  bool merged(const Planecell& a, const Planecell& b) {
    GlobalMap map;
    const std::vector<Planecell> cells = {a, b};
    const std::vector<LabelEdge> adjacency = {{a.id, b.id, 20}};
    const auto report = map.integrate(1, Pose::Identity(), cells,
                                      GetParam() ? std::span<const LabelEdge>(adjacency)
                                                 : std::span<const LabelEdge>());
    EXPECT_EQ(report.added_cells.size(), 2u);
    const auto& stored = map.cells();
    return stored.at(report.added_cells[0]).surface == stored.at(report.added_cells[1]).surface;
  }
};

TEST_P(PairMerge, CoplanarAdjacentSameColourMerge) {
  // Two 1 m road squares side by side on y = 1.5 (KITTI: road below the camera, y down).
  EXPECT_TRUE(merged(rect_cell(0, {0, 1.5f, 5}, kX, kZ, 3), rect_cell(1, {1, 1.5f, 5}, kX, kZ, 3)));
}

TEST_P(PairMerge, PerpendicularPairDoesNotMerge) {
  // A road square and a wall square standing on its far edge.
  EXPECT_FALSE(merged(rect_cell(0, {0, 1.5f, 5}, kX, kZ, 3), rect_cell(1, {0, 0.5f, 6}, kX, kY, 3)));
}

TEST_P(PairMerge, ParallelOffsetCurbDoesNotMerge) {
  // Sidewalk 15 cm above the road (y − 0.15), touching it along x = 1: a curb.
  EXPECT_FALSE(merged(rect_cell(0, {0, 1.5f, 5}, kX, kZ, 3), rect_cell(1, {1, 1.35f, 5}, kX, kZ, 3)));
}

TEST_P(PairMerge, DifferentColourDoesNotMerge) {
  EXPECT_FALSE(merged(rect_cell(0, {0, 1.5f, 5}, kX, kZ, 3), rect_cell(1, {1, 1.5f, 5}, kX, kZ, 40)));
}

TEST_P(PairMerge, SlightlyTiltedNeighbourWithinRangeMerges) {
  // 3° slope change (< 10°) across the shared edge: still one road surface.
  const float drop = std::tan(3.0f * 3.14159265f / 180.0f);
  EXPECT_TRUE(merged(rect_cell(0, {0, 1.5f, 5}, kX, kZ, 3),
                     rect_cell(1, {1, 1.5f, 5}, Eigen::Vector3f(1, drop, 0), kZ, 3)));
}

INSTANTIATE_TEST_SUITE_P(NeighbourRoutes, PairMerge, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "ImageAdjacency" : "Proximity3d"; });

TEST(IncrementalMerge, ReobservedRoadJoinsExistingSurface) {
  GlobalMap map;
  const std::vector<Planecell> frame1 = {rect_cell(0, {0, 1.5f, 5}, kX, kZ, 3),
                                         rect_cell(1, {1, 1.5f, 5}, kX, kZ, 3)};
  const auto r1 = map.integrate(1, Pose::Identity(), frame1);
  ASSERT_EQ(map.surfaces().size(), 1u);
  const std::uint32_t road = map.surfaces().begin()->first;
  EXPECT_EQ(r1.updated_surfaces, std::vector<std::uint32_t>{road});

  // Frame 2: the next metre of road (overlapping the first by 20 cm) and the half it re-observes.
  Pose pose = Pose::Identity();
  pose.translation() = Eigen::Vector3d(0, 0, 1);
  const std::vector<Planecell> frame2 = {rect_cell(0, {1, 1.5f, 5.8f}, kX, kZ, 3),
                                         rect_cell(1, {0.1f, 1.5f, 5.1f}, {0.8f, 0, 0}, {0, 0, 0.8f}, 3)};
  const auto r2 = map.integrate(2, pose, frame2);
  EXPECT_EQ(map.surfaces().size(), 1u);
  EXPECT_EQ(r2.fused_cells, 1u);  // the re-observed square adds no area
  ASSERT_EQ(r2.added_cells.size(), 1u);
  EXPECT_EQ(map.cell(r2.added_cells[0])->surface, road);
  EXPECT_EQ(map.surface(road)->cells.size(), 3u);
  EXPECT_EQ(map.surface(road)->observations, 4u);
  // Footprint: 2 × 1 m² plus the new square's 0.8 m² outside the first two.
  EXPECT_NEAR(map.surface(road)->area_m2, 2.0 + 0.8, 1e-6);
}

TEST(IncrementalMerge, BridgingCellMergesTwoSurfacesAndReportsEvent) {
  GlobalMap map;
  // Two road squares 1 m apart (> neighbour gap): two surfaces.
  const std::vector<Planecell> frame1 = {rect_cell(0, {0, 1.5f, 5}, kX, kZ, 3),
                                         rect_cell(1, {2, 1.5f, 5}, kX, kZ, 3)};
  map.integrate(1, Pose::Identity(), frame1);
  ASSERT_EQ(map.surfaces().size(), 2u);
  const std::uint32_t first = map.cells().at(0).surface, second = map.cells().at(1).surface;
  ASSERT_LT(first, second);
  // Frame 2 sees the road in between.
  const std::vector<Planecell> frame2 = {rect_cell(0, {1, 1.5f, 5}, kX, kZ, 3)};
  const auto r2 = map.integrate(2, Pose::Identity(), frame2);
  ASSERT_EQ(r2.surface_merges.size(), 1u);
  EXPECT_EQ(r2.surface_merges[0], (SurfaceMerge{2, second, first}));
  EXPECT_EQ(r2.removed_surfaces, std::vector<std::uint32_t>{second});
  EXPECT_EQ(r2.relabelled_cells, std::vector<std::uint32_t>{1});
  EXPECT_EQ(map.surfaces().size(), 1u);
  for (const auto& [id, cell] : map.cells()) EXPECT_EQ(cell.surface, first);
  EXPECT_NEAR(map.surface(first)->area_m2, 3.0, 1e-6);
}

}  // namespace
}  // namespace planecell::map
