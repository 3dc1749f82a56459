/// Planecell segmentation scores (boundary recall within r px, cells on one GT surface) on
/// hand-made label images whose answers are counted by hand, and their eval-stereo output.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "services/eval/segmentation_metrics.hpp"
#include "services/eval/stereo_metrics.hpp"

namespace planecell::services::eval {
namespace {

/// 10×6 GT: surface 1 in columns 0..4, surface 2 in columns 5..9. GT boundary pixels: columns
/// 4 and 5, 12 pixels.
cv::Mat two_surfaces() {
  cv::Mat ids(6, 10, CV_16U, cv::Scalar(1));
  ids.colRange(5, 10).setTo(2);
  return ids;
}

/// Two cells split before column `split`.
cv::Mat two_cells(int split) {
  cv::Mat labels(6, 10, CV_32S, cv::Scalar(0));
  labels.colRange(split, 10).setTo(1);
  return labels;
}

TEST(SegmentationMetrics, CellsOnTheSurfaceEdgeRecallEveryBoundaryPixel) {
  const SegmentationScores s = evaluate_segmentation(two_cells(5), two_surfaces());
  EXPECT_EQ(s.gt_boundary_pixels, 12);
  EXPECT_EQ(s.recalled_boundary_pixels, 12);
  EXPECT_DOUBLE_EQ(s.boundary_recall_pct(), 100.0);
  EXPECT_EQ(s.cells, 2);
  EXPECT_EQ(s.single_surface_cells, 2);
}

TEST(SegmentationMetrics, ShiftedCellEdgeRecallsOnlyWithinTheTolerance) {
  // Cell boundary pixels in columns 7 and 8: GT column 5 is 2 px away (recalled), column 4 is
  // 3 px away (missed with r = 2, recalled with r = 3). Cell 0 holds 30 pixels of surface 1 and
  // 18 of surface 2 (62.5 % < 90 %); cell 1 lies on surface 2 only.
  const SegmentationScores s = evaluate_segmentation(two_cells(8), two_surfaces());
  EXPECT_EQ(s.gt_boundary_pixels, 12);
  EXPECT_EQ(s.recalled_boundary_pixels, 6);
  EXPECT_DOUBLE_EQ(s.boundary_recall_pct(), 50.0);
  EXPECT_EQ(s.cells, 2);
  EXPECT_EQ(s.single_surface_cells, 1);
  EXPECT_DOUBLE_EQ(s.single_surface_pct(), 50.0);
  SegmentationOptions wider;
  wider.boundary_tolerance_px = 3;
  EXPECT_EQ(evaluate_segmentation(two_cells(8), two_surfaces(), wider).recalled_boundary_pixels,
            12);
}

TEST(SegmentationMetrics, PurityThresholdIsInclusive) {
  // One cell of 10 pixels, 9 of them on surface 1: exactly 90 %.
  cv::Mat ids(1, 10, CV_32S, cv::Scalar(1));
  ids.at<std::int32_t>(0, 9) = 2;
  const cv::Mat labels(1, 10, CV_32S, cv::Scalar(0));
  EXPECT_EQ(evaluate_segmentation(labels, ids).single_surface_cells, 1);
  SegmentationOptions strict;
  strict.purity = 0.95;
  EXPECT_EQ(evaluate_segmentation(labels, ids, strict).single_surface_cells, 0);
}

TEST(SegmentationMetrics, ScoresPoolOverFramesAndNoBoundaryGivesNaN) {
  SegmentationScores total = evaluate_segmentation(two_cells(5), two_surfaces());
  total += evaluate_segmentation(two_cells(8), two_surfaces());
  EXPECT_EQ(total.gt_boundary_pixels, 24);
  EXPECT_EQ(total.recalled_boundary_pixels, 18);
  EXPECT_EQ(total.single_surface_cells, 3);
  const cv::Mat one_surface(4, 4, CV_16U, cv::Scalar(3));
  const SegmentationScores flat =
      evaluate_segmentation(cv::Mat(4, 4, CV_32S, cv::Scalar(0)), one_surface);
  EXPECT_TRUE(std::isnan(flat.boundary_recall_pct()));
  EXPECT_DOUBLE_EQ(flat.single_surface_pct(), 100.0);
}

TEST(SegmentationMetrics, RejectsBadInput) {
  EXPECT_THROW(evaluate_segmentation(cv::Mat(), two_surfaces()), InputError);
  EXPECT_THROW(evaluate_segmentation(two_cells(5), cv::Mat(6, 9, CV_16U, cv::Scalar(1))),
               InputError);
  EXPECT_THROW(evaluate_segmentation(two_cells(5), cv::Mat(6, 10, CV_8U, cv::Scalar(1))),
               InputError);
  SegmentationOptions bad;
  bad.boundary_tolerance_px = -1;
  EXPECT_THROW(evaluate_segmentation(two_cells(5), two_surfaces(), bad), ConfigError);
  bad = {};
  bad.purity = 0.0;
  EXPECT_THROW(evaluate_segmentation(two_cells(5), two_surfaces(), bad), ConfigError);
}

TEST(SegmentationMetrics, EvalStereoPrintsAndWritesTheScores) {
  PairResult pair;
  pair.pair = "seq/000000";
  pair.segmentation = evaluate_segmentation(two_cells(8), two_surfaces());
  const std::vector<StereoMethod> methods;
  const std::string table = format_table({pair}, methods);
  EXPECT_NE(table.find("boundary recall 50.0 % (6/12)"), std::string::npos) << table;
  EXPECT_NE(table.find("cells on one surface 50.0 % (1/2)"), std::string::npos) << table;
  const std::string json = format_json("synthetic", {pair}, methods);
  EXPECT_NE(json.find("\"segmentation\": {\"boundary_recall_pct\": 50"), std::string::npos) << json;
  EXPECT_NE(json.find("\"segmentation_overall\""), std::string::npos) << json;
  // Pairs without segmentation add neither lines nor fields.
  PairResult plain;
  plain.pair = "teddy";
  EXPECT_EQ(format_table({plain}, methods).find("boundary recall"), std::string::npos);
  EXPECT_EQ(format_json("middlebury", {plain}, methods).find("segmentation"), std::string::npos);
}

}  // namespace
}  // namespace planecell::services::eval
