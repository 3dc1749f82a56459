#include "services/pipeline/pipeline.hpp"

#include <opencv2/core.hpp>
#include <readerwriterqueue/readerwriterqueue.h>
#include <spdlog/spdlog.h>

#if defined(__linux__)
#include <pthread.h>
#endif

#include "core/error.hpp"
#include "io/map_store.hpp"
#include "mapping/voxel/voxel_map.hpp"

namespace planecell::services {
namespace {

/// Names the calling thread "pc-<stage>" (15 characters at most), so that top -H, htop and gdb
/// show which stage a busy thread runs. No-op off Linux.
void name_this_thread(const std::string& stage) {
#if defined(__linux__)
  pthread_setname_np(pthread_self(), ("pc-" + stage).substr(0, 15).c_str());
#else
  (void)stage;
#endif
}

}  // namespace

/// A bounded SPSC queue of frames: moodycamel::BlockingReaderWriterQueue for the hand-off. A null
/// item is the end marker. Two policies:
///  - blocking: a semaphore of free slots makes push() wait while `capacity` frames wait;
///  - drop-oldest (live ingest): push never blocks; pop() drops every frame that has `capacity` or
///    more newer frames waiting behind it, so the newest `capacity` frames survive. A stalled
///    consumer is bounded by kStallFactor × capacity waiting frames, beyond which the incoming
///    frame is dropped too.
class Pipeline::Queue {
 public:
  using Item = std::unique_ptr<FrameWork>;
  static constexpr std::size_t kStallFactor = 32;

  Queue(std::string name, std::size_t capacity, bool drop_oldest)
      : name_(std::move(name)),
        capacity_(capacity),
        drop_oldest_(drop_oldest),
        queue_(capacity + 1),
        free_slots_(static_cast<moodycamel::spsc_sema::LightweightSemaphore::ssize_t>(capacity)) {}

  const std::string& name() const { return name_; }
  /// Frames waiting (the end marker not counted).
  std::size_t size() const {
    const std::size_t n = queue_.size_approx(), marker = ended_.load() ? 1 : 0;
    return n > marker ? n - marker : 0;
  }
  std::size_t dropped() const { return dropped_.load(); }

  /// Frame: waits for a free slot (blocking policy). Null item: the end marker.
  void push(Item item) {
    if (!item) ended_.store(true);
    if (!drop_oldest_) free_slots_.wait();
    queue_.enqueue(std::move(item));
  }

  /// Drop-oldest policy: never blocks. Returns false (frame dropped) on a stalled consumer.
  bool push_dropping_oldest(Item item) {
    if (queue_.size_approx() >= kStallFactor * capacity_) {
      dropped_.fetch_add(1);
      return false;
    }
    queue_.enqueue(std::move(item));
    return true;
  }

  /// Blocks until an item arrives (drop-oldest: the oldest one still worth taking).
  Item pop() {
    for (;;) {
      Item item;
      queue_.wait_dequeue(item);
      if (!drop_oldest_) {
        free_slots_.signal();
        return item;
      }
      if (item && size() >= capacity_) {  // `capacity` newer frames wait: this one is stale
        dropped_.fetch_add(1);
        continue;
      }
      return item;
    }
  }

