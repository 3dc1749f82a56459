/// `planecell run` — the streaming daemon: stereo frames and poses in over LCM, the threaded
/// pipeline (services/pipeline), map updates and stats out over LCM, the map in a store.
#include <spdlog/spdlog.h>

#include <chrono>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <span>

#include "core/error.hpp"
#include "io/map_store.hpp"
#include "services/commands/commands.hpp"
#include "services/pipeline/heap_tuning.hpp"
#include "services/pipeline/lcm_link.hpp"
#include "services/pipeline/pipeline.hpp"

namespace planecell::services {
namespace {

/// Pairs stereo frames with their poses (either may come first) and hands complete frames to the
/// pipeline in frame-id order. Runs on the LCM thread, the pipeline's ingest thread.
class Intake {
 public:
  Intake(Pipeline& pipeline, std::set<std::uint64_t> committed)
      : pipeline_(pipeline), committed_(std::move(committed)) {}

  void on_stereo(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
    try {
      // End-to-end latency counts from the message's arrival: the decode (PNG or raw) is the
      // "load" stage of a live frame.
      FrameWork work;
      work.ingest_time = StageClock::now();
      work.timed("load", [&] { work.frame = io::from_lcm(io::decode_stereo_frame(bytes(buffer))); });
      work.frame_id = work.frame.frame_id;
      check_order(work.frame_id, channel);
      if (frames_.size() >= kMaxWaiting) frames_.erase(frames_.begin());  // oldest never got a pose
      const auto id = work.frame_id;
      frames_[id] = std::move(work);
      try_submit(id);
    } catch (const InputError& e) {
      reject(channel, e.what());
    }
  }

  void on_pose(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
    try {
      const auto message = io::decode_pose(bytes(buffer));
      const Pose pose = io::from_lcm(message);
      const auto id = static_cast<std::uint64_t>(message.frame_id);
      check_order(id, channel);
      if (poses_.size() >= kMaxWaiting) poses_.erase(poses_.begin());
      poses_[id] = pose;
      try_submit(id);
    } catch (const InputError& e) {
      reject(channel, e.what());
    }
  }

  std::size_t rejected() const { return rejected_; }
  std::size_t resumed() const { return resumed_; }

 private:
  static constexpr std::size_t kMaxWaiting = 64;  ///< frames/poses waiting for their partner

  static std::span<const std::uint8_t> bytes(const lcm::ReceiveBuffer* buffer) {
    return {static_cast<const std::uint8_t*>(buffer->data), buffer->data_size};
  }
  void check_order(std::uint64_t id, const std::string& channel) const {
    if (last_submitted_ && id <= *last_submitted_)
      throw InputError(channel + ": frame " + std::to_string(id) + " arrived after frame " +
                       std::to_string(*last_submitted_) + " (out of order or repeated)");
  }
  void try_submit(std::uint64_t id) {
    auto frame = frames_.find(id);
    auto pose = poses_.find(id);
    if (frame == frames_.end() || pose == poses_.end()) return;
    FrameWork work = std::move(frame->second);
    work.frame.pose = pose->second;
    // Everything older than this frame is stale now.
    frames_.erase(frames_.begin(), std::next(frame));
    poses_.erase(poses_.begin(), std::next(pose));
    last_submitted_ = id;
    if (committed_.contains(id)) {  // already in the resumed store
      ++resumed_;
      return;
    }
    pipeline_.submit(std::move(work));
  }
  void reject(const std::string& channel, const std::string& what) {
    ++rejected_;
    spdlog::warn("run: skipped a message on {}: {}", channel, what);
  }

