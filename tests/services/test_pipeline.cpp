/// The threaded pipeline: same map as the single-threaded replay, live-mode dropping of stale
/// frames, clean stop mid-stream.
#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <mutex>

#include "core/error.hpp"
#include "io/kitti_odometry.hpp"
#include "io/map_store.hpp"
#include "services/pipeline/pipeline.hpp"
#include "services/replay.hpp"
#include "support/small_street.hpp"
#include "support/test_data.hpp"

namespace planecell::services {
namespace {

class PipelineTest : public ::testing::Test {
 protected:
  void SetUp() override {
    test::write_small_street(scratch_ / "seq", 6, 7);
    config_ = test::small_street_config();
    config_.pipeline.queue_capacity = 1;
  }
  ReplayOptions options(const std::string& map_name, bool threads) const {
    ReplayOptions o;
    o.sequence_dir = scratch_ / "seq";
    o.map_path = scratch_ / map_name;
    o.progress = false;
    o.threads = threads;
    return o;
  }
  test::ScratchDir scratch_;
  AppConfig config_;
};

TEST_F(PipelineTest, ThreadedReplayBuildsTheSameMapAsTheSingleThreadedOne) {
  AppConfig single_config = config_;
  single_config.sgm.threads = 1;  // the pipeline runs SGM on pipeline.sgm_threads = 2
  const ReplayReport single = run_replay(options("single.db", false), single_config);
  const ReplayReport threaded = run_replay(options("threaded.db", true), config_);
  EXPECT_EQ(threaded.frames, 6u);
  EXPECT_TRUE(threaded.threaded);
  EXPECT_EQ(threaded.cells_extracted, single.cells_extracted);
  EXPECT_EQ(threaded.cells_in_map, single.cells_in_map);
  EXPECT_EQ(threaded.surface_merges, single.surface_merges);
  EXPECT_GT(threaded.cells_in_map, 0u);
  const auto single_map = io::load_map(io::MapStore(scratch_ / "single.db"));
  const auto threaded_map = io::load_map(io::MapStore(scratch_ / "threaded.db"));
  EXPECT_TRUE(threaded_map.same_content(single_map));
  // Every stage and the end-to-end latency saw every frame.
  std::map<std::string, std::size_t> counts;
  for (const auto& [stage, summary] : threaded.stage_latency) counts[stage] = summary.count;
  for (const char* stage : {"load", "sgm", "extract", "transform", "merge", "store", "end_to_end"})
    EXPECT_EQ(counts[stage], 6u) << stage;
}

TEST_F(PipelineTest, ThreadedReplayReportsStageCostsAndMemoryOverFrames) {
  ReplayOptions o = options("costs.db", true);
  o.memory_sample_every = 2;
  const ReplayReport report = run_replay(o, config_);
  std::map<std::string, StageCostSummary> costs(report.stage_cost.begin(), report.stage_cost.end());
  for (const char* stage : {"load", "sgm", "extract", "transform", "merge", "store"}) {
    ASSERT_TRUE(costs.contains(stage)) << stage;
    EXPECT_EQ(costs[stage].cpu.count, 6u) << stage;
    EXPECT_GT(costs[stage].cpu.max_ms, 0.0) << stage;  // every stage burns some CPU on its thread
    EXPECT_GE(costs[stage].minor_faults_mean, 0.0) << stage;
  }
  // RSS before the first frame, after frames 2, 4 and 6 (the last sample is also the end).
  ASSERT_EQ(report.memory.size(), 4u);
  for (std::size_t i = 0; i < report.memory.size(); ++i) {
    EXPECT_EQ(report.memory[i].frames, 2 * i);
    EXPECT_GT(report.memory[i].rss_bytes, 0u);
    if (i > 0) {
      EXPECT_GE(report.memory[i].elapsed_s, report.memory[i - 1].elapsed_s);
      EXPECT_GT(report.memory[i].map_bytes, 0u);  // measured by the merge stage on that frame
    }
  }
  // The last sample is the map as the last frame left it; the report's is the settled map.
  EXPECT_EQ(report.memory.back().map_bytes, report.map_bytes_live);
  EXPECT_TRUE(report.settled);
  EXPECT_LT(report.map_bytes, report.map_bytes_live);
  EXPECT_GE(report.peak_rss_bytes, report.memory.back().rss_bytes);
}

TEST_F(PipelineTest, PacedThreadedReplayFeedsFramesAtTheRateAndBuildsTheSameMap) {
  ReplayOptions paced = options("paced.db", true);
  paced.rate_hz = 40.0;  // frame k of the run is due at k / 40 s: 6 frames take at least 125 ms
  paced.sinks.want_delta = true;
  std::vector<std::pair<std::uint64_t, bool>> published;
  paced.sinks.publish = [&](const FrameWork& work) {
    EXPECT_EQ(work.delta.frame_id, work.frame_id);
    published.emplace_back(work.frame_id, work.delta.settled);
  };
  const ReplayReport report = run_replay(paced, config_);
  EXPECT_EQ(report.rate_hz, 40.0);
  EXPECT_GE(report.wall_s, 5.0 / 40.0);
  // Every frame in order, then the settling after the last.
  EXPECT_EQ(published, (std::vector<std::pair<std::uint64_t, bool>>{
                           {0, false}, {1, false}, {2, false}, {3, false}, {4, false}, {5, false}, {5, true}}));
  run_replay(options("unpaced.db", false), config_);
  EXPECT_TRUE(io::load_map(io::MapStore(scratch_ / "paced.db"))
                  .same_content(io::load_map(io::MapStore(scratch_ / "unpaced.db"))));
}

TEST_F(PipelineTest, WarmUpRunsSgmAndExtractionWithoutMappingCountingOrPublishing) {
  const auto sequence = io::open_kitti_odometry(scratch_ / "seq");
  std::vector<std::uint64_t> published;
  PipelineSinks sinks;
  sinks.publish = [&](const FrameWork& work) { published.push_back(work.frame_id); };
  Pipeline pipeline(config_, PipelineMode::kReplay, map::GlobalMap(config_.map), nullptr, nullptr, sinks);
  pipeline.warm_up(sequence.camera.width, sequence.camera.height);  // returns once it went through
  PipelineStats stats = pipeline.stats();
  EXPECT_EQ(stats.frames_in, 0u);
  EXPECT_EQ(stats.frames_done, 0u);
  EXPECT_TRUE(stats.latency.empty());
  EXPECT_TRUE(published.empty());
  pipeline.warm_up(0, 0);  // nothing to warm: returns at once
  ASSERT_TRUE(pipeline.submit(load_stage(sequence, 0)));
  const map::GlobalMap map = pipeline.finish();
  EXPECT_EQ(published, (std::vector<std::uint64_t>{0}));
  // The map holds frame 0 only: the same as a fresh map given frame 0.
  FrameWork alone = load_stage(sequence, 0);
  sgm_stage(alone, [&] {
    SgmConfig sgm = config_.sgm;
    sgm.threads = config_.pipeline.sgm_threads;
    return sgm;
  }());
  extract_stage(alone, config_.extraction);
  transform_stage(alone);
  map::GlobalMap expected(config_.map);
  merge_stage(alone, expected, false);
  EXPECT_TRUE(map.same_content(expected));
  EXPECT_GT(map.cells().size(), 0u);
}

TEST_F(PipelineTest, ReplayRejectsANegativeRate) {
  ReplayOptions o = options("negative.db", true);
  o.rate_hz = -1.0;
  EXPECT_THROW(run_replay(o, config_), ConfigError);
}

TEST_F(PipelineTest, ThreadedReplayResumesAStoreLikeTheSingleThreadedRun) {
  config_.map.settle_at_close = false;  // stopped as a killed run is: the map as frame 2 left it
  ReplayOptions first_half = options("split.db", true);
  first_half.last_frame = 3;
  EXPECT_EQ(run_replay(first_half, config_).frames, 3u);
  const ReplayReport rest = run_replay(options("split.db", true), config_);
  EXPECT_EQ(rest.frames, 3u);
  EXPECT_EQ(rest.frames_resumed, 3u);
  run_replay(options("whole.db", false), config_);
  EXPECT_TRUE(io::load_map(io::MapStore(scratch_ / "split.db"), config_.map)
                  .same_content(io::load_map(io::MapStore(scratch_ / "whole.db"), config_.map)));
}

TEST_F(PipelineTest, LiveModeKeepsTheNewestFramesAndCountsTheDroppedOnes) {
  const auto sequence = io::open_kitti_odometry(scratch_ / "seq");
  std::vector<FrameWork> frames;
  for (std::size_t i = 0; i < 6; ++i) frames.push_back(load_stage(sequence, i));

  // The publish sink holds the first frame until every frame is submitted, so the pipeline backs
  // up: with capacity 1, at most 9 frames fit in the stages and their queues (5 queues, 4 stage
  // threads); more than that wait in the ingest queue where only the newest survives.
  std::mutex mutex;
  std::condition_variable released_cv;
  bool released = false;
  std::vector<std::uint64_t> published;
  PipelineSinks sinks;
  sinks.want_delta = true;
  sinks.publish = [&](const FrameWork& work) {
    std::unique_lock lock(mutex);
    released_cv.wait(lock, [&] { return released; });
    published.push_back(work.frame_id);
    EXPECT_EQ(work.delta.frame_id, work.frame_id);
  };
  Pipeline pipeline(config_, PipelineMode::kLive, map::GlobalMap(config_.map), nullptr, nullptr, sinks);
  constexpr std::uint64_t kSubmitted = 16;
  for (std::uint64_t id = 0; id < kSubmitted; ++id) {
    FrameWork work = frames[id % frames.size()];  // cv::Mat copies share pixels: fine, read-only
    work.frame_id = id;
    work.ingest_time = {};
    ASSERT_TRUE(pipeline.submit(std::move(work)));
  }
  {
    const std::lock_guard lock(mutex);
    released = true;
  }
  released_cv.notify_all();
  pipeline.request_stop();
  EXPECT_FALSE(pipeline.submit(FrameWork{}));  // no intake after a stop request
  pipeline.finish();
  const PipelineStats stats = pipeline.stats();
  EXPECT_EQ(stats.frames_in, kSubmitted);
  EXPECT_EQ(stats.frames_failed, 0u);
  EXPECT_EQ(stats.frames_done + stats.frames_dropped, kSubmitted);
  EXPECT_GE(stats.frames_dropped, kSubmitted - 10);
  ASSERT_EQ(published.size(), stats.frames_done);
  for (std::size_t i = 1; i < published.size(); ++i) EXPECT_LT(published[i - 1], published[i]);
  EXPECT_EQ(published.back(), kSubmitted - 1);  // the newest frame is never the one dropped
  for (const auto& [queue, depth] : stats.queue_depths) EXPECT_EQ(depth, 0u) << queue;
}

TEST_F(PipelineTest, LiveModeSkipsAFrameThatFailsAndKeepsGoing) {
  const auto sequence = io::open_kitti_odometry(scratch_ / "seq");
  AppConfig config = config_;
  config.pipeline.queue_capacity = 8;  // nothing dropped
  Pipeline pipeline(config, PipelineMode::kLive, map::GlobalMap(config.map), nullptr, nullptr);
  for (std::size_t i = 0; i < 3; ++i) {
    FrameWork work = load_stage(sequence, i);
    if (i == 1) work.frame.pose.reset();  // no pose: the transform stage rejects it
    pipeline.submit(std::move(work));
  }
  const map::GlobalMap map = pipeline.finish();
  const PipelineStats stats = pipeline.stats();
  EXPECT_EQ(stats.frames_failed, 1u);
  EXPECT_EQ(stats.frames_done, 2u);
  EXPECT_EQ(stats.frames_dropped, 0u);
  EXPECT_GT(map.cells().size(), 0u);
}

TEST_F(PipelineTest, StopMidStreamLeavesAStoreThatReopens) {
  const auto sequence = io::open_kitti_odometry(scratch_ / "seq");
  std::size_t committed = 0;
  {
    io::MapStore store(scratch_ / "stopped.db");
    Pipeline pipeline(config_, PipelineMode::kReplay, map::GlobalMap(config_.map), &store, nullptr);
    for (std::size_t i = 0; i < 3; ++i) ASSERT_TRUE(pipeline.submit(load_stage(sequence, i)));
    pipeline.request_stop();  // frames 3.. never enter; 0..2 drain
    EXPECT_FALSE(pipeline.submit(load_stage(sequence, 3)));
    const map::GlobalMap map = pipeline.finish();
    committed = map.cells().size();
    EXPECT_EQ(pipeline.stats().frames_done, 3u);
  }
  const io::MapStore reopened(scratch_ / "stopped.db");
  EXPECT_EQ(reopened.frame_count(), 3u);
  EXPECT_EQ(io::load_map(reopened).cells().size(), committed);
}

TEST_F(PipelineTest, ReplayStopsAtABadFrameWithTheEarlierFramesStored) {
  // Frame 4's left image is unreadable: frames 0..3 are mapped and stored, then the error.
  const auto sequence = io::open_kitti_odometry(scratch_ / "seq");
  const auto left = sequence.left_images.at(4);
  std::filesystem::resize_file(left, 10);
  EXPECT_THROW(run_replay(options("bad.db", true), config_), InputError);
  EXPECT_EQ(io::MapStore(scratch_ / "bad.db").frame_count(), 4u);
}

TEST(PipelineConfigTest, RejectsAnEmptyQueue) {
  AppConfig config;
  config.pipeline.queue_capacity = 0;
  EXPECT_THROW(Pipeline(config, PipelineMode::kReplay, map::GlobalMap(config.map), nullptr, nullptr),
               ConfigError);
}

TEST(PipelineConfigTest, RejectsANegativeOrOversizedWarmUpFrame) {
  for (const auto& [width, height] : {std::pair{-1, 375}, std::pair{1242, -1}, std::pair{100000, 100000}}) {
    AppConfig config;
    config.pipeline.warm_up_width = width;
    config.pipeline.warm_up_height = height;
    try {
      Pipeline(config, PipelineMode::kLive, map::GlobalMap(config.map), nullptr, nullptr);
      ADD_FAILURE() << width << "x" << height << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("pipeline.warm_up_width"), std::string::npos) << e.what();
    }
  }
  AppConfig off;
  off.pipeline.warm_up_width = 0;  // 0 turns the warm-up off and is fine
  EXPECT_NO_THROW(Pipeline(off, PipelineMode::kLive, map::GlobalMap(off.map), nullptr, nullptr).finish());
}

}  // namespace
}  // namespace planecell::services
