/// Accuracy of the dense planecell disparity against ground truth on every real pair present
/// (Middlebury bad-2, KITTI D1), with the project's SGM (the pipeline's matcher) and OpenCV
/// StereoSGBM as raw matchers. Skips cleanly when the shared data is absent. Prints the figures
/// recorded in docs/PERFORMANCE.md.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "services/eval/stereo_metrics.hpp"
#include "io/planecell_codec.hpp"
#include "io/stereo_datasets.hpp"
#include "mapping/planecell/extraction.hpp"
#include "mapping/stereo/sgm.hpp"
#include "support/small_street.hpp"
#include "support/test_data.hpp"

namespace planecell::extraction {
namespace {


struct Scores {
  double error_all = 0.0;       ///< % of GT pixels wrong (missing counts as wrong)
  double error_on_valid = 0.0;  ///< % wrong among GT pixels where `mask_valid` has a value
  double coverage = 0.0;        ///< % of GT pixels with a value
};

/// bad-2 (Middlebury: |e| > 2 px) or D1 (KITTI: |e| > 3 px and > 5 %).
bool wrong(float estimate, float truth, bool kitti) {
  if (std::isnan(estimate)) return true;
  const float e = std::abs(estimate - truth);
  return kitti ? (e > 3.0f && e > 0.05f * truth) : e > 2.0f;
}

Scores score(const cv::Mat& estimate, const cv::Mat& truth, const cv::Mat& mask_valid, bool kitti) {
  long n = 0, n_wrong = 0, covered = 0, n_valid = 0, n_valid_wrong = 0;
  for (int v = 0; v < truth.rows; ++v)
    for (int u = 0; u < truth.cols; ++u) {
      const float t = truth.at<float>(v, u);
      if (!(t > 0.0f)) continue;
      const float e = estimate.at<float>(v, u);
      const bool bad = wrong(e, t, kitti);
      ++n;
      n_wrong += bad;
      covered += !std::isnan(e);
      if (!std::isnan(mask_valid.at<float>(v, u))) {
        ++n_valid;
        n_valid_wrong += bad;
      }
    }
  Scores s;
  s.error_all = 100.0 * n_wrong / std::max(1L, n);
  s.error_on_valid = 100.0 * n_valid_wrong / std::max(1L, n_valid);
  s.coverage = 100.0 * covered / std::max(1L, n);
  return s;
}

struct DatasetCase {
  const char* folder;
  io::StereoDataset dataset;
  int cells;  ///< KITTI ~765 as the paper; Middlebury 600 (paper ~270)
};

class PlanecellAccuracy : public ::testing::TestWithParam<DatasetCase> {};

/// Raw matcher: the project's SGM with its default configuration (invalid → NaN).
cv::Mat project_sgm(const cv::Mat& left, const cv::Mat& right, int max_disparity) {
  SgmConfig config;
  config.max_disparity = std::min(max_disparity, left.cols - 1);
  return stereo::compute_disparity(left, right, config);
}

TEST_P(PlanecellAccuracy, DensePlaneDisparityBeatsRawMatchers) {
  const auto root = test::shared_data(GetParam().folder);
  if (!root) GTEST_SKIP() << "shared data '" << GetParam().folder << "' absent";
  const auto refs = io::find_stereo_samples(GetParam().dataset, *root);
  if (refs.empty()) GTEST_SKIP() << "no pairs with ground truth under " << root->string();
  const bool kitti = GetParam().dataset == io::StereoDataset::kKitti;
  ExtractionConfig config;
  config.target_cells = GetParam().cells;
  for (const auto& ref : refs) {
    const io::StereoSample sample = io::load_stereo_sample(ref);
    for (const bool own_sgm : {true, false}) {
      const char* matcher = own_sgm ? "SGM " : "SGBM";
      const cv::Mat raw =
          own_sgm ? project_sgm(sample.left, sample.right, sample.max_disparity)
                  : services::eval::opencv_sgbm_disparity(sample.left, sample.right,
                                                    sample.max_disparity, cv::StereoSGBM::MODE_SGBM);
      const StereoCamera camera = sample.camera.value_or(StereoCamera{});
      const PlanecellFrame frame = extract_planecells(sample.left, raw, camera, config);
      const Scores raw_score = score(raw, sample.gt_disparity, raw, kitti);
      const Scores cell_score = score(frame.dense_disparity, sample.gt_disparity, raw, kitti);
      std::printf(
          "%-24s %-4s cells %4zu planes %5.1f%%  raw %s: all %6.2f%% valid %6.2f%% "
          "cover %5.1f%% | planecell: all %6.2f%% valid %6.2f%% cover %5.1f%%  ratio %.2f "
          "(%.1f ms)\n",
          ref.name.c_str(), kitti ? "D1" : "bad2", frame.cells.size(), 100.0 * frame.plane_fraction,
          matcher, raw_score.error_all, raw_score.error_on_valid, raw_score.coverage,
          cell_score.error_all, cell_score.error_on_valid, cell_score.coverage,
          cell_score.error_all / std::max(1e-9, raw_score.error_all), frame.timings.total_ms);
      const std::size_t compact = io::encode_planecells(frame.cells, camera, 0).size();
      std::printf("%-24s %s compact encoding %zu B for %zu cells\n", ref.name.c_str(), matcher,
                  compact, frame.cells.size());
      // What holds on every pair: the planes cover the GT, remove errors overall, and stay within
      // one point of the raw matcher where it has a value. (The 35 % reduction target is met on
      // 7 of 8 pairs with SGM input (teddy 0.66), 6 of 8 with SGBM input: docs/PERFORMANCE.md.)
      EXPECT_GE(cell_score.coverage, 99.0) << ref.name << " " << matcher;
      EXPECT_LT(cell_score.error_all, 0.9 * raw_score.error_all) << ref.name << " " << matcher;
      EXPECT_LE(cell_score.error_on_valid, raw_score.error_on_valid + 1.0)
          << ref.name << " " << matcher;
      // The 15 kB bound, on every pair and both matchers (codec v3 measured 9.4–10.7 kB
      // for 765–884 cells on SGM input).
      EXPECT_LE(compact, 15000u) << ref.name << " " << matcher;
    }
  }
}

/// Issue 3's accuracy target on every real pair present: the project's SGM (defaults) has a
/// lower all-pixel error (Middlebury and Scene Flow bad-2, KITTI D1; a missing value counts as
/// wrong) than OpenCV StereoSGBM in both MODE_SGBM and MODE_SGBM_3WAY (eval-stereo's settings),
/// and, where the dataset has them, on the non-occluded pixels too.
class RawSgmAccuracy : public ::testing::TestWithParam<DatasetCase> {};

/// Expects the project's SGM to beat OpenCV in both modes on every pair of `refs`.
void expect_sgm_beats_opencv(const std::vector<io::StereoSampleRef>& refs, bool kitti) {
  for (const auto& ref : refs) {
    const io::StereoSample sample = io::load_stereo_sample(ref);
    const cv::Mat ours = project_sgm(sample.left, sample.right, sample.max_disparity);
    for (const int mode : {cv::StereoSGBM::MODE_SGBM, cv::StereoSGBM::MODE_SGBM_3WAY}) {
      const cv::Mat theirs = services::eval::opencv_sgbm_disparity(
          sample.left, sample.right, sample.max_disparity, mode);
      for (const cv::Mat* truth : {&sample.gt_disparity, &sample.gt_disparity_noc}) {
        if (truth->empty()) continue;
        const double e_ours = score(ours, *truth, ours, kitti).error_all;
        const double e_theirs = score(theirs, *truth, theirs, kitti).error_all;
        std::printf("%-24s %s %s: planecell SGM %6.2f%%, OpenCV %6.2f%%\n", ref.name.c_str(),
                    truth == &sample.gt_disparity ? "all" : "noc",
                    mode == cv::StereoSGBM::MODE_SGBM ? "MODE_SGBM     " : "MODE_SGBM_3WAY",
                    e_ours, e_theirs);
        EXPECT_LT(e_ours, e_theirs) << ref.name << " mode " << mode;
      }
    }
  }
}

TEST_P(RawSgmAccuracy, BeatsOpenCvStereoSgbmOnEveryPair) {
  const auto root = test::shared_data(GetParam().folder);
  if (!root) GTEST_SKIP() << "shared data '" << GetParam().folder << "' absent";
  const auto refs = io::find_stereo_samples(GetParam().dataset, *root);
  if (refs.empty()) GTEST_SKIP() << "no pairs with ground truth under " << root->string();
  expect_sgm_beats_opencv(refs, GetParam().dataset == io::StereoDataset::kKitti);
}

/// The same on the project's own KITTI-size synthetic streets (D1, exact GT, all and
/// non-occluded pixels: the renderer writes disp_noc_0), two worlds.
TEST(RawSgmAccuracySynthetic, BeatsOpenCvStereoSgbmOnKittiSizeStreets) {
  test::ScratchDir dir;
  for (const std::uint64_t seed : {1u, 3u})
    test::write_small_street(dir / ("street" + std::to_string(seed)), 2, seed, 1242, 375);
  const auto refs = io::find_stereo_samples(io::StereoDataset::kSynthetic, dir.path());
  ASSERT_EQ(refs.size(), 4u);
  expect_sgm_beats_opencv(refs, true);
}

INSTANTIATE_TEST_SUITE_P(
    RealPairs, PlanecellAccuracy,
    ::testing::Values(DatasetCase{"middlebury", io::StereoDataset::kMiddlebury, 600},
                      DatasetCase{"kitti2012", io::StereoDataset::kKitti, 800},
                      DatasetCase{"kitti2015", io::StereoDataset::kKitti, 800}),
    [](const auto& info) { return std::string(info.param.folder); });

INSTANTIATE_TEST_SUITE_P(
    RealPairs, RawSgmAccuracy,
    ::testing::Values(DatasetCase{"middlebury", io::StereoDataset::kMiddlebury, 0},
                      DatasetCase{"kitti2012", io::StereoDataset::kKitti, 0},
                      DatasetCase{"kitti2015", io::StereoDataset::kKitti, 0},
                      DatasetCase{"sceneflow_sample", io::StereoDataset::kSceneFlow, 0}),
    [](const auto& info) { return std::string(info.param.folder); });

}  // namespace
}  // namespace planecell::extraction
