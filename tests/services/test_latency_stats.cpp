#include <gtest/gtest.h>

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

}  // namespace
}  // namespace planecell::services
