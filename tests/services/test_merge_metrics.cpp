/// Merge metrics against ground-truth surfaces: hand-built label images, GT ids and merge reports
/// whose dominant labels, cross-merged cells and followed surface merges are counted by hand.
#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace planecell::services::eval
