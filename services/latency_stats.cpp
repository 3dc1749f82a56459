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

namespace {

constexpr double kFirstBinMs = 1e-3;  ///< a: below it, bin 0 (1 µs)
constexpr double kBinRatio = 1.01;    ///< r: each bin 1 % wider than the one before
constexpr int kBins = 2402;           ///< bin i in 1..2400 holds [a·r^(i−1), a·r^i); a·r^2400 ≈ 6.4 h
                                      ///< and longer go in the last bin

int bin_of(double ms) {
  if (!(ms >= kFirstBinMs)) return 0;
  const double i = 1.0 + std::floor(std::log(ms / kFirstBinMs) / std::log(kBinRatio));
  return static_cast<int>(std::min(i, static_cast<double>(kBins - 1)));
}

/// What a sample in bin i stands for: the bin's geometric centre, clamped to the observed range;
/// the two open-ended bins stand for the observed minimum and maximum.
double bin_value(int i, double min, double max) {
  if (i == 0) return min;
  if (i == kBins - 1) return max;
  return std::clamp(kFirstBinMs * std::pow(kBinRatio, i - 0.5), min, max);
}

}  // namespace

void LatencyLog::add(const std::string& stage, double ms) {
  auto [it, inserted] = series_.try_emplace(stage);
  if (inserted) order_.push_back(stage);
  Series& s = it->second;
  if (s.bins.empty()) s.bins.assign(kBins, 0);
  ++s.bins[static_cast<std::size_t>(bin_of(ms))];
  s.min = s.count == 0 ? ms : std::min(s.min, ms);
  s.max = s.count == 0 ? ms : std::max(s.max, ms);
  s.sum += ms;
  ++s.count;
}

std::vector<std::pair<std::string, LatencySummary>> LatencyLog::summaries() const {
  std::vector<std::pair<std::string, LatencySummary>> out;
  for (const auto& name : order_) {
    const Series& s = series_.at(name);
    LatencySummary summary;
    summary.count = s.count;
    summary.max_ms = s.max;
    summary.mean_ms = s.count > 0 ? s.sum / static_cast<double>(s.count) : 0.0;
    // Nearest rank k = ceil(p/100·n) (at least 1), then the bin holding the k-th sample.
    auto rank = [&](double p) {
      const auto n = static_cast<double>(s.count);
      const auto k = static_cast<std::size_t>(std::max(1.0, std::ceil(p / 100.0 * n)));
      std::size_t seen = 0;
      for (int i = 0; i < kBins; ++i) {
        seen += s.bins[static_cast<std::size_t>(i)];
        if (seen >= k) return bin_value(i, s.min, s.max);
      }
      return s.max;
    };
    if (s.count > 0) {
      summary.p50_ms = rank(50);
      summary.p95_ms = rank(95);
      summary.p99_ms = rank(99);
    }
    out.emplace_back(name, summary);
  }
  return out;
}

}  // namespace planecell::services
