#pragma once
/// Explicit per-stripe parallelism for the SGM stage: rows [0, rows) split into `threads`
/// contiguous stripes, each run on its own std::thread (the calling thread takes the last one).
#include <algorithm>
#include <thread>
#include <vector>

namespace planecell::stereo::detail {

template <class Fn>
void parallel_rows(int rows, int threads, Fn&& fn) {
  threads = std::clamp(threads, 1, std::max(1, rows));
  std::vector<std::thread> workers;
  workers.reserve(static_cast<std::size_t>(threads - 1));
  for (int t = 0; t < threads; ++t) {
    const int begin = rows * t / threads;
    const int end = rows * (t + 1) / threads;
    if (t + 1 < threads) workers.emplace_back([&fn, begin, end] { fn(begin, end); });
    else fn(begin, end);
  }
  for (auto& w : workers) w.join();
}

}  // namespace planecell::stereo::detail