 private:
  std::string name_;
  std::size_t capacity_;
  bool drop_oldest_;
  moodycamel::BlockingReaderWriterQueue<Item> queue_;
  moodycamel::spsc_sema::LightweightSemaphore free_slots_;
  std::atomic<bool> ended_{false};
  std::atomic<std::size_t> dropped_{0};
};

Pipeline::Pipeline(const AppConfig& config, PipelineMode mode, map::GlobalMap map, io::MapStore* store,
                   voxel::VoxelMap* voxels, PipelineSinks sinks)
    : config_(config), mode_(mode), map_(std::move(map)), store_(store), voxels_(voxels), sinks_(std::move(sinks)) {
  if (config_.pipeline.queue_capacity < 1)
    throw ConfigError("pipeline.queue_capacity = " + std::to_string(config_.pipeline.queue_capacity) +
                      ": must be at least 1");
  if (config_.pipeline.sgm_threads < 0)
    throw ConfigError("pipeline.sgm_threads = " + std::to_string(config_.pipeline.sgm_threads) +
                      ": must be 0 (use sgm.threads) or positive");
  const auto& pc = config_.pipeline;
  if (pc.warm_up_width < 0 || pc.warm_up_height < 0 ||
      static_cast<double>(pc.warm_up_width) * pc.warm_up_height > config_.sgm.max_image_pixels)
    throw ConfigError("pipeline.warm_up_width x warm_up_height = " + std::to_string(pc.warm_up_width) + "x" +
                      std::to_string(pc.warm_up_height) + ": must be 0 (no warm-up) or a frame size within " +
                      "sgm.max_image_pixels");
  SgmConfig sgm = config_.sgm;
  if (config_.pipeline.sgm_threads > 0) sgm.threads = config_.pipeline.sgm_threads;

  // A live pipeline runs indefinitely: its refinement keeps only the record the next frame needs.
  if (config_.refine.enabled) refine_.emplace(config_.refine, mode_ == PipelineMode::kReplay);
  // Pose transform and the voxel baseline need the frame's final pose: with pose refinement it is
  // known only in the merge thread (refinement reads the map that thread writes), so they run
  // there, after it; without, in their own stage.
  const auto place = [this](FrameWork& w) {
    transform_stage(w);
    if (voxels_) voxel_stage(w, *voxels_, config_.voxel);
    if (sinks_.keep_images) return;
    // Later stages need only the world cells: free the images early.
    w.frame.left.release();
    w.frame.right.release();
    w.disparity.release();
    w.cells.labels.release();
    w.cells.dense_disparity.release();
    w.cells.outliers.release();
  };

  // The stage list: a new stage is one more entry.
  stages_.push_back({"sgm", [sgm](FrameWork& w) { sgm_stage(w, sgm); }, true});
  stages_.push_back({"extract", [this](FrameWork& w) { extract_stage(w, config_.extraction); }, true});
  stages_.push_back({"transform", [this, place](FrameWork& w) {
                       if (!refine_) place(w);
                     }});
  stages_.push_back({"merge", [this, place](FrameWork& w) {
                       if (refine_) {
                         refine_stage(w, *refine_, map_);
                         place(w);
                       }
                       const std::size_t every = sinks_.map_bytes_every;
                       merge_stage(w, map_, sinks_.want_delta, every > 0 && ++merged_frames_ % every == 0);
                       if (store_) store_stage(w, *store_, map_);
                       const std::lock_guard lock(stats_mutex_);
                       map_cells_ = map_.cells().size();
                       map_surfaces_ = map_.surfaces().size();
                       last_merged_frame_ = w.frame_id;
                     }});

  const auto capacity = static_cast<std::size_t>(config_.pipeline.queue_capacity);
  for (const auto& stage : stages_)
    queues_.push_back(std::make_unique<Queue>(stage.name, capacity, mode_ == PipelineMode::kLive && queues_.empty()));
  queues_.push_back(std::make_unique<Queue>("publish", capacity, false));
  for (std::size_t i = 0; i < stages_.size(); ++i) threads_.emplace_back([this, i] { stage_loop(i); });
  threads_.emplace_back([this] { publish_loop(); });
}

Pipeline::~Pipeline() {
  if (finished_) return;
  request_stop();
  for (auto& thread : threads_)
    if (thread.joinable()) thread.join();
}

void Pipeline::warm_up(int width, int height) {
  if (width < 1 || height < 1) return;
  FrameWork work;
  work.warm_up = true;
  cv::Mat texture(height, width + 16, CV_8UC3);
  cv::randu(texture, cv::Scalar::all(0), cv::Scalar::all(256));  // cv::theRNG's fixed seed
  work.frame.left = texture(cv::Rect(0, 0, width, height)).clone();
  work.frame.right = texture(cv::Rect(16, 0, width, height)).clone();
  work.frame.camera.width = width;
  work.frame.camera.height = height;
  {
    const std::lock_guard lock(ingest_mutex_);
    if (stop_requested_.load()) return;
    std::lock_guard warm_lock(warm_mutex_);
    warm_done_ = false;
    queues_.front()->push(std::make_unique<FrameWork>(std::move(work)));
  }
  std::unique_lock lock(warm_mutex_);
  warm_cv_.wait(lock, [this] { return warm_done_; });
}

bool Pipeline::submit(FrameWork work) {
  const std::lock_guard lock(ingest_mutex_);
  if (stop_requested_.load() || (mode_ == PipelineMode::kReplay && failed_.load())) return false;
  if (work.ingest_time == StageClock::time_point{}) work.ingest_time = StageClock::now();
  {
    const std::lock_guard stats_lock(stats_mutex_);
    ++frames_in_;
  }
  auto item = std::make_unique<FrameWork>(std::move(work));
  if (mode_ == PipelineMode::kReplay) {
    queues_.front()->push(std::move(item));
  } else {
    queues_.front()->push_dropping_oldest(std::move(item));  // a drop is counted by the queue
  }
  return true;
}

void Pipeline::request_stop() {
  const std::lock_guard lock(ingest_mutex_);
  if (stop_requested_.exchange(true)) return;
  queues_.front()->push(nullptr);
}

map::GlobalMap Pipeline::finish() {
  if (!finished_) {
    request_stop();
    for (auto& thread : threads_) thread.join();
    finished_ = true;
  }
  if (mode_ == PipelineMode::kReplay && error_) std::rethrow_exception(error_);
  return std::move(map_);
}

void Pipeline::fail(std::exception_ptr error, const FrameWork& work, const std::string& stage) {
  std::string what = "unknown error";
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    what = e.what();
  } catch (...) {
  }
  const std::lock_guard lock(stats_mutex_);
  if (mode_ == PipelineMode::kLive) {
    ++frames_failed_;
    spdlog::warn("pipeline: frame {} skipped, {} stage failed: {}", work.frame_id, stage, what);
    return;
  }
  if (!error_) {
    error_ = error;
    spdlog::debug("pipeline: frame {} failed in {}: {}; draining", work.frame_id, stage, what);
  }
  failed_.store(true);
}

