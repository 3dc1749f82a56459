/// SGM on a KITTI-size pair (1242×375, 128 disparities): planecell vs OpenCV StereoSGBM, same run.
/// Uses /work/shared/data/kitti2015 000000_10 when present, else a random-texture pair.
///   build-sgm/tests/bench_sgm --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include "io/image_io.hpp"
#include "mapping/stereo/sgm.hpp"
#include "mapping/stereo/sgm_detail.hpp"
#include "support/test_data.hpp"

namespace {

struct Pair {
  cv::Mat left, right;
  std::string source;
};

const Pair& kitti_pair() {
  static const Pair pair = [] {
    Pair p;
    if (auto root = planecell::test::shared_data("kitti2015/training")) {
      p.left = planecell::io::read_image(*root / "image_2/000000_10.png");
      p.right = planecell::io::read_image(*root / "image_3/000000_10.png");
      p.source = "kitti2015/000000_10";
    } else {
      cv::Mat texture(375, 1242 + 40, CV_8UC3);
      cv::randu(texture, 0, 255);
      cv::GaussianBlur(texture, texture, cv::Size(0, 0), 1.0);
      p.left = texture(cv::Rect(0, 0, 1242, 375)).clone();
      p.right = texture(cv::Rect(20, 0, 1242, 375)).clone();
      p.source = "random texture (20 px shift)";
    }
    return p;
  }();
  return pair;
}

void BM_PlanecellSgm(benchmark::State& state) {
  const Pair& pair = kitti_pair();
  planecell::SgmConfig config;
  config.max_disparity = 128;
  config.threads = static_cast<int>(state.range(0));
  config.paths = static_cast<int>(state.range(1));
  for (auto _ : state)
    benchmark::DoNotOptimize(planecell::stereo::compute_disparity(pair.left, pair.right, config));
  state.SetLabel(pair.source);
}
BENCHMARK(BM_PlanecellSgm)
    ->ArgNames({"threads", "paths"})
    ->Args({1, 8})
    ->Args({2, 8})
    ->Args({2, 4})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// 8 paths, one aggregation kernel (0 portable, 1 AVX2, 2 AVX-512BW) per run; with 1 thread
/// the CPU time column is the whole computation.
void BM_PlanecellSgmKernel(benchmark::State& state) {
  using planecell::stereo::detail::AggregationKernel;
  const auto kernel = static_cast<AggregationKernel>(state.range(0));
  if (!planecell::stereo::detail::aggregation_kernel_supported(kernel)) {
    state.SkipWithError("aggregation kernel not supported on this CPU");
    return;
  }
  const Pair& pair = kitti_pair();
  planecell::SgmConfig config;
  config.max_disparity = 128;
  config.threads = static_cast<int>(state.range(1));
  for (auto _ : state)
    benchmark::DoNotOptimize(
        planecell::stereo::detail::compute_disparity_with(pair.left, pair.right, config, kernel));
  state.SetLabel(pair.source);
}
BENCHMARK(BM_PlanecellSgmKernel)
    ->ArgNames({"kernel", "threads"})
    ->Args({1, 1})
    ->Args({2, 1})
    ->Args({1, 2})
    ->Args({2, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_OpenCvSgbm(benchmark::State& state) {
  const Pair& pair = kitti_pair();
  const int mode = state.range(1) == 0 ? cv::StereoSGBM::MODE_SGBM : cv::StereoSGBM::MODE_SGBM_3WAY;
  constexpr int kBlock = 5;
  auto sgbm = cv::StereoSGBM::create(0, 128, kBlock, 8 * 3 * kBlock * kBlock,
                                     32 * 3 * kBlock * kBlock, 1, 0, 10, 100, 2, mode);
  const int previous_threads = cv::getNumThreads();
  cv::setNumThreads(static_cast<int>(state.range(0)));
  cv::Mat disparity;
  for (auto _ : state) {
    sgbm->compute(pair.left, pair.right, disparity);
    benchmark::DoNotOptimize(disparity.data);
  }
  cv::setNumThreads(previous_threads);
  state.SetLabel(std::string(state.range(1) == 0 ? "MODE_SGBM " : "MODE_SGBM_3WAY ") + pair.source);
}
BENCHMARK(BM_OpenCvSgbm)
    ->ArgNames({"threads", "3way"})
    ->Args({1, 0})
    ->Args({2, 0})
    ->Args({1, 1})
    ->Args({2, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
