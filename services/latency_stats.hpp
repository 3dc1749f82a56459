#pragma once
/// Per-stage latency samples and their percentiles (p50/p95/p99/max), for reports.
#include <map>
#include <string>
#include <vector>

namespace planecell::services {

struct LatencySummary {
  std::size_t count = 0;
  double p50_ms = 0.0, p95_ms = 0.0, p99_ms = 0.0, max_ms = 0.0, mean_ms = 0.0;
};

/// Percentile by nearest rank on a sorted copy: p-th percentile = sorted[ceil(p/100·n) − 1].
LatencySummary summarise(std::vector<double> samples_ms);

/// Named series of latency samples ("sgm", "extract", ...), in insertion order of names.
class LatencyLog {
 public:
  void add(const std::string& stage, double ms);
  std::vector<std::pair<std::string, LatencySummary>> summaries() const;

 private:
  std::vector<std::string> order_;
  std::map<std::string, std::vector<double>> samples_;
};

}  // namespace planecell::services