void Pipeline::stage_loop(std::size_t index) {
  name_this_thread(stages_[index].name);
  Queue& in = *queues_[index];
  Queue& out = *queues_[index + 1];
  for (;;) {
    Queue::Item item = in.pop();
    if (!item) {
      out.push(nullptr);  // end marker: everything before it has been passed on
      return;
    }
    if (item->warm_up) {
      if (stages_[index].warms) {
        try {
          stages_[index].run(*item);
        } catch (const std::exception& e) {
          spdlog::debug("pipeline: warm-up frame failed in {}: {}", stages_[index].name, e.what());
        }
      }
      out.push(std::move(item));
      continue;
    }
    if (mode_ == PipelineMode::kReplay && failed_.load()) continue;  // drain without work
    try {
      stages_[index].run(*item);
    } catch (...) {
      fail(std::current_exception(), *item, stages_[index].name);
      continue;
    }
    out.push(std::move(item));
  }
}

void Pipeline::publish_loop() {
  name_this_thread("publish");
  Queue& in = *queues_.back();
  for (;;) {
    Queue::Item item = in.pop();
    if (!item) return;
    if (item->warm_up) {
      const std::lock_guard lock(warm_mutex_);
      warm_done_ = true;
      warm_cv_.notify_all();
      continue;
    }
    if (mode_ == PipelineMode::kReplay && failed_.load()) continue;
    if (sinks_.publish) {
      try {
        item->timed("publish", [&] { sinks_.publish(*item); });
      } catch (...) {
        fail(std::current_exception(), *item, "publish");
        continue;
      }
    }
    const double e2e_ms =
        std::chrono::duration<double, std::milli>(StageClock::now() - item->ingest_time).count();
    if (spdlog::should_log(spdlog::level::debug)) {
      std::string stages;
      for (const auto& [stage, ms] : item->stage_ms) stages += fmt::format(" {} {:.1f}", stage, ms);
      spdlog::debug("pipeline: frame {} done, end to end {:.1f} ms (stage ms:{})", item->frame_id, e2e_ms, stages);
    }
    const std::lock_guard lock(stats_mutex_);
    for (const auto& [stage, ms] : item->stage_ms) latency_.add(stage, ms);
    latency_.add("end_to_end", e2e_ms);
    costs_.add(*item);
    ++frames_done_;
  }
}

PipelineStats Pipeline::stats() const {
  PipelineStats out;
  for (const auto& queue : queues_) {
    out.queue_depths.emplace_back(queue->name(), queue->size());
    out.frames_dropped += queue->dropped();
  }
  const std::lock_guard lock(stats_mutex_);
  out.frames_in = frames_in_;
  out.frames_done = frames_done_;
  out.frames_failed = frames_failed_;
  out.latency = latency_.summaries();
  out.stage_cost = costs_.summaries();
  out.map_cells = map_cells_;
  out.map_surfaces = map_surfaces_;
  out.last_merged_frame = last_merged_frame_;
  return out;
}

}  // namespace planecell::services
