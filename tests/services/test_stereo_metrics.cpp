/// eval-stereo's scoring: hand-computed bad-t / D1 / MAE / density on tiny maps.
#include <gtest/gtest.h>

#include <limits>
#include <opencv2/core.hpp>

#include "core/error.hpp"
#include "core/stereo_camera.hpp"
#include "services/eval/stereo_metrics.hpp"

namespace planecell::services::eval {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

TEST(StereoMetrics, CountsOutliersMissingAndUnknownGroundTruth) {
  // GT: 5 known pixels (0 and NaN = unknown). Estimates: errors 0.5, 1.5, 3.5 (D1: 3.5 > 5 % of
  // 10), 5 (GT 200: 5 < 5 % · 200 = 10 → not D1), and one missing.
  const cv::Mat gt = (cv::Mat_<float>(2, 4) << 10, 10, 10, 200, 50, 0, kNaN, 7);
  const cv::Mat est = (cv::Mat_<float>(2, 4) << 10.5f, 8.5f, 13.5f, 205, kNaN, 3, 3, 1);
  // Last pixel: GT 7, estimate 1 → error 6 (bad1/2/4; D1: 6 > 3 and > 0.35).
  const DisparityErrors e = evaluate_disparity(est, gt);
  EXPECT_EQ(e.gt_pixels, 6);
  EXPECT_EQ(e.estimated, 5);
  EXPECT_EQ(e.bad1, 4);  // 1.5, 3.5, 5, 6
  EXPECT_EQ(e.bad2, 3);  // 3.5, 5, 6
  EXPECT_EQ(e.bad4, 2);  // 5, 6
  EXPECT_EQ(e.d1, 2);    // 3.5 (GT 10), 6 (GT 7)
  EXPECT_DOUBLE_EQ(e.abs_error_sum_px, 0.5 + 1.5 + 3.5 + 5 + 6);
  EXPECT_DOUBLE_EQ(e.mae_px(), 16.5 / 5);
  EXPECT_DOUBLE_EQ(e.density_pct(), 100.0 * 5 / 6);
  EXPECT_DOUBLE_EQ(e.all_pct(e.bad2), 100.0 * (3 + 1) / 6);  // missing counts as an error
  EXPECT_DOUBLE_EQ(e.estimated_pct(e.bad2), 100.0 * 3 / 5);
}

TEST(StereoMetrics, PoolsCountsOverImages) {
  const cv::Mat gt = (cv::Mat_<float>(1, 2) << 10, 20);
  DisparityErrors total = evaluate_disparity((cv::Mat_<float>(1, 2) << 10, 30), gt);
  total += evaluate_disparity((cv::Mat_<float>(1, 2) << kNaN, 20), gt);
  EXPECT_EQ(total.gt_pixels, 4);
  EXPECT_EQ(total.estimated, 3);
  EXPECT_EQ(total.bad2, 1);
  EXPECT_DOUBLE_EQ(total.all_pct(total.bad2), 50.0);
}

TEST(StereoMetrics, RejectsMismatchedMaps) {
  EXPECT_THROW(evaluate_disparity(cv::Mat(2, 3, CV_32F), cv::Mat(3, 3, CV_32F)), InputError);
  EXPECT_THROW(evaluate_disparity(cv::Mat(2, 3, CV_16S), cv::Mat(2, 3, CV_32F)), InputError);
}

TEST(StereoMetrics, MethodsRunOnASampleAndScoreAShiftedTexture) {
  // Right = texture, left = texture shifted by 6 px: every method should find d = 6 mostly.
  cv::Mat texture(60, 140, CV_8UC3);
  cv::randu(texture, 0, 255);
  io::StereoSample sample;
  sample.name = "shift6";
  sample.right = texture(cv::Rect(10, 0, 120, 60)).clone();
  sample.left = texture(cv::Rect(4, 0, 120, 60)).clone();
  sample.gt_disparity = cv::Mat(60, 120, CV_32F, cv::Scalar(6.0f));
  sample.gt_disparity.colRange(0, 6).setTo(kNaN);
  sample.max_disparity = 32;
  const auto methods = default_stereo_methods(SgmConfig{});
  ASSERT_EQ(methods.size(), 4u);  // planecell-sgm, opencv-sgbm, opencv-sgbm-3way, planecell
  const PairResult result = evaluate_pair(sample, methods);
  ASSERT_EQ(result.methods.size(), 4u);
  for (const auto& m : result.methods) {
    EXPECT_GT(m.all.estimated, m.all.gt_pixels / 2) << m.method;
    EXPECT_LT(m.all.estimated_pct(m.all.bad1), 5.0) << m.method;
  }
  const std::string json = format_json("synthetic", {result}, methods);
  EXPECT_NE(json.find("\"planecell-sgm\""), std::string::npos);
  EXPECT_NE(json.find("\"opencv-sgbm-3way\""), std::string::npos);
  EXPECT_NE(json.find("\"planecell\""), std::string::npos);
  EXPECT_EQ(json.find("\"points\""), std::string::npos);  // no camera → no 3D figures
  EXPECT_NE(format_table({result}, methods).find("OVERALL"), std::string::npos);
  EXPECT_EQ(format_table({result}, methods).find("3D accuracy"), std::string::npos);
  // A pair name longer than the default column (Scene Flow: "sceneflow_sample/A-0032-0006")
  // is printed whole, and the columns after it stay aligned with the header.
  PairResult long_name = result;
  long_name.pair = "sceneflow_sample/A-0032-0006";
  const std::string table = format_table({long_name}, methods);
  const auto row = table.find(long_name.pair + " planecell-sgm");
  ASSERT_NE(row, std::string::npos) << table;
  const auto header = table.find("pair ");
  ASSERT_NE(header, std::string::npos);
  const auto line_start = [&](std::size_t at) { return table.rfind('\n', at) + 1; };
  EXPECT_EQ(table.find("method", header) - line_start(header),
            table.find("planecell-sgm", row) - line_start(row));
}

TEST(StereoMetrics, PointAccuracyOnHandComputedPixels) {
  // f = 100 px, B = 0.5 m, principal point (1, 0): Z(d) = 50 / d m, and the pixel ray factor is
  // ‖((u − 1)/100, v/100, 1)‖.
  StereoCamera camera;
  camera.fx = camera.fy = 100.0;
  camera.cx = 1.0;
  camera.cy = 0.0;
  camera.baseline_m = 0.5;
  camera.width = 3;
  camera.height = 2;
  // (0,0): GT 10 (Z 5 m), est 9.9 (Z 5.0505 m) → 5.05 cm · √(1 + 0.0001) = 5.05 cm: all radii.
  // (1,0): GT 10, est 9.5 (Z 5.2632 m) → 26.3 cm on the axis: within 50 and 100 cm only.
  // (2,0): GT 5 (Z 10 m), est 5.5 (Z 9.0909 m) → 90.9 cm · 1.00005 = 90.9 cm: 100 cm only.
  // Row 1: GT 20 with a missing estimate (counts, outside every radius); unknown GT skipped.
  const cv::Mat gt = (cv::Mat_<float>(2, 3) << 10, 10, 5, 20, 0, kNaN);
  const cv::Mat est = (cv::Mat_<float>(2, 3) << 9.9f, 9.5f, 5.5f, kNaN, 3, 3);
  const PointErrors e = evaluate_points(est, gt, camera);
  EXPECT_EQ(e.gt_pixels, 4);
  EXPECT_EQ(e.within[0], 1);  // 10 cm
  EXPECT_EQ(e.within[1], 1);  // 20 cm
  EXPECT_EQ(e.within[2], 2);  // 50 cm
  EXPECT_EQ(e.within[3], 3);  // 100 cm
  EXPECT_DOUBLE_EQ(e.within_pct(3), 75.0);
  // On the optical axis, GT 10 and estimate 9.8: |50/9.8 − 5| = 10.2 cm → just outside 10 cm,
  // inside 20 cm.
  const cv::Mat one_gt = (cv::Mat_<float>(1, 1) << 10);
  camera.cx = 0.0;
  camera.width = camera.height = 1;
  const PointErrors f = evaluate_points((cv::Mat_<float>(1, 1) << 9.8f), one_gt, camera);
  EXPECT_EQ(f.within[0], 0);
  EXPECT_EQ(f.within[1], 1);
  PointErrors total = e;
  total += f;
  EXPECT_EQ(total.gt_pixels, 5);
  EXPECT_EQ(total.within[1], 2);
  EXPECT_THROW(evaluate_points(cv::Mat(1, 2, CV_32F), one_gt, camera), InputError);
  camera.baseline_m = 0.0;
  EXPECT_THROW(evaluate_points(one_gt, one_gt, camera), ConfigError);
}

TEST(StereoMetrics, PlanecellMethodAndPointTableWithACamera) {
  // A fronto-parallel textured wall at d = 6 px seen by a known camera: the planecell method's
  // dense disparity is ~6 everywhere, so nearly all GT points lie within 10 cm
  // (f = 100, B = 0.1 m: Z = 10/6 m, and ±0.25 px moves the point by < 8 cm).
  cv::Mat texture(80, 180, CV_8UC3);
  cv::RNG rng(3);
  rng.fill(texture, cv::RNG::UNIFORM, 0, 255);
  io::StereoSample sample;
  sample.name = "wall6";
  sample.right = texture(cv::Rect(10, 0, 160, 80)).clone();
  sample.left = texture(cv::Rect(4, 0, 160, 80)).clone();
  sample.gt_disparity = cv::Mat(80, 160, CV_32F, cv::Scalar(6.0f));
  sample.max_disparity = 32;
  StereoCamera camera;
  camera.fx = camera.fy = 100.0;
  camera.cx = 80.0;
  camera.cy = 40.0;
  camera.baseline_m = 0.1;
  camera.width = 160;
  camera.height = 80;
  sample.camera = camera;
  ExtractionConfig extraction;
  extraction.target_cells = 20;
  const auto methods = default_stereo_methods(SgmConfig{}, extraction);
  const PairResult result = evaluate_pair(sample, methods);
  ASSERT_EQ(result.methods.size(), 4u);
  const MethodResult& planecell = result.methods[3];
  ASSERT_EQ(planecell.method, "planecell");
  EXPECT_GT(planecell.all.density_pct(), 99.0);
  EXPECT_EQ(planecell.points.gt_pixels, 80 * 160);
  EXPECT_GT(planecell.points.within_pct(0), 90.0);
  const std::string json = format_json("synthetic", {result}, methods);
  EXPECT_NE(json.find("\"within_10cm_pct\""), std::string::npos);
  const std::string table = format_table({result}, methods);
  EXPECT_NE(table.find("3D accuracy"), std::string::npos);
  // The paper's Table 1 row (SGBM + planecell) is printed under the 3D table as the row to beat.
  EXPECT_NE(table.find("33.49    50.23    72.91    80.84"), std::string::npos) << table;
}

}  // namespace
}  // namespace planecell::services::eval
