#pragma once
/// The threaded mapping pipeline: the stages of services/pipeline/stages, one thread each,
///
///   ingest (caller) → sgm → extract → transform (→ voxel) → merge (→ store) → publish
///
/// joined by bounded single-producer/single-consumer queues (moodycamel BlockingReaderWriterQueue
/// plus a free-slot semaphore for the bound). Frames leave in the order they entered, so the map is
/// the one the single-threaded replay builds from the same frames.
///
/// Threads: SGM runs PipelineConfig::sgm_threads workers, every other stage one thread; only SGM and
/// extract are heavy, so ~2 threads are busy at once; the rest mostly wait on their queue.
#include <atomic>
#include <condition_variable>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "core/config/app_config.hpp"
#include "mapping/map/global_map.hpp"
#include "services/latency_stats.hpp"
#include "services/pipeline/stage_cost_log.hpp"
#include "services/pipeline/stages.hpp"
#include "services/refine_stage.hpp"

namespace planecell::io {
class MapStore;
}
namespace planecell::voxel {
class VoxelMap;
}

namespace planecell::services {

enum class PipelineMode {
  kReplay,  ///< submit() blocks while the first queue is full; a failing frame stops the pipeline
  kLive,    ///< submit() never blocks: the sgm stage takes only the newest queue_capacity waiting
            ///< frames and drops older ones (counted); a failing frame is counted, logged, skipped
};

/// Counters and latencies of a pipeline (a consistent copy; see Pipeline::stats).
struct PipelineStats {
  std::size_t frames_in = 0;       ///< submitted
  std::size_t frames_done = 0;     ///< through every stage
  std::size_t frames_dropped = 0;  ///< live mode: dropped waiting in the first queue
  std::size_t frames_failed = 0;   ///< live mode: a stage threw (frame skipped)
  std::vector<std::pair<std::string, std::size_t>> queue_depths;  ///< frames waiting per queue
  /// Per stage ("load" when given, "sgm", ..., "store", "voxel") and "end_to_end" (ingest → publish), ms.
  std::vector<std::pair<std::string, LatencySummary>> latency;
  /// Per stage: CPU time of its thread and page faults per frame (wall time minus waiting).
  std::vector<std::pair<std::string, StageCostSummary>> stage_cost;
  std::size_t map_cells = 0;  ///< after the last merged frame
  std::size_t map_surfaces = 0;
  std::optional<std::uint64_t> last_merged_frame;  ///< id of the last merged frame; none yet
};

/// Called on the publish thread with every finished frame (work.delta filled when
/// PipelineSinks::want_delta), in frame order.
using PublishFn = std::function<void(const FrameWork& work)>;

struct PipelineSinks {
  PublishFn publish;        ///< may be empty
  bool want_delta = false;  ///< merge stage copies its changes into FrameWork::delta
  /// The merge stage measures GlobalMap::map_bytes() into FrameWork::map_bytes on every n-th
  /// merged frame (O(cells): not every frame of a long run); 0 = never.
  std::size_t map_bytes_every = 0;
  /// Keep the frame's images, disparity and label images until publish (e.g. for a per-frame
  /// observer that scores them); by default the transform stage frees them.
  bool keep_images = false;
};

class Pipeline {
 public:
  /// Starts the stage threads. `map` is moved in (returned by finish()); `store` and `voxels` are
  /// optional and must outlive the pipeline. Throws ConfigError on queue_capacity < 1.
  Pipeline(const AppConfig& config, PipelineMode mode, map::GlobalMap map, io::MapStore* store,
           voxel::VoxelMap* voxels, PipelineSinks sinks = {});
  /// Stops and joins (request_stop + finish) when still running.
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  /// Runs one synthetic width×height frame (a fixed random texture seen with a 16 px shift)
  /// through the sgm and extract stages on their own threads and waits for it: the first-frame
  /// costs (buffers faulted in, OpenCV's colour tables, worker threads) are paid before the
  /// first real frame, whose latency then is a steady-state one. Not mapped, published or
  /// counted; a stage error is logged (debug) and not kept. Call before the first submit().
  void warm_up(int width, int height);

  /// Hands one frame to the sgm stage (call from one thread only: the ingest thread). Replay
  /// mode blocks while the queue is full. Returns false (frame not taken) after request_stop()
  /// or once the pipeline failed.
  bool submit(FrameWork work);

  /// No more input: frames already submitted are drained through every stage. Idempotent; may
  /// be called from any thread (e.g. a signal watcher).
  void request_stop();

  /// request_stop(), waits for the drain, joins every thread and returns the map. In replay mode
  /// rethrows the first stage error (frames before the failing one were merged and stored).
  map::GlobalMap finish();

  /// Counters and latency percentiles so far (thread-safe).
  PipelineStats stats() const;

  /// The pose refinement's per-frame record (config refine.enabled), else nullptr. Read it after
  /// finish(): until then the merge thread writes it.
  const RefineStage* refinement() const { return refine_ ? &*refine_ : nullptr; }

  bool stopping() const { return stop_requested_.load(); }

 private:
  class Queue;
  /// One pipeline stage: its name (also its queue's) and what it does to a frame.
  struct Stage {
    std::string name;
    std::function<void(FrameWork&)> run;
    bool warms = false;  ///< runs on warm-up frames too
  };
  void stage_loop(std::size_t index);
  void publish_loop();
  /// Records a stage error: replay keeps the first and stops taking frames; live counts and logs.
  void fail(std::exception_ptr error, const FrameWork& work, const std::string& stage);

  AppConfig config_;
  PipelineMode mode_;
  map::GlobalMap map_;
  io::MapStore* store_;
  voxel::VoxelMap* voxels_;
  PipelineSinks sinks_;
  std::optional<RefineStage> refine_;  ///< used by the merge thread only

  std::vector<Stage> stages_;                    ///< sgm, extract, transform, merge (in order)
  std::vector<std::unique_ptr<Queue>> queues_;  ///< queues_[i] feeds stage i; the last feeds publish
  std::vector<std::thread> threads_;
  std::atomic<bool> stop_requested_{false};
  std::atomic<bool> failed_{false};
  std::mutex ingest_mutex_;  ///< serialises submit() with request_stop()'s end marker
  bool finished_ = false;
  std::exception_ptr error_;
  std::mutex warm_mutex_;
  std::condition_variable warm_cv_;
  bool warm_done_ = false;

  mutable std::mutex stats_mutex_;
  std::size_t frames_in_ = 0, frames_done_ = 0, frames_failed_ = 0;
  std::size_t map_cells_ = 0, map_surfaces_ = 0;
  std::optional<std::uint64_t> last_merged_frame_;
  std::size_t merged_frames_ = 0;  ///< merge thread only: frames merged (map_bytes_every)
  LatencyLog latency_;
  StageCostLog costs_;
};

}  // namespace planecell::services
