/// Merge metrics against ground-truth surfaces: hand-built label images, GT ids and merge reports
/// whose dominant labels, cross-merged cells and followed surface merges are counted by hand.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <tuple>

#include "core/error.hpp"
#include "services/eval/merge_metrics.hpp"

namespace planecell::services::eval {
namespace {

/// A flat square cell of side `side_m` (area side²) with extraction id `id`.
Planecell square(std::uint32_t id, float side_m) {
  Planecell c;
  c.id = id;
  c.has_plane = true;
  c.vertices_m = {{0, 0, 0}, {side_m, 0, 0}, {side_m, side_m, 0}, {0, side_m, 0}};
  return c;
}

/// 4×4 labels: columns 0–1 cell `left`, columns 2–3 cell `right`; GT ids likewise.
void halves(cv::Mat& labels, cv::Mat& gt, int left, int right, std::uint16_t gt_left, std::uint16_t gt_right) {
  labels = cv::Mat(4, 4, CV_32S);
  gt = cv::Mat(4, 4, CV_16U);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) {
      labels.at<std::int32_t>(r, c) = c < 2 ? left : right;
      gt.at<std::uint16_t>(r, c) = c < 2 ? gt_left : gt_right;
    }
}

/// A unit square cell (extraction id `id`) lifted to z = z_m, with depth noise σ_Z = sigma_m.
Planecell lifted_square(std::uint32_t id, float z_m, float sigma_m) {
  Planecell c = square(id, 1.0f);
  for (auto& v : c.vertices_m) v.z() = z_m;
  c.depth_sigma_m = sigma_m;
  return c;
}

/// One frame of two unit squares on GT 1 and GT 2 in labels 10 and 20, evaluated without any
/// scene ground truth (kinds, textures, planes).
MergeMetrics plain_evaluation() {
  MergeEvaluator plain;
  cv::Mat labels, gt;
  halves(labels, gt, 0, 1, 1, 2);
  map::MergeReport report;
  report.cell_surfaces = {10, 20};
  plain.add_frame(labels, gt, std::vector<Planecell>{square(0, 1.0f), square(1, 1.0f)}, report);
  return plain.finish();
}

/// A 1 m × 1 m rectangle of the plane z = z0 (normal +z), x ∈ [x0, x0 + 1], y ∈ [0, 1].
io::SyntheticSurface tile_at(std::uint16_t id, double x0, double z0) {
  return io::make_rectangle(id, io::SurfaceKind::kBox, {x0, 0.0, z0}, Eigen::Vector3d::UnitX(),
                            Eigen::Vector3d::UnitY(), 1.0, 1.0, {});
}

TEST(MergeMetrics, CoplanarTouchingGtSurfacesFormOnePlaneGroup) {
  // 1 and 2 share an edge on z = 0; 3 is on z = 0 too but 4 m away; 4 lies 10 cm above 1;
  // 5 touches 2 on z = 0.01 (within 2 cm: the same plane), so it joins 1 and 2 transitively.
  const std::vector<io::SyntheticSurface> surfaces = {tile_at(1, 0.0, 0.0), tile_at(2, 1.0, 0.0),
                                                      tile_at(3, 6.0, 0.0), tile_at(4, 0.0, 0.1),
                                                      tile_at(5, 2.0, 0.01)};
  const auto groups = coplanar_groups(surfaces);
  EXPECT_EQ(groups.at(1), 1);
  EXPECT_EQ(groups.at(2), 1);
  EXPECT_EQ(groups.at(5), 1);
  EXPECT_EQ(groups.at(3), 3);
  EXPECT_EQ(groups.at(4), 4);
  // A normal 2° off is another plane.
  io::SyntheticSurface tilted = io::make_rectangle(
      6, io::SurfaceKind::kBox, {1.0, 0.0, 0.0}, Eigen::Vector3d(std::cos(0.035), 0.0, std::sin(0.035)),
      Eigen::Vector3d::UnitY(), 1.0, 1.0, {});
  const std::vector<io::SyntheticSurface> two = {tile_at(1, 0.0, 0.0), tilted};
  EXPECT_NE(coplanar_groups(two).at(6), coplanar_groups(two).at(1));
}

TEST(MergeMetrics, MergingCoplanarGtSurfacesIsNotCrossMergingBetweenPlanes) {
  MergeEvaluator eval;
  eval.set_gt_planes({{1, 1}, {2, 1}});  // GT 1 and 2: one plane; GT 3: its own
  cv::Mat labels, gt;
  halves(labels, gt, 0, 1, 1, 2);
  map::MergeReport report;
  report.cell_surfaces = {10, 10};
  eval.add_frame(labels, gt, std::vector<Planecell>{square(0, std::sqrt(2.0f)), square(1, 1.0f)}, report);
  halves(labels, gt, 2, 3, 1, 3);
  report.cell_surfaces = {10, 10};  // a cell of GT 3 (another plane) joins the same label
  eval.add_frame(labels, gt, std::vector<Planecell>{square(2, std::sqrt(2.0f)), square(3, 1.0f)}, report);
  const MergeMetrics m = eval.finish();
  ASSERT_EQ(m.cells, 4u);
  // Label 10: GT 1 4 m², GT 2 1 m², GT 3 1 m² → GT 1 dominates. Per surface, the cells of GT 2 and
  // GT 3 are cross-merged (2 of 4); per plane only the cell of GT 3 (1 of 4).
  EXPECT_NEAR(m.cross_merged_cells, 0.5, 1e-9);
  EXPECT_NEAR(m.cross_merged_cells_between_planes, 0.25, 1e-9);
}

/// `cell` lifted by z_m, with depth noise sigma_m.
Planecell lifted(Planecell cell, float z_m, float sigma_m) {
  for (auto& v : cell.vertices_m) v.z() += z_m;
  cell.depth_sigma_m = sigma_m;
  return cell;
}

TEST(MergeMetrics, CrossMergesBeyondTwiceTheCellsDepthNoiseAreTheResolvableOnes) {
  // GT 1: the plane z = 0; GT 2: z = 0.15 (a sidewalk step); GT 3: z = 0.03 (a door proud of a
  // wall). Every frame puts a 2 m² cell of GT 1 and one 1 m² cell of another GT surface in label
  // 10, which GT 1 dominates (6 m² of 9).
  MergeEvaluator eval;
  Plane3 z0, z15, z3;
  z0.normal = z15.normal = z3.normal = Eigen::Vector3d::UnitZ();
  z15.offset = -0.15;
  z3.offset = -0.03;
  eval.set_gt_surface_planes({{1, z0}, {2, z15}, {3, z3}});
  map::MergeReport report;
  report.cell_surfaces = {10, 10};
  cv::Mat labels, gt;
  auto frame = [&](std::uint16_t other_gt, const Planecell& other) {
    halves(labels, gt, 0, 1, 1, other_gt);
    eval.add_frame(labels, gt, std::vector<Planecell>{lifted(square(0, std::sqrt(2.0f)), 0.0f, 0.05f), other}, report);
  };
  // The step seen with σ_Z 5 cm (2σ = 10 cm < 15 cm: resolvable; the cell measured 10 cm too
  // high is moved onto its GT plane first), then with σ_Z 10 cm (20 cm > 15 cm: not), and the
  // door with σ_Z 1 cm (2 cm < 3 cm: resolvable) and 2 cm (4 cm > 3 cm: not).
  frame(2, lifted(square(1, 1.0f), 0.25f, 0.05f));
  frame(2, lifted(square(1, 1.0f), 0.15f, 0.10f));
  frame(3, lifted(square(1, 1.0f), 0.03f, 0.01f));
  frame(3, lifted(square(1, 1.0f), 0.03f, 0.02f));
  const MergeMetrics m = eval.finish();
  ASSERT_EQ(m.cells, 8u);
  EXPECT_NEAR(m.cross_merged_cells_between_planes, 4.0 / 8.0, 1e-9);
  EXPECT_NEAR(m.cross_merged_cells_resolvable, 2.0 / 8.0, 1e-9);
  // Without GT planes every cross-merge counts as resolvable.
  MergeEvaluator no_planes;
  halves(labels, gt, 0, 1, 1, 3);
  no_planes.add_frame(labels, gt, std::vector<Planecell>{square(0, std::sqrt(2.0f)), lifted(square(1, 1.0f), 0.03f, 0.02f)},
                      report);
  EXPECT_NEAR(no_planes.finish().cross_merged_cells_resolvable, 0.5, 1e-9);
}

TEST(MergeMetrics, CrossMergedBoundaryCellsAreThoseUnder90PercentOnTheirGtSurface) {
  // Label 10 holds, over two frames, two 4 m² cells of GT 1 (which dominates it: 8 m² of 10), a
  // 1 m² cell 6/8 of whose pixels are GT 2 (a boundary cell: 75 % < 90 %) and a pure 1 m² cell of
  // GT 3. Both are merged across GT planes; only the first is a boundary cell. The second frame's
  // GT 1 cell is 7/8 pure (87.5 %) but in its own GT surface's label: not crossed, not counted.
  MergeEvaluator eval;
  map::MergeReport report;
  report.cell_surfaces = {10, 10};
  cv::Mat labels, gt;
  halves(labels, gt, 0, 1, 1, 2);
  gt.at<std::uint16_t>(2, 3) = gt.at<std::uint16_t>(3, 3) = 1;  // two of cell 1's eight pixels: GT 1
  eval.add_frame(labels, gt, std::vector<Planecell>{square(0, 2.0f), square(1, 1.0f)}, report);
  halves(labels, gt, 0, 1, 1, 3);
  gt.at<std::uint16_t>(0, 0) = 3;  // one of cell 0's eight pixels: GT 3
  eval.add_frame(labels, gt, std::vector<Planecell>{square(0, 2.0f), square(1, 1.0f)}, report);
  const MergeMetrics m = eval.finish();
  ASSERT_EQ(m.cells, 4u);
  EXPECT_NEAR(m.cross_merged_cells_between_planes, 2.0 / 4.0, 1e-9);
  EXPECT_NEAR(m.cross_merged_cells_boundary, 1.0 / 4.0, 1e-9);
}

TEST(MergeMetrics, CellsAreBrokenDownByThePathThatPlacedThem) {
  // Label 10 over two frames: GT 1 cells (fused, found first) dominate it; frame 1's GT 2 cell was
  // covered by it though the CRF labelled it apart, frame 2's GT 3 cell was stored in it. Both
  // are across GT planes: the stored and the covered path hold a quarter of the cells each, all
  // crossed; the found-first path half, none crossed.
  MergeEvaluator eval;
  map::MergeReport report;
  report.cell_surfaces = {10, 10};
  report.cell_fates = {map::CellFate::kFusedFoundFirst, map::CellFate::kCoveredElsewhere};
  cv::Mat labels, gt;
  halves(labels, gt, 0, 1, 1, 2);
  eval.add_frame(labels, gt, std::vector<Planecell>{square(0, 2.0f), square(1, 1.0f)}, report);
  report.cell_fates = {map::CellFate::kFusedFoundFirst, map::CellFate::kStored};
  halves(labels, gt, 0, 1, 1, 3);
  eval.add_frame(labels, gt, std::vector<Planecell>{square(0, 2.0f), square(1, 1.0f)}, report);
  const MergeMetrics m = eval.finish();
  ASSERT_EQ(m.cells, 4u);
  ASSERT_EQ(m.crossed_by_fate.size(), 3u);  // in map::CellFate order
  const std::vector<std::tuple<std::string, double, double>> expected = {
      {"stored", 0.25, 0.25}, {"found first", 0.5, 0.0}, {"covered by another surface", 0.25, 0.25}};
  for (std::size_t k = 0; k < expected.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(m.crossed_by_fate[k].fate, std::get<0>(expected[k]));
    EXPECT_NEAR(m.crossed_by_fate[k].cells, std::get<1>(expected[k]), 1e-9);
    EXPECT_NEAR(m.crossed_by_fate[k].crossed, std::get<2>(expected[k]), 1e-9);
  }
  EXPECT_NEAR(m.cross_merged_cells_between_planes, 0.5, 1e-9);  // the crossed shares' sum
  // A report without fates gives no breakdown.
  MergeEvaluator no_fates;
  report.cell_fates.clear();
  no_fates.add_frame(labels, gt, std::vector<Planecell>{square(0, 2.0f), square(1, 1.0f)}, report);
  EXPECT_TRUE(no_fates.finish().crossed_by_fate.empty());
}

TEST(MergeMetrics, CrossMergesAcrossGtPlanesAreBrokenDownByTheTwoKinds) {
  // Label 10: 2 m² facade cells (GT 1) with a 1 m² door cell (GT 2, 3 cm proud), a 1 m² window
  // cell (GT 3, likewise) and a 1 m² cell of the next facade (GT 6); label 20: a 2 m² car side
  // (GT 4) with a 1 m² side of another car (GT 5: coplanar, 1 m away). GT 1 and GT 6 lie on one
  // plane and touch, so the second facade's cell is across GT surfaces but not across GT planes.
  // Of the 8 cells, the door, the window and the other car's side are across GT planes.
  std::vector<io::SyntheticSurface> scene = {tile_at(1, 0.0, 0.0), tile_at(2, 3.0, 0.03), tile_at(3, 5.0, 0.03),
                                             tile_at(4, 7.0, 1.0), tile_at(5, 9.0, 1.0), tile_at(6, 1.0, 0.0)};
  MergeEvaluator eval;
  eval.set_gt_planes(coplanar_groups(scene));
  eval.set_gt_kinds({{1, io::SurfaceKind::kFacade}, {2, io::SurfaceKind::kDoor}, {3, io::SurfaceKind::kWindow},
                     {4, io::SurfaceKind::kCar}, {5, io::SurfaceKind::kCar}, {6, io::SurfaceKind::kFacade}});
  cv::Mat labels, gt;
  const auto frame = [&](std::uint16_t gt_left, std::uint16_t gt_right, std::uint32_t surface) {
    halves(labels, gt, 0, 1, gt_left, gt_right);
    map::MergeReport report;
    report.cell_surfaces = {surface, surface};
    eval.add_frame(labels, gt, std::vector<Planecell>{square(0, std::sqrt(2.0f)), square(1, 1.0f)}, report);
  };
  frame(1, 2, 10);
  frame(1, 3, 10);
  frame(4, 5, 20);
  frame(1, 6, 10);
  const MergeMetrics m = eval.finish();
  ASSERT_EQ(m.cells, 8u);
  EXPECT_NEAR(m.cross_merged_cells, 4.0 / 8.0, 1e-9);
  EXPECT_NEAR(m.cross_merged_cells_between_planes, 3.0 / 8.0, 1e-9);
  ASSERT_EQ(m.crossed_by_kinds.size(), 3u);
  double sum = 0.0;
  for (const auto& c : m.crossed_by_kinds) {
    EXPECT_NEAR(c.cells, 1.0 / 8.0, 1e-9);
    sum += c.cells;
  }
  EXPECT_NEAR(sum, m.cross_merged_cells_between_planes, 1e-12);
  const auto has = [&](const std::string& own, const std::string& label) {
    return std::any_of(m.crossed_by_kinds.begin(), m.crossed_by_kinds.end(),
                       [&](const auto& c) { return c.own_kind == own && c.label_kind == label; });
  };
  EXPECT_TRUE(has("door", "facade"));
  EXPECT_TRUE(has("window", "facade"));
  EXPECT_TRUE(has("car", "car"));
  EXPECT_FALSE(has("facade", "car"));
  // Two door cells in the facade's label come first, with twice the share.
  frame(1, 2, 10);
  const MergeMetrics more = eval.finish();
  ASSERT_FALSE(more.crossed_by_kinds.empty());
  EXPECT_EQ(more.crossed_by_kinds[0].own_kind, "door");
  EXPECT_EQ(more.crossed_by_kinds[0].label_kind, "facade");
  EXPECT_NEAR(more.crossed_by_kinds[0].cells, 2.0 / 10.0, 1e-9);
}

TEST(MergeMetrics, CellMergedIntoAnotherGtSurfacesLabelIsCrossMerged) {
  MergeEvaluator eval;
  cv::Mat labels, gt;
  halves(labels, gt, 0, 1, 1, 2);
  const std::vector<Planecell> cells = {square(0, std::sqrt(2.0f)), square(1, 1.0f)};  // 2 m², 1 m²
  map::MergeReport report;
  report.cell_surfaces = {10, 10};  // both in one label: GT 1 dominates it (2 m² vs 1 m²)
  eval.add_frame(labels, gt, cells, report);
  const MergeMetrics m = eval.finish();
  EXPECT_EQ(m.cells, 2u);
  EXPECT_EQ(m.gt_surfaces, 2u);
  EXPECT_EQ(m.labels, 1u);
  EXPECT_NEAR(m.cross_merged_cells, 0.5, 1e-9);
  EXPECT_NEAR(m.area_in_dominant_label, 1.0, 1e-6);  // each GT surface lies in one label
  EXPECT_NEAR(m.area_one_label, 1.0, 1e-6);
}

TEST(MergeMetrics, SplitSurfaceIsCountedAndLaterSurfaceMergesAreFollowed) {
  MergeEvaluator eval;
  cv::Mat labels, gt;
  halves(labels, gt, 0, 1, 1, 2);
  map::MergeReport first;
  first.cell_surfaces = {10, 20};
  eval.add_frame(labels, gt, std::vector<Planecell>{square(0, std::sqrt(2.0f)), square(1, 1.0f)}, first);
  halves(labels, gt, 5, 5, 1, 1);  // frame 2: one cell on GT 1, in a new label 11
  map::MergeReport second;
  second.cell_surfaces = {11};
  eval.add_frame(labels, gt, std::vector<Planecell>{square(5, std::sqrt(2.0f))}, second);
  MergeMetrics m = eval.finish();
  // GT 1: 2 m² in label 10 and 2 m² in label 11 → dominant 2 of 4; GT 2: 1 of 1.
  EXPECT_NEAR(m.area_in_dominant_label, 3.0 / 5.0, 1e-6);
  EXPECT_NEAR(m.area_one_label, 1.0 / 5.0, 1e-6);
  EXPECT_EQ(m.labels, 3u);
  // Frame 3 merges label 11 into 10: GT 1 becomes one label.
  map::MergeReport third;
  third.surface_merges = {{2, 11, 10}};
  halves(labels, gt, -1, -1, 0, 0);
  eval.add_frame(labels, gt, std::vector<Planecell>{}, third);
  m = eval.finish();
  EXPECT_NEAR(m.area_in_dominant_label, 1.0, 1e-6);
  EXPECT_NEAR(m.area_one_label, 1.0, 1e-6);
  EXPECT_EQ(m.labels, 2u);
  EXPECT_NEAR(m.cross_merged_cells, 0.0, 1e-12);
}

TEST(MergeMetrics, AreaNotInOneLabelIsBrokenDownByKindWithTheLargestSplitSurfaces) {
  // GT 1 (a facade) lies 2 m² in label 10 and 2 m² in label 11; GT 2 (a door) 1 m² in label 20;
  // GT 3 (a car) 1.5 m² in label 30 and 0.5 m² in label 31. Total 7 m²: only the door is one label.
  MergeEvaluator eval;
  eval.set_gt_kinds({{1, io::SurfaceKind::kFacade}, {2, io::SurfaceKind::kDoor}, {3, io::SurfaceKind::kCar}});
  cv::Mat labels, gt;
  const auto frame = [&](int left, int right, std::uint16_t gt_left, std::uint16_t gt_right, float side_left,
                         float side_right, std::uint32_t surface_left, std::uint32_t surface_right) {
    halves(labels, gt, left, right, gt_left, gt_right);
    map::MergeReport report;
    report.cell_surfaces = {surface_left, surface_right};
    eval.add_frame(labels, gt, std::vector<Planecell>{square(left, side_left), square(right, side_right)}, report);
  };
  frame(0, 1, 1, 2, std::sqrt(2.0f), 1.0f, 10, 20);
  frame(0, 1, 1, 3, std::sqrt(2.0f), std::sqrt(1.5f), 11, 30);
  frame(0, 1, 2, 3, 0.0f, std::sqrt(0.5f), 20, 31);  // a zero-area door cell: adds nothing
  const MergeMetrics m = eval.finish();
  EXPECT_NEAR(m.area_one_label, 1.0 / 7.0, 1e-6);
  ASSERT_EQ(m.by_kind.size(), 3u);
  EXPECT_EQ(m.by_kind[0].kind, "facade");  // largest loss first
  EXPECT_NEAR(m.by_kind[0].area, 4.0 / 7.0, 1e-6);
  EXPECT_NEAR(m.by_kind[0].one_label, 0.0, 1e-9);
  EXPECT_NEAR(m.by_kind[0].lost, 4.0 / 7.0, 1e-6);
  EXPECT_EQ(m.by_kind[1].kind, "car");
  EXPECT_NEAR(m.by_kind[1].lost, 2.0 / 7.0, 1e-6);
  EXPECT_EQ(m.by_kind[2].kind, "door");
  EXPECT_EQ(m.by_kind[2].gt_surfaces, 1u);
  EXPECT_NEAR(m.by_kind[2].one_label, 1.0 / 7.0, 1e-6);
  EXPECT_NEAR(m.by_kind[2].lost, 0.0, 1e-9);
  double lost = 0.0;
  for (const auto& k : m.by_kind) lost += k.lost;
  EXPECT_NEAR(lost, 1.0 - m.area_one_label, 1e-9);
  ASSERT_EQ(m.split_surfaces.size(), 2u);  // largest first; the door is one label
  EXPECT_EQ(m.split_surfaces[0].gt, 1);
  EXPECT_EQ(m.split_surfaces[0].kind, "facade");
  EXPECT_NEAR(m.split_surfaces[0].area_m2, 4.0, 1e-5);
  EXPECT_NEAR(m.split_surfaces[0].dominant_share, 0.5, 1e-6);
  EXPECT_EQ(m.split_surfaces[0].labels, 2u);
  EXPECT_EQ(m.split_surfaces[1].gt, 3);
  EXPECT_NEAR(m.split_surfaces[1].dominant_share, 0.75, 1e-6);
  // Without kinds every GT surface is of kind "unknown".
  const MergeMetrics p = plain_evaluation();
  ASSERT_EQ(p.by_kind.size(), 1u);
  EXPECT_EQ(p.by_kind[0].kind, "unknown");
  EXPECT_EQ(p.by_kind[0].gt_surfaces, 2u);
  EXPECT_NEAR(p.by_kind[0].lost, 0.0, 1e-9);
  EXPECT_TRUE(p.split_surfaces.empty());
}

TEST(MergeMetrics, WeaklyTexturedSurfacesGetTheirOwnShareOfTheAreaNotInOneLabel) {
  // GT 1 (a weakly textured facade) lies 3 m² in label 10 and 1 m² in label 11 (75 %: split);
  // GT 2 (a weakly textured window) 1 m² in label 20 (one label); GT 3 (a textured car) 2 m² in
  // label 30 and 1 m² in label 31 (split). Total 8 m².
  MergeEvaluator eval;
  eval.set_gt_kinds({{1, io::SurfaceKind::kFacade}, {2, io::SurfaceKind::kWindow}, {3, io::SurfaceKind::kCar}});
  eval.set_gt_weak_texture({1, 2});
  cv::Mat labels, gt;
  const auto frame = [&](std::uint16_t gt_left, std::uint16_t gt_right, float area_left, float area_right,
                         std::uint32_t surface_left, std::uint32_t surface_right) {
    halves(labels, gt, 0, 1, gt_left, gt_right);
    map::MergeReport report;
    report.cell_surfaces = {surface_left, surface_right};
    eval.add_frame(labels, gt,
                   std::vector<Planecell>{square(0, std::sqrt(area_left)), square(1, std::sqrt(area_right))}, report);
  };
  frame(1, 3, 3.0f, 2.0f, 10, 30);
  frame(1, 3, 1.0f, 1.0f, 11, 31);
  frame(2, 3, 1.0f, 0.0f, 20, 30);  // a zero-area car cell: adds nothing
  const MergeMetrics m = eval.finish();
  EXPECT_NEAR(m.area_one_label, 1.0 / 8.0, 1e-6);
  EXPECT_EQ(m.weak_texture.kind, "weakly textured");
  EXPECT_EQ(m.weak_texture.gt_surfaces, 2u);
  EXPECT_NEAR(m.weak_texture.area, 5.0 / 8.0, 1e-6);
  EXPECT_NEAR(m.weak_texture.one_label, 1.0 / 8.0, 1e-6);
  EXPECT_NEAR(m.weak_texture.lost, 4.0 / 8.0, 1e-6);
  ASSERT_EQ(m.split_surfaces.size(), 2u);
  EXPECT_EQ(m.split_surfaces[0].gt, 1);
  EXPECT_TRUE(m.split_surfaces[0].weak_texture);
  EXPECT_EQ(m.split_surfaces[1].gt, 3);
  EXPECT_FALSE(m.split_surfaces[1].weak_texture);
  // Without texture ground truth no surface is weakly textured.
  const MergeMetrics p = plain_evaluation();
  EXPECT_EQ(p.weak_texture.gt_surfaces, 0u);
  EXPECT_NEAR(p.weak_texture.area, 0.0, 1e-12);
}

TEST(MergeMetrics, MixedAndRejectedCellsAreLeftOut) {
  MergeEvaluator eval;
  cv::Mat labels, gt;
  halves(labels, gt, 0, 0, 1, 2);  // one cell over 16 px: 6 on GT 1, 5 on GT 2, 5 on GT 3 → mixed
  for (int i = 0; i < 16; ++i) gt.at<std::uint16_t>(i / 4, i % 4) = i < 6 ? 1 : (i < 11 ? 2 : 3);
  map::MergeReport report;
  report.cell_surfaces = {3};
  eval.add_frame(labels, gt, std::vector<Planecell>{square(0, 1.0f)}, report);
  halves(labels, gt, 0, 1, 1, 1);
  report.cell_surfaces = {kNoSurface, 4};  // cell 0 rejected by the map
  eval.add_frame(labels, gt, std::vector<Planecell>{square(0, 1.0f), square(1, 1.0f)}, report);
  const MergeMetrics m = eval.finish();
  EXPECT_EQ(m.mixed_cells, 1u);
  EXPECT_EQ(m.cells, 1u);
}

TEST(MergeMetrics, CellsOfPrunedSurfacesAreLeftOut) {
  MergeEvaluator eval;
  cv::Mat labels, gt;
  halves(labels, gt, 0, 1, 1, 2);
  map::MergeReport first;
  first.cell_surfaces = {10, 20};  // GT 1 in label 10, GT 2 in label 20
  eval.add_frame(labels, gt, std::vector<Planecell>{square(0, 1.0f), square(1, 1.0f)}, first);
  halves(labels, gt, 3, 3, 1, 1);
  map::MergeReport second;
  second.cell_surfaces = {30};  // a second GT-1 cell in its own label ...
  eval.add_frame(labels, gt, std::vector<Planecell>{square(3, 1.0f)}, second);
  EXPECT_NEAR(eval.finish().area_one_label, 1.0 / 3.0, 1e-6);  // GT 1 split over 10 and 30
  map::MergeReport third;
  third.removed_surfaces = {30};
  third.pruned_surfaces = {30};  // ... which the map later prunes as unconfirmed
  halves(labels, gt, -1, -1, 0, 0);
  eval.add_frame(labels, gt, std::vector<Planecell>{}, third);
  const MergeMetrics m = eval.finish();
  EXPECT_EQ(m.cells, 2u);
  EXPECT_EQ(m.pruned_cells, 1u);
  EXPECT_EQ(m.labels, 2u);
  EXPECT_NEAR(m.area_one_label, 1.0, 1e-6);
  EXPECT_NEAR(m.cross_merged_cells, 0.0, 1e-12);
}

TEST(MergeMetrics, MismatchedInputsAreClearErrors) {
  MergeEvaluator eval;
  cv::Mat labels(4, 4, CV_32S, cv::Scalar(0)), gt(4, 5, CV_16U, cv::Scalar(1));
  map::MergeReport report;
  report.cell_surfaces = {1};
  EXPECT_THROW(eval.add_frame(labels, gt, std::vector<Planecell>{square(0, 1.0f)}, report), InputError);
  gt = cv::Mat(4, 4, CV_16U, cv::Scalar(1));
  report.cell_surfaces = {};
  EXPECT_THROW(eval.add_frame(labels, gt, std::vector<Planecell>{square(0, 1.0f)}, report), InputError);
}

TEST(MergeMetrics, CellPlaneErrorIsTheRmsVertexDistanceToTheGtPlane) {
  MergeEvaluator eval;
  // GT 1: the plane z = 0 (n = +z, e = 0); GT 3 has no known plane and is not measured.
  eval.set_gt_surface_planes({{1, Plane3{Eigen::Vector3d::UnitZ(), 0.0}}});
  cv::Mat labels, gt;
  halves(labels, gt, 0, 1, 1, 3);
  for (int i = 0; i <= 10; ++i) {
    // On GT 1's plane, lifted by 1 cm · i; the other cell lies on GT 3 (no plane known).
    const float lift = 0.01f * static_cast<float>(i);
    map::MergeReport report;
    report.cell_surfaces = {10, 20};
    eval.add_frame(labels, gt, std::vector<Planecell>{lifted_square(0, lift, 0.1f + lift), lifted_square(1, 0.0f, 0.5f)},
                   report);
  }
  const MergeMetrics m = eval.finish();
  EXPECT_EQ(m.cells, 22u);
  ASSERT_EQ(m.plane_error_cells, 11u);
  // Errors 0, 1, …, 10 cm: sorted[⌊0.5·10⌋] = 5 cm, sorted[⌊0.9·10⌋] = 9 cm.
  EXPECT_NEAR(m.plane_error_median_m, 0.05, 1e-6);
  EXPECT_NEAR(m.plane_error_p90_m, 0.09, 1e-6);
  EXPECT_NEAR(m.depth_sigma_median_m, 0.15, 1e-6);
  // ε/σ = 0.01 i / (0.1 + 0.01 i) grows with i: the median is i = 5's, 0.05 / 0.15.
  EXPECT_NEAR(m.plane_error_over_sigma_median, 1.0 / 3.0, 1e-6);
}

/// Three frames of a cell on GT 1 (weakly textured) beside a cell on GT 2 (textured), both GT
/// surfaces on the plane z = 0, in labels 10 and 20: frame i ∈ {1, 2, 3} gives cells_of_frame(i).
MergeMetrics weak_beside_textured(const std::function<std::vector<Planecell>(int)>& cells_of_frame) {
  MergeEvaluator eval;
  eval.set_gt_surface_planes({{1, Plane3{Eigen::Vector3d::UnitZ(), 0.0}}, {2, Plane3{Eigen::Vector3d::UnitZ(), 0.0}}});
  eval.set_gt_weak_texture({1});
  cv::Mat labels, gt;
  halves(labels, gt, 0, 1, 1, 2);
  for (int i = 1; i <= 3; ++i) {
    map::MergeReport report;
    report.cell_surfaces = {10, 20};
    eval.add_frame(labels, gt, cells_of_frame(i), report);
  }
  return eval.finish();
}

TEST(MergeMetrics, CellPlaneErrorOnWeaklyTexturedSurfacesIsReportedApart) {
  // The weak cell 10, 20, 30 cm off its plane, the textured one 1 cm; both σ_Z = 10 cm.
  const MergeMetrics m = weak_beside_textured([](int i) {
    return std::vector<Planecell>{lifted_square(0, 0.1f * static_cast<float>(i), 0.1f), lifted_square(1, 0.01f, 0.1f)};
  });
  ASSERT_EQ(m.plane_error_cells, 6u);
  EXPECT_NEAR(m.plane_error_median_m, 0.01, 1e-6);  // sorted 1, 1, 1, 10, 20, 30 cm: [⌊0.5·5⌋] = 1 cm
  ASSERT_EQ(m.weak_plane_error_cells, 3u);
  EXPECT_NEAR(m.weak_plane_error_median_m, 0.2, 1e-6);
  EXPECT_NEAR(m.weak_plane_error_over_sigma_median, 2.0, 1e-5);
}

/// A unit square on the plane through (0.5, 0.5, z_m) tilted by `tilt_deg` about the x axis:
/// normal (0, −sin θ, cos θ), its y = 0 edge h = tan(θ)/2 below z_m and its y = 1 edge h above.
Planecell tilted_square(std::uint32_t id, float z_m, double tilt_deg) {
  Planecell c = square(id, 1.0f);
  const double theta = tilt_deg * std::numbers::pi / 180.0;
  const auto h = static_cast<float>(0.5 * std::tan(theta));
  for (auto& v : c.vertices_m) v.z() = z_m + (v.y() > 0.5f ? h : -h);
  c.plane.normal = Eigen::Vector3d(0.0, -std::sin(theta), std::cos(theta));
  c.plane.offset = -c.plane.normal.dot(Eigen::Vector3d(0.5, 0.5, z_m));
  c.depth_sigma_m = 0.1f;
  return c;
}

TEST(MergeMetrics, CellPlaneErrorSplitsIntoNormalAngleAndCentroidOffset) {
  // The weak cell tilted by 10°, 20°, 30° about a centroid 2 cm above its plane; the textured
  // cell flat, 1, 2, 3 cm above its plane.
  const MergeMetrics m = weak_beside_textured([](int i) {
    return std::vector<Planecell>{tilted_square(0, 0.02f, 10.0 * i), tilted_square(1, 0.01f * static_cast<float>(i), 0.0)};
  });
  ASSERT_EQ(m.plane_error_cells, 6u);
  // All six: angles sorted 0, 0, 0, 10, 20, 30° and offsets 1, 2, 2, 2, 2, 3 cm: [⌊0.5·5⌋] = [2].
  EXPECT_NEAR(m.normal_error_median_deg, 0.0, 1e-3);
  EXPECT_NEAR(m.centroid_offset_median_m, 0.02, 1e-6);
  ASSERT_EQ(m.weak_plane_error_cells, 3u);
  EXPECT_NEAR(m.weak_normal_error_median_deg, 20.0, 1e-3);
  EXPECT_NEAR(m.weak_centroid_offset_median_m, 0.02, 1e-6);
  // The tilt shows in ε, not in the offset: ε = √(o² + h²) with h = tan(20°)/2 = 0.182 m.
  const double h = 0.5 * std::tan(20.0 * std::numbers::pi / 180.0);
  EXPECT_NEAR(m.weak_plane_error_median_m, std::sqrt(0.02 * 0.02 + h * h), 1e-5);
}

TEST(MergeMetrics, TiltedCellPlaneErrorAndNoGtPlanesMeasureNothing) {
  cv::Mat labels, gt;
  halves(labels, gt, 0, 0, 2, 2);
  // Corners alternately 20 cm above and below GT 2's plane z = 1 (n = −z, e = 1): RMS 0.2 m.
  Planecell tilted = square(0, 1.0f);
  for (std::size_t k = 0; k < tilted.vertices_m.size(); ++k) tilted.vertices_m[k].z() = k % 2 ? 0.8f : 1.2f;
  map::MergeReport report;
  report.cell_surfaces = {10};
  MergeEvaluator eval;
  eval.set_gt_surface_planes({{2, Plane3{-Eigen::Vector3d::UnitZ(), 1.0}}});
  eval.add_frame(labels, gt, std::vector<Planecell>{tilted}, report);
  const MergeMetrics m = eval.finish();
  ASSERT_EQ(m.plane_error_cells, 1u);
  EXPECT_NEAR(m.plane_error_median_m, 0.2, 1e-6);
  EXPECT_NEAR(m.plane_error_p90_m, 0.2, 1e-6);
  EXPECT_EQ(m.plane_error_over_sigma_median, 0.0);  // σ_Z unknown (0): no ratio
  MergeEvaluator without_planes;
  without_planes.add_frame(labels, gt, std::vector<Planecell>{tilted}, report);
  EXPECT_EQ(without_planes.finish().plane_error_cells, 0u);
  EXPECT_EQ(eval.finish().weak_plane_error_cells, 0u);  // no texture ground truth
}

}  // namespace
}  // namespace planecell::services::eval
