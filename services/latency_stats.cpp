#include "services/latency_stats.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace planecell::services {

LatencySummary summarise(std::vector<double> samples) {
  LatencySummary out;
  out.count = samples.size();
  if (samples.empty()) return out;
  std::sort(samples.begin(), samples.end());
  auto rank = [&](double p) {
    const auto n = static_cast<double>(samples.size());
    const auto index = static_cast<std::size_t>(std::max(1.0, std::ceil(p / 100.0 * n))) - 1;
    return samples[std::min(index, samples.size() - 1)];
  };
  out.p50_ms = rank(50);
  out.p95_ms = rank(95);
  out.p99_ms = rank(99);
  out.max_ms = samples.back();
  out.mean_ms = std::accumulate(samples.begin(), samples.end(), 0.0) / static_cast<double>(samples.size());
  return out;
}

void LatencyLog::add(const std::string& stage, double ms) {
  auto [it, inserted] = samples_.try_emplace(stage);
  if (inserted) order_.push_back(stage);
  it->second.push_back(ms);
}

std::vector<std::pair<std::string, LatencySummary>> LatencyLog::summaries() const {
  std::vector<std::pair<std::string, LatencySummary>> out;
  for (const auto& name : order_) out.emplace_back(name, summarise(samples_.at(name)));
  return out;
}

}  // namespace planecell::services
