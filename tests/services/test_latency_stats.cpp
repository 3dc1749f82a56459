#include <gtest/gtest.h>

#include <random>

#include "services/latency_stats.hpp"

namespace planecell::services {
namespace {

TEST(LatencyStats, NearestRankPercentilesOfOneToHundred) {
  std::vector<double> samples;
  for (int i = 100; i >= 1; --i) samples.push_back(i);  // unsorted on purpose
  const auto s = summarise(samples);
  EXPECT_EQ(s.count, 100u);
  EXPECT_DOUBLE_EQ(s.p50_ms, 50.0);
  EXPECT_DOUBLE_EQ(s.p95_ms, 95.0);
  EXPECT_DOUBLE_EQ(s.p99_ms, 99.0);
  EXPECT_DOUBLE_EQ(s.max_ms, 100.0);
  EXPECT_DOUBLE_EQ(s.mean_ms, 50.5);
}

TEST(LatencyStats, SingleSampleIsEveryPercentile) {
  const auto s = summarise({7.5});
  EXPECT_DOUBLE_EQ(s.p50_ms, 7.5);
  EXPECT_DOUBLE_EQ(s.p99_ms, 7.5);
}

TEST(LatencyStats, LogKeepsStageOrderAndSeparatesSeries) {
  LatencyLog log;
  log.add("sgm", 30);
  log.add("extract", 10);
  log.add("sgm", 50);
  const auto summaries = log.summaries();
  ASSERT_EQ(summaries.size(), 2u);
  EXPECT_EQ(summaries[0].first, "sgm");
  EXPECT_EQ(summaries[0].second.count, 2u);
  EXPECT_DOUBLE_EQ(summaries[0].second.max_ms, 50.0);
  EXPECT_EQ(summaries[1].first, "extract");
  EXPECT_DOUBLE_EQ(summaries[1].second.p50_ms, 10.0);
}

TEST(LatencyStats, LogPercentilesStayWithinHalfAPercentOfTheExactOnes) {
  // Log-normal latencies around 100 ms, with a tail: what a stage's samples look like.
  std::mt19937 rng(7);
  std::lognormal_distribution<double> latency(std::log(100.0), 0.4);
  std::vector<double> samples;
  LatencyLog log;
  for (int i = 0; i < 100000; ++i) {
    samples.push_back(latency(rng));
    log.add("e2e", samples.back());
  }
  log.add("tiny", 2e-4);  // below the first bin
  log.add("tiny", 5e8);   // beyond the last
  const LatencySummary exact = summarise(samples);
  const LatencySummary binned = log.summaries().front().second;
  EXPECT_EQ(binned.count, exact.count);
  EXPECT_NEAR(binned.p50_ms, exact.p50_ms, 0.005 * exact.p50_ms);
  EXPECT_NEAR(binned.p95_ms, exact.p95_ms, 0.005 * exact.p95_ms);
  EXPECT_NEAR(binned.p99_ms, exact.p99_ms, 0.005 * exact.p99_ms);
  EXPECT_DOUBLE_EQ(binned.max_ms, exact.max_ms);
  EXPECT_NEAR(binned.mean_ms, exact.mean_ms, 1e-9 * exact.mean_ms);
  const LatencySummary tiny = log.summaries().back().second;
  EXPECT_DOUBLE_EQ(tiny.p50_ms, 2e-4);  // clamped to the observed minimum
  EXPECT_DOUBLE_EQ(tiny.p99_ms, 5e8);   // and maximum
}

}  // namespace
}  // namespace planecell::services
