/// Synthetic stereo world: rendering (both views + GT) and writing (PNG encode) per frame, at the
/// KITTI size. Single-threaded. Run: build/tests/bench_synth --benchmark_min_time=2
#include <benchmark/benchmark.h>

#include <filesystem>

#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "io/synthetic/synthetic_world.hpp"

namespace {

using namespace planecell;

io::SyntheticWorld kitti_street() {
  SynthConfig config;
  config.frames = 200;
  return io::make_street_world(config);
}

void BM_SynthBuildStreet(benchmark::State& state) {
  SynthConfig config;
  config.frames = static_cast<int>(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(io::make_street_world(config));
}
BENCHMARK(BM_SynthBuildStreet)->Arg(200)->Arg(2000)->Unit(benchmark::kMillisecond);

void BM_SynthRenderFrame(benchmark::State& state) {
  const io::SyntheticWorld world = kitti_street();
  std::size_t i = 0;
  for (auto _ : state) {
    const auto view = io::render_view(world, world.trajectory[i % world.trajectory.size()], i);
    benchmark::DoNotOptimize(view.left.data);
    i += 7;
  }
  state.counters["fps"] = benchmark::Counter(static_cast<double>(state.iterations()),
                                             benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SynthRenderFrame)->Unit(benchmark::kMillisecond);

void BM_SynthWriteFrame(benchmark::State& state) {
  const io::SyntheticWorld world = kitti_street();
  const auto view = io::render_view(world, world.trajectory[50], 50);
  const auto dir = std::filesystem::temp_directory_path() / "planecell_bench_synth";
  const int level = static_cast<int>(state.range(0));
  for (auto _ : state) {
    io::write_image(dir / "l.png", view.left, level);
    io::write_image(dir / "r.png", view.right, level);
    io::write_kitti_disparity(dir / "d.png", view.disparity, level);
    io::write_image(dir / "s.png", view.surface_id, level);
  }
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_SynthWriteFrame)->Arg(1)->Arg(3)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
