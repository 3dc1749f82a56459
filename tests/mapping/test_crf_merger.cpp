/// CRF merger (paper Eq. CRFFunction): energy terms against hand-computed values, label adjacency,
/// union-find, and merging decisions on synthetic cells with known geometry.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <map>
#include <random>
#include <set>

#include "support/planecell_fixtures.hpp"
#include "core/error.hpp"
#include "mapping/map/crf_merger.hpp"
#include "mapping/map/global_map.hpp"

namespace planecell::map {
namespace {

using test::rect_cell;

using test::kX;
using test::kY;
using test::kZ;

/// σ_n = σ_Z·|n·C + e| / |X̄ − C|: a wall seen head-on keeps (almost) all of σ_Z, a road cell
/// 1.65 m below the camera and 16.5 m ahead keeps 1.65 / √(1.65² + 16.5²) of it, a cell seen
/// from its own centroid keeps σ_Z, and one without vertices has none.
TEST(NormalDepthSigma, IsTheDepthNoiseAlongThePlaneNormal) {
  Planecell wall = test::rect_cell(0, {-0.5f, -0.5f, 10}, {1, 0, 0}, {0, 1, 0}, 0);
  wall.depth_sigma_m = 0.2f;
  EXPECT_NEAR(normal_depth_sigma_m(wall, Eigen::Vector3d::Zero()), 0.2, 1e-7);  // X̄ = (0, 0, 10)
  Planecell road = test::rect_cell(1, {-0.5f, 1.65f, 16}, {1, 0, 0}, {0, 0, 1}, 0);
  road.depth_sigma_m = 0.4f;
  const double range = std::hypot(1.65, 16.5);  // X̄ = (0, 1.65, 16.5)
  EXPECT_NEAR(normal_depth_sigma_m(road, Eigen::Vector3d::Zero()), 0.4 * 1.65 / range, 1e-7);
  // From a camera 1 m higher the road is 2.65 m below it.
  EXPECT_NEAR(normal_depth_sigma_m(road, Eigen::Vector3d(0, -1, 0)), 0.4 * 2.65 / std::hypot(2.65, 16.5), 1e-7);
  EXPECT_NEAR(normal_depth_sigma_m(road, Eigen::Vector3d(0, 1.65, 16.5)), 0.4, 1e-7);
  road.vertices_m.clear();
  EXPECT_EQ(normal_depth_sigma_m(road, Eigen::Vector3d::Zero()), 0.0);
}

/// The range noise is kept beside the plane-fit weights: a cell of σ_Z = 0.4 m and range noise
/// 0.1 m keeps weight area / 0.4² and ranges by 0.1 m; two labels fold to the harmonic means
/// √(Σ area / Σ area/ρ²) and √(Σ area / Σ area/σ²); a label without range information (a stored
/// surface's state) ranges by its σ_eff.
TEST(NormalDepthSigma, RangeNoiseAndPlaneWeightsFoldSeparately) {
  Planecell a = test::rect_cell(0, {0, 1.5f, 5}, {1, 0, 0}, {0, 0, 1}, 0);
  Planecell b = test::rect_cell(1, {1, 1.5f, 5}, {1, 0, 0}, {0, 0, 1}, 0);
  a.depth_sigma_m = 0.4f;
  b.depth_sigma_m = 0.2f;
  LabelState la = state_of_cell(a, 1.0, 0.1, 0.05);
  EXPECT_NEAR(la.sigma_m(), 0.4, 1e-7);
  EXPECT_NEAR(la.range_sigma_m(), 0.1, 1e-12);
  EXPECT_NEAR(state_of_cell(a, 1.0, 0.01, 0.05).range_sigma_m(), 0.05, 1e-12);  // floored
  fold_label(la, state_of_cell(b, 3.0, 0.2, 0.05));
  EXPECT_NEAR(la.sigma_m(), std::sqrt(4.0 / (1.0 / (0.4 * 0.4) + 3.0 / (0.2 * 0.2))), 1e-6);
  EXPECT_NEAR(la.range_sigma_m(), std::sqrt(4.0 / (1.0 / (0.1 * 0.1) + 3.0 / (0.2 * 0.2))), 1e-6);
  LabelState surface = state_of_cell(b, 3.0, 0.05);
  surface.range_information = 0.0;  // as state_of_surface: the map keeps no range information
  EXPECT_NEAR(surface.range_sigma_m(), surface.sigma_m(), 1e-12);
  fold_label(surface, state_of_cell(a, 1.0, 0.1, 0.05));
  EXPECT_NEAR(surface.range_sigma_m(), std::sqrt(4.0 / (3.0 / (0.2 * 0.2) + 1.0 / (0.1 * 0.1))), 1e-6);
}

/// The label pairs of every 4-connected pixel pair with two different non-negative labels,
/// counted one pixel pair at a time (std::map, sorted by (a, b)): label_adjacency's answer.
std::vector<LabelEdge> adjacency_by_hand(const cv::Mat& labels) {
  std::map<std::pair<int, int>, std::uint32_t> expected;
  for (int r = 0; r < labels.rows; ++r)
    for (int c = 0; c < labels.cols; ++c)
      for (const auto& [dr, dc] : {std::pair{0, 1}, std::pair{1, 0}}) {
        if (r + dr >= labels.rows || c + dc >= labels.cols) continue;
        const int p = labels.at<int>(r, c), q = labels.at<int>(r + dr, c + dc);
        if (p != q && p >= 0 && q >= 0) ++expected[{std::min(p, q), std::max(p, q)}];
      }
  std::vector<LabelEdge> by_hand;
  for (const auto& [pair, n] : expected)
    by_hand.push_back({static_cast<std::uint32_t>(pair.first), static_cast<std::uint32_t>(pair.second), n});
  return by_hand;
}

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

TEST(LabelAdjacency, DenseAndSparseLabelValuesCountTheSamePairs) {
  // Random rectangles painted over a 60 × 80 image (labels 0..39, some -1): the pairs counted by
  // hand (std::map over every 4-connected pixel pair) equal label_adjacency's, and so do they for
  // the same image with the labels spread over the int32 range (the hash-map path).
  std::mt19937 rng(7);
  cv::Mat labels(60, 80, CV_32S, cv::Scalar(0));
  for (int k = 0; k < 120; ++k) {
    const int r = static_cast<int>(rng() % 55), c = static_cast<int>(rng() % 75);
    const int label = static_cast<int>(rng() % 41) - 1;
    labels(cv::Rect(c, r, 1 + static_cast<int>(rng() % 20), 1 + static_cast<int>(rng() % 15)) &
           cv::Rect(0, 0, 80, 60)) = label;
  }
  const std::vector<LabelEdge> by_hand = adjacency_by_hand(labels);
  ASSERT_GT(by_hand.size(), 30u);
  EXPECT_EQ(label_adjacency(labels), by_hand);
  auto spread = [](int label) { return label < 0 ? label : 50'000'000 * label + 123; };
  cv::Mat sparse = labels.clone();
  sparse.forEach<int>([&](int& v, const int*) { v = spread(v); });
  std::vector<LabelEdge> spread_by_hand;
  for (const auto& e : by_hand)
    spread_by_hand.push_back({static_cast<std::uint32_t>(spread(static_cast<int>(e.a))),
                              static_cast<std::uint32_t>(spread(static_cast<int>(e.b))), e.boundary_px});
  EXPECT_EQ(label_adjacency(sparse), spread_by_hand);
}

TEST(LabelAdjacency, EveryWidthCountsThePairsOfEveryColumn) {
  // label_adjacency skips blocks of 8 pixels equal to their right and lower neighbours: images of
  // every width from 1 to 27 (blocks, remainders, a pair at any column of a block), mostly
  // uniform with a few single-pixel labels and -1s, give the pairs counted by hand.
  std::mt19937 rng(11);
  for (int cols = 1; cols <= 27; ++cols) {
    cv::Mat labels(9, cols, CV_32S, cv::Scalar(3));
    labels(cv::Rect(0, 5, cols, 4)) = 4;
    for (int k = 0; k < 4; ++k)
      labels.at<int>(static_cast<int>(rng() % 9), static_cast<int>(rng() % static_cast<unsigned>(cols))) =
          static_cast<int>(rng() % 7) - 1;
    EXPECT_EQ(label_adjacency(labels), adjacency_by_hand(labels)) << cols << " columns";
  }
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

/// histogram_chromaticity: the mean colour over the bin centres 31.5 + 64·l (bin 16·l_R + 4·l_G
/// + l_B) divided by its channel sum, computed by hand.
TEST(EnergyTerms, ChromaticityIsTheHistogramsMeanColourOverItsSum) {
  ColourHistogram one{};
  one[16 * 2 + 4 * 1 + 0] = 1.0f;  // levels (2, 1, 0): centres (159.5, 95.5, 31.5)
  EXPECT_TRUE(histogram_chromaticity(one).isApprox(Eigen::Vector3d(159.5, 95.5, 31.5) / 286.5, 1e-12));
  // R = 127.5 lies halfway between the centres of levels 1 and 2: soft binning puts half of it in
  // each, and the mean comes back exactly, whatever the histogram's total mass.
  ColourHistogram split{};
  split[16 * 1 + 4 * 1 + 1] = 1.5f;  // (95.5, 95.5, 95.5)
  split[16 * 2 + 4 * 1 + 1] = 1.5f;  // (159.5, 95.5, 95.5)
  EXPECT_TRUE(histogram_chromaticity(split).isApprox(Eigen::Vector3d(127.5, 95.5, 95.5) / 318.5, 1e-12));
  // Greys of any brightness, and no colour at all, are (1/3, 1/3, 1/3).
  ColourHistogram greys{};
  greys[0] = 0.25f, greys[21] = 0.5f, greys[63] = 0.25f;  // levels (0,0,0), (1,1,1), (3,3,3)
  EXPECT_TRUE(histogram_chromaticity(greys).isApprox(Eigen::Vector3d::Constant(1.0 / 3.0), 1e-12));
  EXPECT_TRUE(histogram_chromaticity(ColourHistogram{}).isApprox(Eigen::Vector3d::Constant(1.0 / 3.0), 1e-12));
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
  bool merged(const Planecell& a, const Planecell& b, const MapConfig& config = {}) {
    GlobalMap map(config);
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

/// A road square whose histogram is half at `first_bin` and half at `second_bin`.
Planecell two_tone(std::uint32_t id, float x, int first_bin, int second_bin) {
  Planecell cell = rect_cell(id, {x, 1.5f, 5}, kX, kZ, first_bin);
  cell.histogram[first_bin] = 0.5f;
  cell.histogram[second_bin] = 0.5f;
  return cell;
}

/// Histograms sharing half their mass on a grey (levels (1, 1, 1), bin 21; intersection 0.5 ≥
/// min_colour_similarity 0.3), the other half reddish on one (levels (2, 1, 0), bin 36) and bluish
/// on the other ((0, 1, 2), bin 6): mean colours (127.5, 95.5, 63.5) and (63.5, 95.5, 127.5),
/// chromaticities 0.315 apart (> max_chromaticity_distance 0.06): two paints, not merged; with the
/// chromaticity test off the histograms alone merge them. A grey half brighter (levels (2, 2, 2))
/// on one and darker ((0, 0, 0)) on the other is one grey paint more and less lit: merged.
TEST_P(PairMerge, OverlappingHistogramsOfAnotherPaintDoNotMerge) {
  EXPECT_FALSE(merged(two_tone(0, 0, 21, 36), two_tone(1, 1, 21, 6)));
  MapConfig off;
  off.max_chromaticity_distance = 0.0;
  EXPECT_TRUE(merged(two_tone(0, 0, 21, 36), two_tone(1, 1, 21, 6), off));
  EXPECT_TRUE(merged(two_tone(0, 0, 21, 42), two_tone(1, 1, 21, 0)));
  MapConfig bad;
  bad.max_chromaticity_distance = -0.1;
  EXPECT_THROW(GlobalMap{bad}, ConfigError);
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

TEST(PlaneMomentsTest, RmsDistanceFromMomentsEqualsDirectSum) {
  // Points at heights 0.1 and −0.3 above y = 0 with weights 1 and 3: RMS = √((0.01 + 3·0.09)/4).
  PlaneMoments m;
  m.add_polygon(std::vector<Eigen::Vector3f>{{0, 0.1f, 0}, {1, 0.1f, 0}}, 2.0);
  m.add_polygon(std::vector<Eigen::Vector3f>{{0, -0.3f, 5}, {2, -0.3f, 1}, {1, -0.3f, 3}}, 6.0);
  Plane3 ground;
  ground.normal = Eigen::Vector3d::UnitY();
  EXPECT_NEAR(m.rms_distance_m(ground), std::sqrt((0.01 + 3 * 0.09) / 4), 1e-6);
}

TEST(LabelStateTest, NoisyCellWeighsLessAndSigmaIsTheHarmonicMean) {
  MapConfig config;
  // A precise (σ = 0.05) and a noisy (σ = 0.5) 1 m² cell: weights 400 and 4.
  Planecell precise = rect_cell(0, {0, 1.5f, 5}, kX, kZ, 3);
  Planecell noisy = rect_cell(1, {1, 1.7f, 5}, kX, kZ, 3);  // 20 cm higher
  precise.depth_sigma_m = 0.05f;
  noisy.depth_sigma_m = 0.5f;
  LabelState label = state_of_cell(precise, 1.0, config.residual_scale_m);
  fold_label(label, state_of_cell(noisy, 1.0, config.residual_scale_m));
  EXPECT_NEAR(label.moments.weight, 400.0 + 4.0, 1e-4);  // σ are floats
  // σ_eff = √(Σ area / Σ area/σ²) = √(2 / 404).
  EXPECT_NEAR(label.sigma_m(), std::sqrt(2.0 / 404.0), 1e-6);
  // Height of the fitted plane above the precise cell's centre (x = 0.5): with equal weights the
  // least-squares plane through the two squares is h ≈ 1.6 + 0.1·(x − 1), i.e. 1.55 there (5 cm
  // off); weighted 100:1 it stays on the precise cell.
  auto height_at_precise_centre = [](const LabelState& s) {
    const Plane3& p = s.plane;  // n·X + e = 0 → y = −(n_x·x + n_z·z + e) / n_y
    return -(p.normal.x() * 0.5 + p.normal.z() * 5.5 + p.offset) / p.normal.y();
  };
  EXPECT_NEAR(height_at_precise_centre(label), 1.5, 0.003);
  noisy.depth_sigma_m = 0.05f;
  LabelState equal = state_of_cell(precise, 1.0, config.residual_scale_m);
  fold_label(equal, state_of_cell(noisy, 1.0, config.residual_scale_m));
  EXPECT_NEAR(height_at_precise_centre(equal), 1.55, 1e-3);  // orthogonal fit: ~vertical regression
}

TEST(IncrementalMerge, NoisyCellJoinsWithinItsNoiseButDoesNotBridgeParallelSurfaces) {
  // Frame 1: a road (y = 1.5) and a sidewalk 25 cm higher, three precise cells each, side by
  // side along x with a 0.5 m gap between them (no image adjacency): two mature surfaces.
  // Seen from 5 m above the road: a cell's noise along its normal is ≥ 0.96 of its σ_Z
  // (map::normal_depth_sigma_m), so the σ below are the planes' own.
  Pose above = Pose::Identity();
  above.translation() = Eigen::Vector3d(1.25, -3.5, 6.5);
  GlobalMap map;
  std::vector<Planecell> frame1;
  for (std::uint32_t k = 0; k < 3; ++k) {
    frame1.push_back(rect_cell(k, {0, 1.5f, 5.0f + k}, kX, kZ, 3));
    frame1.push_back(rect_cell(k + 3, {1.5f, 1.25f, 5.0f + k}, kX, kZ, 3));
  }
  for (auto& cell : frame1) cell.depth_sigma_m = 0.03f;
  const std::vector<LabelEdge> chain = {{0, 1, 20}, {1, 2, 20}, {3, 4, 20}, {4, 5, 20}};
  map.integrate(1, above, frame1, chain);
  ASSERT_EQ(map.surfaces().size(), 2u);
  const std::uint32_t road = map.cells().at(0).surface, sidewalk = map.cells().at(1).surface;
  ASSERT_NE(road, sidewalk);
  // Frame 2: one noisy cell (σ = 0.3 m, within the map's σ_Z gate) halfway between the two
  // heights, spanning the gap and touching both: within its own noise of either plane, so it joins
  // one of them, but the two precise surfaces stay apart (their planes step by 25 cm).
  Planecell bridge = rect_cell(0, {0.5f, 1.375f, 5.5f}, kX, kZ, 3);
  bridge.depth_sigma_m = 0.3f;
  const auto r2 = map.integrate(2, above, std::vector<Planecell>{bridge});
  EXPECT_TRUE(r2.surface_merges.empty());
  EXPECT_EQ(map.surfaces().size(), 2u);
  ASSERT_EQ(r2.cell_surfaces.size(), 1u);
  EXPECT_TRUE(r2.cell_surfaces[0] == road || r2.cell_surfaces[0] == sidewalk);
  // The same cell with a precise plane (σ = 0.03 m) is 12.5 cm off both: a surface of its own.
  bridge.depth_sigma_m = 0.03f;
  const auto r3 = map.integrate(3, above, std::vector<Planecell>{bridge});
  EXPECT_TRUE(r3.surface_merges.empty());
  EXPECT_NE(r3.cell_surfaces[0], road);
  EXPECT_NE(r3.cell_surfaces[0], sidewalk);
}

TEST(IncrementalMerge, CellWithAnUncertainNormalJoinsTheWallItsCentreLiesOn) {
  // Frame 1: a wall z = 10 of six precise 1 m cells (x ∈ [0, 3], y ∈ [0, 2]) facing the camera.
  // Frame 2: one far, noisy cell (σ_Z = 0.35 m; along its normal, seen from the origin,
  // σ_n = σ_Z·|n·r̂| = 0.25 m) beside it (x from 3) whose centre lies on the wall's plane but
  // whose fit turned it 25° about the vertical: its vertices lie ±0.5·sin 25° = ±0.21 m off the
  // plane, within its depth noise, but its normal is outside the angle range
  // 10° + min(atan(0.25 m / 1 m), 10°) = 20°.
  const auto merged_with_wall = [](double normal_sigma_scale, float normal_sigma_rad) {
    MapConfig config;
    config.normal_sigma_scale = normal_sigma_scale;
    GlobalMap map(config);
    std::vector<Planecell> wall;
    for (std::uint32_t k = 0; k < 6; ++k)
      wall.push_back(rect_cell(k, {static_cast<float>(k % 3), static_cast<float>(k / 3), 10.0f}, kX, kY, 3));
    for (auto& cell : wall) cell.depth_sigma_m = 0.03f;
    const std::vector<LabelEdge> chain = {{0, 1, 20}, {1, 2, 20}, {3, 4, 20}, {4, 5, 20}, {0, 3, 20}};
    const std::uint32_t wall_cell = map.integrate(1, Pose::Identity(), wall, chain).added_cells.at(0);
    EXPECT_EQ(map.surfaces().size(), 1u);
    const float turn = 25.0f * 3.14159265f / 180.0f;
    const Eigen::Vector3f across(std::cos(turn), 0.0f, std::sin(turn));
    Planecell turned = rect_cell(0, {3.0f, 0.5f, 10.0f - 0.5f * std::sin(turn)}, across, kY, 3);
    turned.depth_sigma_m = 0.35f;
    turned.normal_sigma_rad = normal_sigma_rad;
    const auto report = map.integrate(2, Pose::Identity(), std::vector<Planecell>{turned});
    return report.cell_surfaces.at(0) == map.cells().at(wall_cell).surface;
  };
  // κ·σ_θ = 8 · 0.0125 = 0.1 rad = 5.7°: the angle range widens to 25.7° ≥ 25°.
  EXPECT_TRUE(merged_with_wall(8.0, 0.0125f));
  // The same cell with a well-determined normal, or with the widening off: a surface of its own.
  EXPECT_FALSE(merged_with_wall(8.0, 0.0f));
  EXPECT_FALSE(merged_with_wall(0.0, 0.0125f));
  // A normal known to 0.008 rad (κσ_θ = 3.7°, range 23.7°) is known too well to be 25° off.
  EXPECT_FALSE(merged_with_wall(8.0, 0.008f));
}

/// The circular greedy as the paper states it: every round evaluates every edge between two
/// labels (the oracle for CrfMerger::merge, which skips edges whose labels did not change).
std::vector<std::pair<std::uint32_t, std::uint32_t>> greedy_evaluating_every_edge(
    const CrfMerger& merger, std::span<const MergeUnit> units, std::span<const MergeEdge> edges,
    std::unordered_map<std::uint32_t, LabelState>& labels, UnionFind& union_find) {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> merges;
  for (int round = 0; round < 64; ++round) {
    std::vector<std::pair<double, std::size_t>> candidates;
    std::set<std::uint32_t> changed;
    for (std::size_t e = 0; e < edges.size(); ++e) {
      const std::uint32_t la = union_find.find(units[edges[e].a].label);
      const std::uint32_t lb = union_find.find(units[edges[e].b].label);
      if (la == lb) continue;
      const auto ev = merger.evaluate(units[edges[e].a], labels.at(la), units[edges[e].b], labels.at(lb),
                                      edges[e].boundary_m);
      if (ev.in_range) candidates.emplace_back(ev.gain, e);
    }
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const auto& x, const auto& y) { return x.first > y.first; });
    bool merged_any = false;
    for (const auto& [gain, e] : candidates) {
      const std::uint32_t la = union_find.find(units[edges[e].a].label);
      const std::uint32_t lb = union_find.find(units[edges[e].b].label);
      if (la == lb) continue;
      if ((changed.contains(la) || changed.contains(lb)) &&
          !merger.evaluate(units[edges[e].a], labels.at(la), units[edges[e].b], labels.at(lb), edges[e].boundary_m)
               .in_range)
        continue;
      const std::uint32_t root = union_find.unite(la, lb);
      const std::uint32_t absorbed = root == la ? lb : la;
      changed.insert(root);
      fold_label(labels.at(root), labels.at(absorbed));
      labels.erase(absorbed);
      merges.emplace_back(absorbed, root);
      merged_any = true;
    }
    if (!merged_any) break;
  }
  return merges;
}

TEST(CircularGreedy, MergesExactlyAsEvaluatingEveryEdgeEveryRound) {
  // A 14 × 14 grid of 0.5 m cells over a road, a sidewalk 12 cm higher and a ramp tilted 6°,
  // each cell with a random tilt (±2°), height noise, depth σ (2–30 cm) and one of two colours;
  // edges between 4-neighbours. Several rounds merge on every seed.
  const CrfMerger merger(MapConfig{});
  for (unsigned seed = 1; seed <= 6; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    constexpr int kN = 14;
    std::vector<Planecell> cells;
    for (int i = 0; i < kN; ++i)
      for (int j = 0; j < kN; ++j) {
        const float x = 0.5f * i, z = 5.0f + 0.5f * j;
        float y = 1.5f;
        if (i >= 9) y -= 0.12f;                         // sidewalk
        if (j >= 9) y -= 0.105f * 0.5f * (j - 9);       // ramp (6°)
        y += 0.01f * unit(rng);
        const float slope = j >= 9 ? -0.105f : 0.0f;
        const Eigen::Vector3f e1(0.5f, 0.5f * 0.035f * unit(rng), 0.0f);
        const Eigen::Vector3f e2(0.0f, 0.5f * (slope + 0.035f * unit(rng)), 0.5f);
        Planecell c = rect_cell(static_cast<std::uint32_t>(cells.size()), {x, y, z}, e1, e2,
                                unit(rng) > 0.6f ? 7 : 3);
        c.depth_sigma_m = 0.02f + 0.14f * (1.0f + unit(rng));
        cells.push_back(c);
      }
    std::vector<MergeUnit> units;
    std::unordered_map<std::uint32_t, LabelState> labels;
    for (std::size_t k = 0; k < cells.size(); ++k) {
      const double area = polygon_area_m2(cells[k].vertices_m);
      units.push_back({static_cast<std::uint32_t>(k), cells[k].plane, cells[k].vertices_m,
                       &cells[k].histogram, area});
      labels.emplace(static_cast<std::uint32_t>(k), state_of_cell(cells[k], area, 0.05));
    }
    std::vector<MergeEdge> edges;
    for (int i = 0; i < kN; ++i)
      for (int j = 0; j < kN; ++j) {
        const auto k = static_cast<std::uint32_t>(i * kN + j);
        if (i + 1 < kN) edges.push_back({k, k + kN, 0.5});
        if (j + 1 < kN) edges.push_back({k, k + 1, 0.5});
      }
    auto labels_ref = labels;
    UnionFind uf, uf_ref;
    const auto merges = merger.merge(units, edges, labels, uf);
    const auto expected = greedy_evaluating_every_edge(merger, units, edges, labels_ref, uf_ref);
    ASSERT_GT(expected.size(), 50u) << "seed " << seed;
    EXPECT_EQ(merges, expected) << "seed " << seed;
    std::set<std::uint32_t> roots;
    for (std::uint32_t k = 0; k < cells.size(); ++k) roots.insert(uf.find(k));
    EXPECT_GT(roots.size(), 2u) << "seed " << seed << ": the sidewalk step and colours keep labels apart";
  }
}

}  // namespace
}  // namespace planecell::map
