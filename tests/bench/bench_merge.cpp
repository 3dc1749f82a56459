/// Merge cost per frame and map bytes per frame of the global map on a synthetic straight drive
/// (road of 1 m cells, walls on both sides, 1 m per frame, 12 m look-ahead), as the map grows.
/// Run: build-*/tests/bench_merge  (counters: bytes_per_frame, cells, surfaces).
#include <benchmark/benchmark.h>

#include "support/planecell_fixtures.hpp"
#include "mapping/map/global_map.hpp"

namespace {

using planecell::Planecell;
using planecell::Pose;
namespace map = planecell::map;

using planecell::test::rect_cell;

/// Cells seen at frame f: road x ∈ [−4, 4], z ∈ [f + 2, f + 14) at y = 1.5; walls at x = ±5.
/// Cells are offset by a frame-dependent fraction so re-observations never align exactly.
std::vector<Planecell> frame_cells(int f) {
  std::vector<Planecell> cells;
  const float jitter = 0.1f * static_cast<float>(f % 5);
  const Eigen::Vector3f x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
  for (int k = 0; k < 12; ++k) {
    const float zk = static_cast<float>(f + 2 + k) + jitter;
    for (int i = -4; i < 4; ++i)
      cells.push_back(rect_cell(static_cast<std::uint32_t>(cells.size()), {float(i), 1.5f, zk}, x, z, 3));
    for (int h = 0; h < 3; ++h) {
      cells.push_back(rect_cell(static_cast<std::uint32_t>(cells.size()), {-5, 1.5f - h - 1, zk}, z, y, 20));
      cells.push_back(rect_cell(static_cast<std::uint32_t>(cells.size()), {5, 1.5f - h - 1, zk}, y, z, 30));
    }
  }
  return cells;
}

Pose frame_pose(int f) {
  Pose pose = Pose::Identity();
  pose.translation().z() = f;
  return pose;
}

void BM_MergeFrame(benchmark::State& state) {
  const int preload = static_cast<int>(state.range(0));
  map::GlobalMap global;
  for (int f = 0; f < preload; ++f) global.integrate(f, frame_pose(f), frame_cells(f));
  const std::size_t bytes_before = global.map_bytes();
  int f = preload;
  for (auto _ : state) {
    state.PauseTiming();
    const auto cells = frame_cells(f);
    state.ResumeTiming();
    benchmark::DoNotOptimize(global.integrate(f, frame_pose(f), cells));
    ++f;
  }
  const int frames = f - preload;
  state.counters["bytes_per_frame"] =
      frames > 0 ? double(global.map_bytes() - bytes_before) / frames : 0.0;
  state.counters["map_kB"] = global.map_bytes() / 1024.0;
  state.counters["cells"] = double(global.cells().size());
  state.counters["surfaces"] = double(global.surfaces().size());
  state.counters["input_cells_per_frame"] = double(frame_cells(0).size());
}
BENCHMARK(BM_MergeFrame)->Arg(10)->Arg(200)->Arg(1000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
