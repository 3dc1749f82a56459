/// Planecell extraction time on a KITTI-size frame (~800 cells) next to OpenCV SuperpixelSEEDS
/// (colour only, 1000 asked, 4 iterations) in the same run, single thread.
///   build-*/tests/bench_planecell --benchmark_min_time=2
/// Input: kitti2015 000000_10 left + the project's SGM disparity (the pipeline's matcher; the
/// StereoSGBM input is kept as a second row) when the shared data is present, else a generated
/// 1242×375 street-like frame with known planes.
#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/ximgproc.hpp>

#include "services/eval/stereo_metrics.hpp"
#include "io/image_io.hpp"
#include "io/planecell_codec.hpp"
#include "mapping/planecell/extraction.hpp"
#include "mapping/stereo/sgm.hpp"
#include "support/test_data.hpp"

namespace {

using namespace planecell;

struct BenchFrame {
  cv::Mat left, disparity;  ///< disparity: project SGM (or the generated planes)
  cv::Mat disparity_sgbm;   ///< OpenCV StereoSGBM (= disparity for the generated frame)
  std::string source;
};


/// Ground plane, a far wall, a few boxes and sky, with texture noise (no data needed).
BenchFrame generated_frame() {
  BenchFrame f;
  f.source = "generated";
  f.left.create(375, 1242, CV_8UC3);
  f.disparity.create(375, 1242, CV_32F);
  cv::RNG rng(1);
  for (int v = 0; v < 375; ++v)
    for (int u = 0; u < 1242; ++u) {
      cv::Vec3b c(200, 180, 170);
      float d = std::numeric_limits<float>::quiet_NaN();
      if (v > 180) {
        c = cv::Vec3b(90, 90, 95);
        d = 0.45f * (v - 172);
      } else if (v > 80) {
        c = cv::Vec3b(60, 120, 160);
        d = 12.0f + 0.004f * u;
      }
      if ((u / 150) % 3 == 1 && v > 120 && v < 260) {
        c = cv::Vec3b(40 + 20 * (u / 150 % 4), 40, 160);
        d = 40.0f + 0.01f * u;
      }
      for (int k = 0; k < 3; ++k) c[k] = cv::saturate_cast<uchar>(c[k] + rng.uniform(-12, 12));
      f.left.at<cv::Vec3b>(v, u) = c;
      f.disparity.at<float>(v, u) = d;
    }
  return f;
}

const BenchFrame& frame() {
  static const BenchFrame f = [] {
    // Warm-up: OpenCV builds its BGR→Lab tables on the first conversion of the process; both
    // benchmarks convert to Lab, so that one-off cost is paid here rather than by whichever runs
    // first.
    cv::Mat lab, tiny(8, 8, CV_8UC3, cv::Scalar(1, 2, 3));
    cv::cvtColor(tiny, lab, cv::COLOR_BGR2Lab);
    const auto root = test::shared_data("kitti2015/training");
    if (root && std::filesystem::exists(*root / "image_3/000000_10.png")) {
      BenchFrame k;
      k.source = "kitti2015 000000_10";
      k.left = io::read_image(*root / "image_2/000000_10.png");
      const cv::Mat right = io::read_image(*root / "image_3/000000_10.png");
      k.disparity = stereo::compute_disparity(k.left, right, SgmConfig{});
      k.disparity_sgbm = planecell::services::eval::opencv_sgbm_disparity(k.left, right, 128,
                                                                     cv::StereoSGBM::MODE_SGBM);
      return k;
    }
    BenchFrame g = generated_frame();
    g.disparity_sgbm = g.disparity;
    return g;
  }();
  return f;
}

/// range(0) = cells asked for, range(1) = 1 for the project SGM input, 0 for StereoSGBM.
void BM_PlanecellExtraction(benchmark::State& state) {
  cv::setNumThreads(1);
  const BenchFrame& f = frame();
  const cv::Mat& disparity = state.range(1) ? f.disparity : f.disparity_sgbm;
  ExtractionConfig config;
  config.target_cells = static_cast<int>(state.range(0));
  extraction::PlanecellFrame out;
  extraction::ExtractionTimings sum;
  for (auto _ : state) {
    out = extraction::extract_planecells(f.left, disparity, StereoCamera{}, config);
    benchmark::DoNotOptimize(out.cells.data());
    sum.superpixels_ms += out.timings.superpixels_ms;
    sum.planes_ms += out.timings.planes_ms;
    sum.boundary_update_ms += out.timings.boundary_update_ms;
    sum.vertices_ms += out.timings.vertices_ms;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["cells"] = static_cast<double>(out.cells.size());
  state.counters["plane_pct"] = 100.0 * out.plane_fraction;
  state.counters["compact_bytes"] =
      static_cast<double>(io::encode_planecells(out.cells, StereoCamera{}, 0).size());
  state.counters["superpixels_ms"] = sum.superpixels_ms / n;
  state.counters["planes_ms"] = sum.planes_ms / n;
  state.counters["boundary_ms"] = sum.boundary_update_ms / n;
  state.counters["vertices_ms"] = sum.vertices_ms / n;
  state.SetLabel(f.source + (state.range(1) ? " + SGM" : " + StereoSGBM"));
}
BENCHMARK(BM_PlanecellExtraction)->Args({800, 1})->Args({800, 0})->Unit(benchmark::kMillisecond);

void BM_OpenCvSeeds(benchmark::State& state) {
  cv::setNumThreads(1);
  const BenchFrame& f = frame();
  cv::Mat lab;
  int cells = 0;
  for (auto _ : state) {
    cv::cvtColor(f.left, lab, cv::COLOR_BGR2Lab);
    auto seeds = cv::ximgproc::createSuperpixelSEEDS(f.left.cols, f.left.rows, 3,
                                                     static_cast<int>(state.range(0)), 4);
    seeds->iterate(lab, 4);
    cells = seeds->getNumberOfSuperpixels();
  }
  state.counters["cells"] = cells;
  state.SetLabel(f.source);
}
BENCHMARK(BM_OpenCvSeeds)->Arg(1000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
