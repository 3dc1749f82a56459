/// What the pipeline's reports are made of: thread CPU time and page faults per stage run,
/// process RSS, the allocator setting of the streaming commands, and the single-threaded replay's
/// publish sink (the one `replay --publish` uses without --threads).
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <vector>

#include "core/error.hpp"
#include "services/pipeline/heap_tuning.hpp"
#include "services/pipeline/process_memory.hpp"
#include "services/pipeline/stage_cost_log.hpp"
#include "services/pipeline/thread_usage.hpp"
#include "services/replay.hpp"
#include "support/small_street.hpp"
#include "support/test_data.hpp"

namespace planecell::services {
namespace {

/// Touches `bytes` of fresh memory (a write per page) so that the kernel must map new pages.
std::unique_ptr<char[]> touch_new_pages(std::size_t bytes) {
  std::unique_ptr<char[]> block(new char[bytes]);
  for (std::size_t i = 0; i < bytes; i += 4096) block[i] = static_cast<char>(i);
  return block;
}

TEST(ThreadUsageTest, CountsThisThreadsCpuTimeAndFirstTouchFaults) {
  const ThreadUsage before = thread_usage();
  volatile double sink = 0.0;
  for (int i = 0; i < 20'000'000; ++i) sink = sink + 1e-9 * i;  // some ms of CPU
  const auto block = touch_new_pages(std::size_t{64} << 20);    // mmap'd: 16384 new 4 kB pages
  const ThreadUsage after = thread_usage();
  EXPECT_GT(after.cpu_ms, before.cpu_ms);
  EXPECT_GE(after.minor_faults - before.minor_faults, 16);  // 32 with 2 MB transparent huge pages
}

TEST(StageCostLogTest, SummarisesEveryStageRunOfEveryFrame) {
  StageCostLog log;
  for (int frame = 0; frame < 4; ++frame) {
    FrameWork work;
    work.stage_cost = {{"sgm", StageCost{10.0 + frame, 100}},
                       {"extract", StageCost{5.0, 2 * frame}}};
    log.add(work);
  }
  const auto summaries = log.summaries();
  ASSERT_EQ(summaries.size(), 2u);
  EXPECT_EQ(summaries[0].first, "sgm");  // order of first appearance
  EXPECT_EQ(summaries[0].second.cpu.count, 4u);
  EXPECT_DOUBLE_EQ(summaries[0].second.cpu.mean_ms, 11.5);
  EXPECT_DOUBLE_EQ(summaries[0].second.minor_faults_mean, 100.0);
  EXPECT_EQ(summaries[1].first, "extract");
  EXPECT_DOUBLE_EQ(summaries[1].second.minor_faults_mean, 3.0);  // (0 + 2 + 4 + 6) / 4
}

TEST(FrameWorkTest, TimedRecordsWallTimeAndCostUnderTheStageName) {
  FrameWork work;
  work.timed("busy", [] { touch_new_pages(std::size_t{8} << 20); });
  ASSERT_EQ(work.stage_ms.size(), 1u);
  ASSERT_EQ(work.stage_cost.size(), 1u);
  EXPECT_EQ(work.stage_cost[0].first, "busy");
  EXPECT_GE(work.stage_ms[0].second, 0.0);
  EXPECT_GE(work.stage_cost[0].second.cpu_ms, 0.0);
  EXPECT_GE(work.stage_cost[0].second.minor_faults, 0);
}

TEST(ProcessMemoryTest, ResidentSetGrowsWithTouchedMemory) {
  const std::size_t before = resident_bytes();
  ASSERT_GT(before, 0u);
  const auto block = touch_new_pages(std::size_t{64} << 20);
  const std::size_t after = resident_bytes();
  EXPECT_GE(after, before + (std::size_t{48} << 20));
  EXPECT_GE(peak_resident_bytes(), before + (std::size_t{48} << 20));
}

TEST(HeapTuningTest, RejectsANegativeRetentionAndAcceptsZero) {
  PipelineConfig config;
  config.heap_retain_mb = -1;
  EXPECT_THROW(apply_heap_config(config), ConfigError);
  EXPECT_TRUE(retain_freed_heap(0));  // 0: the allocator's defaults, nothing to change
}

// The sanitizers replace malloc: glibc's settings do not apply there (retain_freed_heap says so).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define PLANECELL_SANITIZED_MALLOC 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define PLANECELL_SANITIZED_MALLOC 1
#endif
#endif

TEST(HeapTuningTest, RetainedHeapIsReusedWithoutNewFaults) {
#if defined(__GLIBC__) && !defined(PLANECELL_SANITIZED_MALLOC)
  ASSERT_TRUE(retain_freed_heap(std::size_t{256} << 20));
  // A frame-sized buffer allocated, touched and freed twice: the second time it comes back from
  // the kept heap, already mapped.
  touch_new_pages(std::size_t{12} << 20);
  const ThreadUsage before = thread_usage();
  touch_new_pages(std::size_t{12} << 20);
  const ThreadUsage after = thread_usage();
  EXPECT_LT(after.minor_faults - before.minor_faults, 100);  // 12 MB would be 3072 new pages
#else
  GTEST_SKIP() << "glibc allocator settings only (not under a sanitizer's malloc)";
#endif
}

TEST(SingleThreadedReplayTest, PublishSinkSeesEveryFrameWithItsDeltaInOrder) {
  test::ScratchDir scratch;
  test::write_small_street(scratch / "seq", 3, 7);
  ReplayOptions options;
  options.sequence_dir = scratch / "seq";
  options.progress = false;
  options.sinks.want_delta = true;
  std::vector<std::pair<std::uint64_t, bool>> published;
  std::size_t added = 0;
  options.sinks.publish = [&](const FrameWork& work) {
    EXPECT_EQ(work.delta.frame_id, work.frame_id);
    added += work.delta.added_cells.size();
    published.emplace_back(work.frame_id, work.delta.settled);
  };
  const ReplayReport report = run_replay(options, test::small_street_config());
  // Every frame, then the settling after the last (map.settle_at_close).
  EXPECT_EQ(published, (std::vector<std::pair<std::uint64_t, bool>>{{0, false}, {1, false}, {2, false}, {2, true}}));
  EXPECT_GE(added, report.cells_in_map);  // every cell in the map was announced when added
}

}  // namespace
}  // namespace planecell::services
