#pragma once
/// Per-stage latency samples and their percentiles (p50/p95/p99/max), for reports.
#include <cstdint>
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

/// Named series of latency samples ("sgm", "extract", ...), in insertion order of names. Each
/// series is a histogram with logarithmic bins (bin i holds [a·r^(i−1), a·r^i), a = 1 µs,
/// r = 1.01, up to ~6 h; one bin below and one above) plus the exact count, sum, minimum and
/// maximum: memory and summaries() cost stay fixed however long the daemon runs. A percentile is
/// the nearest-rank bin's geometric centre clamped to [min, max] (the minimum below 1 µs, the
/// maximum above 6 h): within 0.5 % of the exact nearest-rank sample, and exact for one sample,
/// the maximum and the mean.
class LatencyLog {
 public:
  void add(const std::string& stage, double ms);
  std::vector<std::pair<std::string, LatencySummary>> summaries() const;

 private:
  struct Series {
    std::vector<std::uint32_t> bins;
    std::size_t count = 0;
    double sum = 0.0, min = 0.0, max = 0.0;
  };
  std::vector<std::string> order_;
  std::map<std::string, Series> series_;
};

}  // namespace planecell::services
