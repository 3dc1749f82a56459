#pragma once
/// Per-stage CPU time and page faults of many frames (FrameWork::stage_cost), summarised for
/// reports next to the wall-time latencies: with more runnable threads than cores a stage's wall
/// time includes waiting for a core, its CPU time does not.
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "services/latency_stats.hpp"
#include "services/pipeline/stages.hpp"

namespace planecell::services {

struct StageCostSummary {
  LatencySummary cpu;              ///< CPU ms per run (p50/p95/p99/max/mean)
  double minor_faults_mean = 0.0;  ///< first-touch page faults per run
};

class StageCostLog {
 public:
  /// Adds every stage run recorded in `work.stage_cost`.
  void add(const FrameWork& work);
  /// One entry per stage, in the order stages were first seen.
  std::vector<std::pair<std::string, StageCostSummary>> summaries() const;

 private:
  LatencyLog cpu_ms_;
  std::map<std::string, std::pair<std::int64_t, std::size_t>> faults_;  ///< sum, runs
};

}  // namespace planecell::services
