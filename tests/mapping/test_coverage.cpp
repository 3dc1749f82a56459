/// Re-observation by coverage (map/coverage, MapConfig::redundant_*): covered shares of hand-made
/// squares, the coplanarity gate, and the map neither storing space it already holds nor keeping a
/// far, noisy cell once a near, precise one covers it.
#include <gtest/gtest.h>

#include <string>

#include "core/error.hpp"
#include "mapping/map/coverage.hpp"
#include "mapping/map/crf_merger.hpp"
#include "mapping/map/global_map.hpp"
#include "support/expect_error.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::map {
namespace {

using test::rect_cell;

using test::kX;
using test::kZ;

/// Colour bins (q = 16·l_R + 4·l_G + l_B) of one grey paint at three brightnesses: histograms
/// that do not intersect (the CRF keeps them apart) but of one chromaticity (a surface's footprint
/// may cover a cell of another with covered_elsewhere_min_colour off), and rect_cell's mean
/// colours 84 levels apart.
constexpr int kDarkGrey = 0, kGrey = 21, kBrightGrey = 42;

/// The map's defaults but for MapConfig::covered_elsewhere_min_colour (off). The tests that keep a
/// re-observation out of a surface's CRF label by a colour whose histogram does not intersect the
/// surface's (one-hot bins) test the coverage's geometry with it; the colour test of a covering
/// surface has its own (AFootprintCoversACellTheCrfLabelledOtherwiseOnlyInItsColours).
MapConfig any_colour_covered() {
  MapConfig config;
  config.covered_elsewhere_min_colour = 0.0;
  return config;
}

/// A 1 m road square at x ∈ [x0, x0 + w], z ∈ [5, 6] on the plane y = 1.5.
Planecell road(std::uint32_t id, float x0, float w = 1.0f, int colour_bin = kGrey) {
  return rect_cell(id, {x0, 1.5f, 5}, w * kX, kZ, colour_bin);
}

/// The map's record of a hand-made cell.
MapCell stored(const Planecell& cell) { return map_cell_of(cell, cell.id, 0, 0); }

/// Frames 0 and 1 (seen from `pose`): a road square, then a re-observation fused into it that
/// stretches its footprint; frame 2: `cell`, expected stored on a surface of its own (`stored`) or
/// fused into the road's surface without being stored.
void expect_stored_or_fused_into_road(GlobalMap& map, const Pose& pose, const Planecell& road_square,
                                      const Planecell& stretching, const Planecell& cell, bool stored) {
  (void)map.integrate(0, pose, std::vector{road_square});
  ASSERT_EQ(map.cells().size(), 1u);
  const std::uint32_t road_surface = map.cells().at(0).surface;
  ASSERT_EQ(map.integrate(1, pose, std::vector{stretching}).fused_cells, 1u);
  const auto r = map.integrate(2, pose, std::vector{cell});
  ASSERT_EQ(r.cell_surfaces.size(), 1u);
  if (stored) {
    EXPECT_EQ(r.redundant_cells, 0u);
    EXPECT_EQ(r.added_cells.size(), 1u);
    EXPECT_NE(r.cell_surfaces[0], road_surface);
    EXPECT_EQ(r.cell_fates[0], CellFate::kNewSurface);
    EXPECT_EQ(map.cells().size(), 2u);
  } else {
    EXPECT_EQ(r.redundant_cells, 1u);
    EXPECT_TRUE(r.added_cells.empty());
    EXPECT_EQ(r.cell_surfaces[0], road_surface);
    EXPECT_EQ(r.cell_fates[0], CellFate::kCoveredElsewhere);  // the CRF kept it apart
    EXPECT_EQ(map.cells().size(), 1u);
  }
}

TEST(Coverage, SharesOfASquareCoveredByHandPlacedSquares) {
  const Planecell cell = road(0, 0);
  const MapCell left = stored(road(1, 0, 0.5f)), right = stored(road(2, 0.5f, 0.5f)),
                far = stored(road(3, 3));
  const int samples = 400;  // a 20 × 20 grid over the cell
  EXPECT_NEAR(covered_fraction(cell, std::vector{&left}, samples), 0.5, 0.03);
  EXPECT_NEAR(covered_fraction(cell, std::vector{&left, &right}, samples), 1.0, 1e-9);
  EXPECT_EQ(covered_fraction(cell, std::vector{&far}, samples), 0.0);
  EXPECT_EQ(covered_fraction(cell, std::vector<const MapCell*>{}, samples), 0.0);
  // A covering square 0.2 m above the cell's plane projects onto the same area.
  const MapCell lifted = stored(rect_cell(4, {0, 1.3f, 5}, kX, kZ, 3));
  EXPECT_NEAR(covered_fraction(cell, std::vector{&lifted}, samples), 1.0, 1e-9);
}

/// With a minimum share, the estimate stops as soon as the share cannot reach it: fewer points are
/// tested and the answer is below the minimum; a share that reaches it is exact.
TEST(Coverage, StopsOnceTheShareCannotReachTheMinimum) {
  const Planecell cell = road(0, 0);
  const MapCell left = stored(road(1, 0, 0.5f)), right = stored(road(2, 0.5f, 0.5f));
  const int samples = 400;
  const double half = covered_fraction(cell, std::vector{&left}, samples);
  EXPECT_NEAR(half, 0.5, 0.03);
  EXPECT_EQ(covered_fraction(cell, std::vector{&left}, samples, 0.4), half);  // reached: exact
  const double stopped = covered_fraction(cell, std::vector{&left}, samples, 0.75);
  EXPECT_LT(stopped, 0.75);
  EXPECT_GE(stopped, half);  // the share still reachable when it stopped
  EXPECT_EQ(covered_fraction(cell, std::vector{&left, &right}, samples, 0.75), 1.0);
  // Points in the cell's own basis: covered on one side of its centroid (about half of them).
  int tested = 0;
  const CoverageTest one_side = [&](const Eigen::Vector2d& st, const PlaneBasis&) {
    ++tested;
    return st.x() < 0.0;
  };
  const double full = covered_fraction(cell.plane, cell.vertices_m, one_side, samples);
  const int all_points = tested;
  EXPECT_NEAR(full, 0.5, 0.03);
  tested = 0;
  EXPECT_LT(covered_fraction(cell.plane, cell.vertices_m, one_side, samples, 0.75), 0.75);
  EXPECT_LT(tested, all_points);
  EXPECT_GE(tested, all_points / 4);  // at least a quarter of the points missed first
}

TEST(Coverage, NearlyCoplanarGatesAngleAndRmsDistance) {
  const Planecell cell = road(0, 0);
  EXPECT_TRUE(nearly_coplanar(cell, stored(road(1, 0.5f)), 10.0, 0.1));
  // 0.2 m above: RMS vertex distance 0.2 m.
  const MapCell lifted = stored(rect_cell(2, {0, 1.3f, 5}, kX, kZ, 3));
  EXPECT_FALSE(nearly_coplanar(cell, lifted, 10.0, 0.19));
  EXPECT_TRUE(nearly_coplanar(cell, lifted, 10.0, 0.21));
  // Tilted by 30° about the x axis through its near edge: rejected at 20°, accepted at 35° when
  // the vertices are close enough (RMS of 0, 0, 0.5, 0.5 = 0.354 m).
  const Eigen::Vector3f tilted_edge(0, -std::sin(0.5236f), std::cos(0.5236f));
  const MapCell tilted = stored(rect_cell(3, {0, 1.5f, 5}, kX, tilted_edge, 3));
  EXPECT_FALSE(nearly_coplanar(cell, tilted, 20.0, 1.0));
  EXPECT_TRUE(nearly_coplanar(cell, tilted, 35.0, 0.36));
  EXPECT_FALSE(nearly_coplanar(cell, tilted, 35.0, 0.35));
}

/// Colours far apart keep the CRF from merging the re-observation into the first surface, so
/// only the coverage rule can recognise it.
TEST(Coverage, MapDoesNotStoreSpaceItAlreadyHoldsWhateverTheLabel) {
  for (const bool rule_on : {true, false}) {
    SCOPED_TRACE(rule_on ? "coverage rule on" : "coverage rule off");
    MapConfig config = any_colour_covered();
    if (!rule_on) config.redundant_coverage = 2.0;
    GlobalMap map(config);
    (void)map.integrate(0, Pose::Identity(), std::vector{road(0, 0), road(1, 1)});
    ASSERT_EQ(map.cells().size(), 2u);
    // The same two squares again, seen with another colour (lighting), plus new road beyond.
    const auto r = map.integrate(1, Pose::Identity(),
                                 std::vector{road(0, 0, 1.0f, kBrightGrey), road(1, 1, 1.0f, kBrightGrey), road(2, 2)});
    if (rule_on) {
      EXPECT_EQ(r.redundant_cells, 2u);
      EXPECT_EQ(r.fused_cells, 2u);
      ASSERT_EQ(r.added_cells.size(), 1u);
      EXPECT_EQ(map.cells().size(), 3u);
      // The fused cells are reported on the surface of the cells that hold their space.
      EXPECT_EQ(r.cell_surfaces[0], map.cells().at(0).surface);
      EXPECT_EQ(r.cell_surfaces[1], map.cells().at(1).surface);
    } else {
      EXPECT_EQ(r.redundant_cells, 0u);
      EXPECT_EQ(map.cells().size(), 5u);
    }
  }
}

/// A re-observation spanning two surfaces is fused into the one covering most of it.
TEST(Coverage, ReobservationGoesToTheSurfaceCoveringMostOfIt) {
  GlobalMap map(any_colour_covered());
  // Two road patches the CRF keeps apart (colours far apart): A at x ∈ [0, 0.6], B at x ∈ [0.6, 1.6].
  (void)map.integrate(0, Pose::Identity(), std::vector{road(0, 0, 0.6f, kGrey), road(1, 0.6f, 1.0f, kDarkGrey)});
  ASSERT_EQ(map.cells().size(), 2u);
  const std::uint32_t a = map.cells().at(0).surface, b = map.cells().at(1).surface;
  ASSERT_NE(a, b);
  // A third colour (no CRF merge with either), fully covered: x ∈ [0, 1] lies 60 % on A.
  const auto on_a = map.integrate(1, Pose::Identity(), std::vector{road(0, 0, 1.0f, kBrightGrey)});
  ASSERT_EQ(on_a.redundant_cells, 1u);
  EXPECT_EQ(on_a.cell_surfaces[0], a);
  EXPECT_EQ(on_a.cell_fates[0], CellFate::kCoveredElsewhere);  // the CRF gave it a label of its own
  // x ∈ [0.3, 1.3] lies 70 % on B.
  const auto on_b = map.integrate(2, Pose::Identity(), std::vector{road(0, 0.3f, 1.0f, kBrightGrey)});
  ASSERT_EQ(on_b.redundant_cells, 1u);
  EXPECT_EQ(on_b.cell_surfaces[0], b);
  EXPECT_EQ(map.cells().size(), 2u);
  EXPECT_EQ(map.surfaces().at(a).observations, 2u);
  EXPECT_EQ(map.surfaces().at(b).observations, 2u);
}

/// A re-observation in its own surface's label that adds more than fuse_new_area_fraction to that
/// surface's footprint, but whose rest lies on a coplanar neighbour of another colour, is fused
/// into its own surface by coverage.
TEST(Coverage, AReobservationCoveredPartlyByAnotherSurfaceIsFusedIntoItsOwn) {
  GlobalMap map(any_colour_covered());
  // A at x ∈ [0, 1] and B at x ∈ [1, 2], colours far apart: two surfaces.
  (void)map.integrate(0, Pose::Identity(), std::vector{road(0, 0, 1.0f, kGrey), road(1, 1.0f, 1.0f, kDarkGrey)});
  ASSERT_EQ(map.cells().size(), 2u);
  const std::uint32_t a = map.cells().at(0).surface;
  ASSERT_NE(a, map.cells().at(1).surface);
  // x ∈ [0.5, 1.5] in A's colour: the CRF gives it A's label; half of it is new to A's footprint
  // (≥ 0.25), but A and B together cover all of it.
  const auto r = map.integrate(1, Pose::Identity(), std::vector{road(0, 0.5f, 1.0f, kGrey)});
  EXPECT_EQ(r.redundant_cells, 1u);
  EXPECT_TRUE(r.added_cells.empty());
  EXPECT_EQ(r.cell_surfaces[0], a);
  EXPECT_EQ(r.cell_fates[0], CellFate::kFusedByCoverage);
  EXPECT_EQ(map.cells().size(), 2u);
}

/// Space the map holds only through a fused (unstored) observation still counts: coverage reads
/// the surfaces' footprints, not just the stored polygons.
TEST(Coverage, SpaceHeldOnlyByAFusedObservationIsNotStoredAgain) {
  GlobalMap map(any_colour_covered());
  (void)map.integrate(0, Pose::Identity(), std::vector{road(0, 0)});  // x ∈ [0, 1], stored
  ASSERT_EQ(map.cells().size(), 1u);
  const std::uint32_t surface = map.cells().at(0).surface;
  // x ∈ [0.2, 1.2]: same surface, adds 0.2 m² (< fuse_new_area_fraction): fused, not stored, but
  // its area enters the footprint (x ∈ [0, 1.2]).
  const auto fused = map.integrate(1, Pose::Identity(), std::vector{road(0, 0.2f)});
  ASSERT_EQ(fused.fused_cells, 1u);
  ASSERT_TRUE(fused.added_cells.empty());
  // x ∈ [0.35, 1.35] in another colour (no CRF merge): the stored polygon covers 65 % of it (below
  // redundant_coverage 0.75), the footprint 85 %: a re-observation, fused into that surface.
  const auto again = map.integrate(2, Pose::Identity(), std::vector{road(0, 0.35f, 1.0f, kBrightGrey)});
  EXPECT_EQ(again.redundant_cells, 1u);
  EXPECT_TRUE(again.added_cells.empty());
  EXPECT_EQ(again.cell_surfaces[0], surface);
  EXPECT_EQ(map.cells().size(), 1u);
  EXPECT_EQ(map.surfaces().size(), 1u);
  // Shifted on to x ∈ [0.6, 1.6], only 60 % lies in the footprint: new space, stored.
  const auto beyond = map.integrate(3, Pose::Identity(), std::vector{road(0, 0.6f, 1.0f, kBrightGrey)});
  EXPECT_EQ(beyond.redundant_cells, 0u);
  EXPECT_EQ(beyond.added_cells.size(), 1u);
}

/// A kerb seen from afar at a grazing angle (MapConfig::coverage_normal_noise): a road square on
/// y = 1.65 (1.65 m below the camera) at x ∈ [0, 1], z ∈ [10, 11], its footprint stretched to
/// x = 1.2 by a fused re-observation; then a 1 m sidewalk cell 15 cm above it (y = 1.5) at
/// x ∈ [0.35, 1.35], another colour (no CRF merge), σ_Z = 0.3 m. The road's footprint holds 85 % of
/// it (the stored square 65 %, below redundant_coverage). Its noise along its normal is
/// σ_n = σ_Z · 1.5 / |X̄| = 0.3 · 1.5 / |(0.85, 1.5, 10.5)| ≈ 4.2 cm, so the surface must pass
/// within 2σ_n ≈ 8.5 cm: the 15 cm step keeps it out and it is stored. Counted by σ_Z (2σ_Z = 0.6 m)
/// the road covers it and it is fused into the road.
TEST(Coverage, AFarKerbCellIsCoveredWithinItsNoiseAlongTheNormal) {
  for (const bool normal_noise : {true, false}) {
    SCOPED_TRACE(normal_noise ? "sigma along the normal" : "sigma_Z");
    MapConfig config = any_colour_covered();
    config.coverage_normal_noise = normal_noise;
    GlobalMap map(config);
    const auto road_at = [](float x0) { return rect_cell(0, {x0, 1.65f, 10}, kX, kZ, kGrey); };
    Planecell kerb = rect_cell(0, {0.35f, 1.5f, 10}, kX, kZ, kBrightGrey);
    kerb.depth_sigma_m = 0.3f;
    const Eigen::Vector3d centroid(0.85, 1.5, 10.5);
    ASSERT_NEAR(normal_depth_sigma_m(kerb, Eigen::Vector3d::Zero()), 0.3 * 1.5 / centroid.norm(), 1e-6);
    expect_stored_or_fused_into_road(map, Pose::Identity(), road_at(0), road_at(0.2f), kerb, normal_noise);
  }
}

/// A surface's footprint covers a cell within the cell's noise along its normal only up to the
/// neighbour gap (neighbour_gap_m, 0.3 m): the setting above seen from straight above (σ_n ≈ σ_Z),
/// the road square on y = 1.5 at x ∈ [0, 1], z ∈ [5, 6] and its footprint stretched to x = 1.2;
/// then a cell of another colour 0.35 m above it (y = 1.15) at x ∈ [0.35, 1.35] with σ_Z = 0.3 m,
/// 2σ_n ≈ 0.6 m. The stored square covers 65 % of it (below redundant_coverage), the footprint
/// 85 % were its plane allowed 0.6 m off: capped at the gap, the 0.35 m keep it out and it is
/// stored. With the gap at 0.4 m the footprint covers it and it is fused into the road.
TEST(Coverage, AFootprintCoversANoisyCellOnlyWithinTheNeighbourGap) {
  for (const double gap_m : {0.3, 0.4}) {
    SCOPED_TRACE("neighbour gap " + std::to_string(gap_m) + " m");
    MapConfig config = any_colour_covered();
    config.neighbour_gap_m = gap_m;
    GlobalMap map(config);
    Pose above = Pose::Identity();
    above.translation() = Eigen::Vector3d(0.85, -3.5, 5.5);
    Planecell lifted = rect_cell(0, {0.35f, 1.15f, 5}, kX, kZ, kBrightGrey);
    lifted.depth_sigma_m = 0.3f;
    ASSERT_GT(2.0 * normal_depth_sigma_m(lifted, above.translation()), 0.55);
    expect_stored_or_fused_into_road(map, above, road(0, 0), road(0, 0.2f), lifted, gap_m < 0.35);
  }
}

TEST(Coverage, NearPreciseCellsReplaceAFarNoisyCellTheyCover) {
  MapConfig config;
  GlobalMap map(config);
  // Seen from 5 m straight above the squares (y = 1.5), their noise along the normal is nearly
  // all of σ_Z (map::normal_depth_sigma_m: ≥ 0.95 σ_Z here), so the σ below are the planes' own.
  Pose above = Pose::Identity();
  above.translation() = Eigen::Vector3d(1.0, -3.5, 5.5);
  // Frame 0: seen from far, σ_Z = 0.3 m: a 2 m square and its 1 m neighbour (one surface).
  Planecell far_big = road(0, 0, 2.0f), far_next = road(1, 2);
  far_big.depth_sigma_m = far_next.depth_sigma_m = 0.3f;
  (void)map.integrate(0, above, std::vector{far_big, far_next});
  ASSERT_EQ(map.cells().size(), 2u);
  ASSERT_EQ(map.surfaces().size(), 1u);
  const std::uint32_t big_id = 0;
  ASSERT_NEAR(polygon_area_m2(map.cells().at(big_id).vertices_m), 2.0, 1e-6);
  // Frame 1: seen from near, σ_Z = 0.02 m: two 1 m squares covering the 2 m one.
  Planecell near_a = road(0, 0), near_b = road(1, 1);
  near_a.depth_sigma_m = near_b.depth_sigma_m = 0.02f;
  const auto r = map.integrate(1, above, std::vector{near_a, near_b});
  EXPECT_EQ(r.prefused_cells, 0u);  // a surface known only from 15× noisier views: not found first
  EXPECT_EQ(r.added_cells.size(), 2u);
  EXPECT_EQ(r.replaced_cells, 1u);
  EXPECT_EQ(r.removed_cells, std::vector<std::uint32_t>{big_id});
  EXPECT_FALSE(map.cells().contains(big_id));
  EXPECT_EQ(map.cells().size(), 3u);
  // Frame 2: the same near squares once more add nothing (covered by equally precise cells).
  const auto again = map.integrate(2, above, std::vector{near_a, near_b});
  EXPECT_EQ(again.prefused_cells, 2u);  // now the surface holds views as precise as these
  EXPECT_TRUE(again.added_cells.empty());
  EXPECT_TRUE(again.removed_cells.empty());
  EXPECT_EQ(map.cells().size(), 3u);
}

/// MapConfig::prefuse_reobservations: a new cell inside its surface's footprint, in the CRF's range
/// of it, is found as a re-observation before the neighbour search and fused as the regular path
/// fuses it; one adding more than fuse_new_area_fraction of new space, or out of the CRF's range
/// (another colour), takes the regular path.
TEST(Coverage, AReobservationIsFoundBeforeTheNeighbourSearch) {
  for (const bool first : {true, false}) {
    SCOPED_TRACE(first ? "found first" : "regular path");
    MapConfig config = any_colour_covered();
    config.prefuse_reobservations = first;
    GlobalMap map(config);
    // x ∈ [0, 1], stored.
    EXPECT_EQ(map.integrate(0, Pose::Identity(), std::vector{road(0, 0)}).cell_fates[0], CellFate::kNewSurface);
    const std::uint32_t surface = map.cells().at(0).surface;
    // x ∈ [0.2, 1.2]: 0.2 m² new (< 0.25 of its area), same colour.
    const auto inside = map.integrate(1, Pose::Identity(), std::vector{road(0, 0.2f)});
    EXPECT_EQ(inside.prefused_cells, first ? 1u : 0u);
    EXPECT_EQ(inside.cell_fates[0], first ? CellFate::kFusedFoundFirst : CellFate::kFusedByFootprint);
    EXPECT_EQ(inside.fused_cells, 1u);
    EXPECT_TRUE(inside.added_cells.empty());
    EXPECT_EQ(inside.cell_surfaces[0], surface);
    EXPECT_NEAR(map.surfaces().at(surface).area_m2, 1.2, 0.05);  // its area entered the footprint
    // x ∈ [0.35, 1.35] in another colour: out of the CRF's range, fused by coverage either way.
    const auto other_colour =
        map.integrate(2, Pose::Identity(), std::vector{road(0, 0.35f, 1.0f, kBrightGrey)});
    EXPECT_EQ(other_colour.prefused_cells, 0u);
    EXPECT_EQ(other_colour.redundant_cells, 1u);
    EXPECT_EQ(other_colour.cell_surfaces[0], surface);
    EXPECT_EQ(other_colour.cell_fates[0], CellFate::kCoveredElsewhere);
    // x ∈ [0.7, 1.7]: half of it new space, stored; the CRF still gives it the surface's label.
    const auto beyond = map.integrate(3, Pose::Identity(), std::vector{road(0, 0.7f)});
    EXPECT_EQ(beyond.prefused_cells, 0u);
    EXPECT_EQ(beyond.cell_fates[0], CellFate::kStored);
    EXPECT_EQ(beyond.added_cells.size(), 1u);
    EXPECT_EQ(beyond.cell_surfaces[0], surface);
    EXPECT_EQ(map.cells().size(), 2u);
    EXPECT_EQ(map.surfaces().size(), 1u);
  }
}

/// A surface's footprint covers a cell only when their chromaticities are near
/// (MapConfig::max_chromaticity_distance): inside the grey road's footprint stretched to x = 1.2
/// (the stored square covering 65 %, the footprint 85 % of it), a cell at x ∈ [0.35, 1.35] of
/// the same grey brighter lit is fused into the road; one of a reddish paint (levels (2, 1, 0),
/// chromaticity 0.32 from grey) is stored on a surface of its own, unless the test is off.
TEST(Coverage, AFootprintCoversOnlyACellOfItsOwnPaint) {
  constexpr int kReddish = 16 * 2 + 4 * 1 + 0;
  for (const double max_chromaticity : {0.06, 0.0}) {
    for (const int bin : {kBrightGrey, kReddish}) {
      SCOPED_TRACE("max chromaticity distance " + std::to_string(max_chromaticity) + ", bin " + std::to_string(bin));
      MapConfig config = any_colour_covered();
      config.max_chromaticity_distance = max_chromaticity;
      GlobalMap map(config);
      expect_stored_or_fused_into_road(map, Pose::Identity(), road(0, 0), road(0, 0.2f), road(0, 0.35f, 1.0f, bin),
                                       bin == kReddish && max_chromaticity > 0.0);
    }
  }
}

/// MapConfig::covered_elsewhere_min_colour: inside the grey road's footprint stretched to x = 1.2
/// (as above), a cell at x ∈ [0.35, 1.35] of the same grey partly lit brighter — its histogram a
/// share s on the grey bin and 1 − s on the bright grey's, its mean colour 84 levels off, so that
/// no stored cell is its neighbour for the CRF (neighbour_max_rgb_distance) and the CRF gives it a
/// label of its own — is fused into the road when its histogram intersects the road's by
/// s = 0.75 ≥ 0.7, and stored on a surface of its own at s = 0.5, unless the test is off.
TEST(Coverage, AFootprintCoversACellTheCrfLabelledOtherwiseOnlyInItsColours) {
  ASSERT_EQ(MapConfig{}.covered_elsewhere_min_colour, 0.7);
  for (const double min_colour : {0.7, 0.0}) {
    for (const float share : {0.75f, 0.5f}) {
      SCOPED_TRACE("min colour " + std::to_string(min_colour) + ", grey share " + std::to_string(share));
      MapConfig config;
      config.covered_elsewhere_min_colour = min_colour;
      GlobalMap map(config);
      Planecell lit = road(0, 0.35f, 1.0f, kBrightGrey);
      lit.histogram[kGrey] = share;
      lit.histogram[kBrightGrey] = 1.0f - share;
      ASSERT_NEAR(colour_similarity(lit.histogram, road(0, 0).histogram), share, 1e-6);
      expect_stored_or_fused_into_road(map, Pose::Identity(), road(0, 0), road(0, 0.2f), lit,
                                       min_colour > 0.0 && share < min_colour);
    }
  }
  MapConfig bad;
  bad.covered_elsewhere_min_colour = 1.5;
  EXPECT_CONTAINS(test::error_of<ConfigError>([&] { GlobalMap{bad}; }), "map.covered_elsewhere_min_colour");
}

/// A new cell meets a stored cell only when their mean colours are near
/// (MapConfig::neighbour_max_rgb_distance): a cell half over a stored one, with the same histogram
/// (the CRF's colour term passes) but a mean colour 40 levels redder, keeps a surface of its own;
/// 15 levels off, or with the gate off, the CRF gives it the stored cell's label.
TEST(Coverage, ANeighbourOfAnotherMeanColourKeepsItsOwnSurface) {
  for (const double max_rgb : {20.0, 0.0}) {
    for (const float redder : {40.0f, 15.0f}) {
      SCOPED_TRACE("max RGB distance " + std::to_string(max_rgb) + ", " + std::to_string(redder) + " levels redder");
      MapConfig config;
      config.neighbour_max_rgb_distance = max_rgb;
      GlobalMap map(config);
      (void)map.integrate(0, Pose::Identity(), std::vector{road(0, 0)});  // x ∈ [0, 1]
      const std::uint32_t surface = map.cells().at(0).surface;
      Planecell other = road(0, 0.5f);  // x ∈ [0.5, 1.5]: half of it new space, stored
      other.mean_rgb.x() += redder;
      const auto r = map.integrate(1, Pose::Identity(), std::vector{other});
      ASSERT_EQ(r.added_cells.size(), 1u);
      if (max_rgb > 0.0 && redder > max_rgb)
        EXPECT_NE(r.cell_surfaces[0], surface);
      else
        EXPECT_EQ(r.cell_surfaces[0], surface);
    }
  }
  MapConfig bad;
  bad.neighbour_max_rgb_distance = -1.0;
  EXPECT_THROW(GlobalMap{bad}, ConfigError);
}

}  // namespace
}  // namespace planecell::map
