/// eval-stereo's scoring: hand-computed bad-t / D1 / MAE / density on tiny maps.
#include <gtest/gtest.h>

#include <limits>
#include <opencv2/core.hpp>

#include "core/error.hpp"
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
  ASSERT_EQ(methods.size(), 3u);
  const PairResult result = evaluate_pair(sample, methods);
  ASSERT_EQ(result.methods.size(), 3u);
  for (const auto& m : result.methods) {
    EXPECT_GT(m.all.estimated, m.all.gt_pixels / 2) << m.method;
    EXPECT_LT(m.all.estimated_pct(m.all.bad1), 5.0) << m.method;
  }
  const std::string json = format_json("synthetic", {result}, methods);
  EXPECT_NE(json.find("\"planecell-sgm\""), std::string::npos);
  EXPECT_NE(json.find("\"opencv-sgbm-3way\""), std::string::npos);
  EXPECT_NE(format_table({result}, methods).find("OVERALL"), std::string::npos);
}

}  // namespace
}  // namespace planecell::services::eval