  Pipeline& pipeline_;
  std::set<std::uint64_t> committed_;
  std::map<std::uint64_t, FrameWork> frames_;  ///< decoded, waiting for their pose
  std::map<std::uint64_t, Pose> poses_;
  std::optional<std::uint64_t> last_submitted_;
  std::size_t rejected_ = 0, resumed_ = 0;
};

}  // namespace

void add_run_command(CLI::App& app, CommandContext& context) {
  auto* command = app.add_subcommand(
      "run",
      "The streaming daemon: takes stereo frames and poses over LCM, maps them with the threaded "
      "pipeline (one thread per stage, section 'pipeline' of the config) and broadcasts map updates "
      "and stats over LCM. SIGINT/SIGTERM stops intake, drains the pipeline, commits the map, exits 0.");
  struct Args {
    std::string lcm_url, map;
    std::size_t max_frames = 0;
  };
  auto args = std::make_shared<Args>();
  command->add_option("--lcm", args->lcm_url, "LCM URL (default: lcm.url of the config)");
  command->add_option("--map", args->map, "SQLite map store (resumes when it exists)");
  command->add_option("--max-frames", args->max_frames, "Stop by itself after this many frames (0 = never)");
  command->footer(
      "Channels (section 'lcm' of the config): PLANECELL_STEREO (stereo_frame_t) and PLANECELL_POSE\n"
      "(pose_t) in; PLANECELL_MAP_UPDATE (map_update_t, chunked < 60 kB) and PLANECELL_STATS\n"
      "(map_stats_t) out. A frame is mapped once its image pair and its pose have arrived; malformed\n"
      "and out-of-order messages are counted and skipped. Live mode: when frames come faster than\n"
      "they are mapped, the oldest waiting ones are dropped (counted in the stats).\n"
      "Example:\n"
      "  planecell run --map /tmp/live.db &\n"
      "  planecell feed /tmp/street --rate 10\n"
      "  planecell listen --count 20 --query 0,1,10");
  context.add(command, [args](const CommandContext& ctx) {
    AppConfig config = ctx.load_app_config();
    apply_heap_config(config.pipeline);  // per-frame buffers stay in the process (fewer faults)
    if (!args->lcm_url.empty()) config.lcm.url = args->lcm_url;
    auto lcm = open_lcm(config.lcm.url);

    std::unique_ptr<io::MapStore> store;
    map::GlobalMap map(config.map);
    std::set<std::uint64_t> committed;
    if (!args->map.empty()) {
      store = std::make_unique<io::MapStore>(args->map);
      if (store->frame_count() > 0) {
        map = io::load_map(*store, config.map);
        for (auto id : store->frame_ids()) committed.insert(id);
        spdlog::info("run: resuming map '{}' ({} frames, {} cells)", args->map, committed.size(), map.cells().size());
      }
    }

    PipelineSinks sinks;
    sinks.want_delta = true;
    sinks.publish = [&lcm, &config](const FrameWork& work) {
      const auto utime = now_utime();
      for (const auto& chunk : io::encode_map_update(work.delta, utime))
        publish_message(*lcm, config.lcm.map_update_channel, chunk);
    };
    Pipeline pipeline(config, PipelineMode::kLive, std::move(map), store.get(), nullptr, sinks);
    if (config.pipeline.warm_up_width > 0 && config.pipeline.warm_up_height > 0) {
      const auto start = std::chrono::steady_clock::now();
      pipeline.warm_up(config.pipeline.warm_up_width, config.pipeline.warm_up_height);
      spdlog::debug("run: warmed up with a {}x{} frame in {:.0f} ms", config.pipeline.warm_up_width,
                    config.pipeline.warm_up_height,
                    std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    }
    Intake intake(pipeline, committed);
    lcm->subscribe(config.lcm.stereo_channel, &Intake::on_stereo, &intake);
    lcm->subscribe(config.lcm.pose_channel, &Intake::on_pose, &intake);
    spdlog::info("run: listening on {} ({} + {}), publishing {} + {}", config.lcm.url, config.lcm.stereo_channel,
                 config.lcm.pose_channel, config.lcm.map_update_channel, config.lcm.stats_channel);

    const StopSignals signals;
    const auto period = std::chrono::duration<double>(std::max(0.05, config.pipeline.stats_period_s));
    auto next_stats = std::chrono::steady_clock::now() + period;
    auto publish_stats = [&] {
      publish_message(*lcm, config.lcm.stats_channel, to_lcm(pipeline.stats(), intake.rejected(), now_utime()));
    };
    while (!signals.requested()) {
      if (lcm->handleTimeout(50) < 0 && !signals.requested())  // a signal interrupts the wait
        throw InputError("LCM: receiving on '" + config.lcm.url + "' failed");
      if (args->max_frames > 0 && pipeline.stats().frames_in >= args->max_frames) break;
      if (std::chrono::steady_clock::now() >= next_stats) {
        publish_stats();
        next_stats += period;
      }
    }
    if (signals.requested()) spdlog::info("run: signal {}: draining the pipeline", signals.signal_number());
    map = pipeline.finish();  // intake stopped: drains, every frame is committed as it merges
    const PipelineStats stats = pipeline.stats();
    // Settled after the last frame in the map (map.settle_at_close), committed and published.
    std::optional<std::uint64_t> last_frame = stats.last_merged_frame;
    if (!last_frame && !committed.empty()) last_frame = *committed.rbegin();
    if (const auto settled = settle_stage(map, store.get(), last_frame))
      for (const auto& chunk : io::encode_map_update(make_delta(*settled, map), now_utime()))
        publish_message(*lcm, config.lcm.map_update_channel, chunk);
    close_store(store);       // compacts, closes: checkpoints the WAL into the database
    publish_stats();
    std::cout << "run: " << stats.frames_done << " frames mapped, " << stats.frames_dropped << " dropped, "
              << stats.frames_failed << " failed, " << intake.rejected() << " messages rejected";
    if (intake.resumed() > 0) std::cout << ", " << intake.resumed() << " already in the store";
    std::cout << "; map " << map.cells().size() << " cells, " << map.surfaces().size() << " surfaces\n";
    for (const auto& [stage, s] : stats.latency)
      std::cout << "  " << stage << ": p50 " << s.p50_ms << " ms, p99 " << s.p99_ms << " ms\n";
    return kExitOk;
  });
}

}  // namespace planecell::services
