#include "services/replay.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <memory>
#include <unordered_map>
#include <unordered_set>
#include <set>
#include <sstream>
#include <thread>

#include "core/error.hpp"
#include "io/extraction_cache.hpp"
#include "services/config_loader.hpp"
#include "io/kitti_odometry.hpp"
#include "io/sequence_ground_truth.hpp"
#include "io/synthetic/synthetic_world.hpp"
#include "io/map_store.hpp"
#include "mapping/map/crf_merger.hpp"
#include "mapping/map/global_map.hpp"
#include "mapping/map/pose_transform.hpp"
#include "mapping/planecell/extraction.hpp"
#include "mapping/stereo/sgm.hpp"
#include "mapping/voxel/voxel_map.hpp"
#include "services/pipeline/process_memory.hpp"
#include "services/pipeline/stages.hpp"
#include "services/progress.hpp"

namespace planecell::services {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::size_t file_bytes(const std::filesystem::path& path) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  return ec ? 0 : static_cast<std::size_t>(size);
}

/// Camera-rate input: next() sleeps until frame k of the run is due (start + k / rate_hz) and
/// returns that due time; without a rate it returns now at once.
class Pacer {
 public:
  explicit Pacer(double rate_hz) : rate_hz_(rate_hz), start_(Clock::now()) {}
  bool paced() const { return rate_hz_ > 0.0; }
  /// Frame 0 is due now (after a warm-up).
  void restart() {
    start_ = Clock::now();
    k_ = 0;
  }
  Clock::time_point next() {
    if (!paced()) return Clock::now();
    const auto due = start_ + std::chrono::duration_cast<Clock::duration>(
                                  std::chrono::duration<double>(static_cast<double>(k_++) / rate_hz_));
    std::this_thread::sleep_until(due);
    return due;
  }

 private:
  double rate_hz_;
  Clock::time_point start_;
  std::size_t k_ = 0;
};

std::size_t parse_index(const std::string& text, const std::string& whole) {
  std::size_t used = 0;
  unsigned long long value = 0;
  try {
    value = std::stoull(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || text[0] == '-')
    throw ConfigError("--frames '" + whole + "': expected A:B with non-negative integers");
  return static_cast<std::size_t>(value);
}

/// The frame's ground-truth disparity (replay --gt-disparity). Throws InputError when the frame
/// has none.
cv::Mat gt_disparity_of(const io::KittiOdometrySequence& sequence, const FrameWork& work) {
  cv::Mat disparity = io::load_disparity_ground_truth(sequence, static_cast<std::size_t>(work.frame_id),
                                                      work.frame.left.cols, work.frame.left.rows);
  if (disparity.empty())
    throw InputError("replay: --gt-disparity: frame " + std::to_string(work.frame_id) +
                     " has no ground-truth disparity");
  return disparity;
}

/// 64-bit FNV-1a of `bytes`, continuing from `hash`.
std::uint64_t fnv1a(std::string_view bytes, std::uint64_t hash = 14695981039346656037ull) {
  for (unsigned char ch : bytes) hash = (hash ^ ch) * 1099511628211ull;
  return hash;
}

/// What the extraction products of a replay depend on, besides each frame's images: the SGM and
/// extraction configuration, the camera, and whether the disparity is the GT's.
std::uint64_t extraction_fingerprint(const AppConfig& config, const StereoCamera& camera, bool gt_disparity) {
  // The sections that produce the cells only: a new key or value elsewhere (map, voxel) keeps the cache.
  constexpr std::array<std::string_view, 2> kInputs{"sgm", "extraction"};
  std::ostringstream text;
  text.precision(17);
  text << config_to_yaml(config, kInputs) << camera.fx << ' ' << camera.fy << ' ' << camera.cx << ' ' << camera.cy << ' '
       << camera.baseline_m << ' ' << camera.width << ' ' << camera.height << ' ' << gt_disparity;
  return fnv1a(text.str());
}

/// extraction_fingerprint extended by frame `index`'s image files (path, size, modification time).
std::uint64_t frame_fingerprint(std::uint64_t base, const io::KittiOdometrySequence& sequence, std::size_t index) {
  std::ostringstream text;
  for (const auto& path : {sequence.left_images[index], sequence.right_images[index]}) {
    std::error_code ec;
    const auto size = std::filesystem::file_size(path, ec);
    const auto time = std::filesystem::last_write_time(path, ec).time_since_epoch().count();
    text << path.string() << ' ' << size << ' ' << time << '\n';
  }
  return fnv1a(text.str(), base);
}

/// Frame `index` without its images, for a frame whose extraction products come from the cache:
/// camera, timestamp and pose as load_kitti_frame gives them.
FrameWork cached_frame_work(const io::KittiOdometrySequence& sequence, std::size_t index) {
  FrameWork work;
  work.ingest_time = StageClock::now();
  work.frame_id = static_cast<std::uint64_t>(index);
  work.frame.frame_id = work.frame_id;
  work.frame.camera = sequence.camera;
  if (!sequence.times_s.empty()) work.frame.timestamp_s = sequence.times_s[index];
  if (!sequence.poses.empty()) work.frame.pose = sequence.poses[index];
  return work;
}

}  // namespace

std::pair<std::size_t, std::size_t> parse_frame_range(const std::string& text) {
  const auto colon = text.find(':');
  if (colon == std::string::npos)
    throw ConfigError("--frames '" + text + "': expected A:B, A: or :B (B exclusive)");
  const std::string a = text.substr(0, colon), b = text.substr(colon + 1);
  const std::size_t first = a.empty() ? 0 : parse_index(a, text);
  const std::size_t last = b.empty() ? std::numeric_limits<std::size_t>::max() : parse_index(b, text);
  if (last <= first) throw ConfigError("--frames '" + text + "': empty range (B must be > A)");
  return {first, last};
}

ReplayReport run_replay(const ReplayOptions& options, const AppConfig& config) {
  const auto start = Clock::now();
  const io::KittiOdometrySequence sequence =
      io::open_kitti_odometry(options.sequence_dir, options.poses_path);
  if (sequence.poses.empty())
    throw InputError("replay: sequence '" + options.sequence_dir.string() +
                     "' has no poses (give --poses FILE)");
  const std::size_t first = std::min(options.first_frame, sequence.size());
  const std::size_t last = std::min(options.last_frame, sequence.size());

  if (options.gt_disparity && options.threads)
    throw ConfigError("replay: --gt-disparity runs single-threaded only (drop --threads)");
  if (options.gt_disparity && !io::has_disparity_ground_truth(sequence))
    throw InputError("replay: --gt-disparity: sequence '" + options.sequence_dir.string() +
                     "' has no ground-truth disparity (disp_occ_0/)");
  if (options.extraction_cache_dir && (options.threads || options.voxel))
    throw ConfigError("replay: --extraction-cache runs single-threaded without --voxel (the voxel baseline "
                      "needs the SGM disparity the cache skips): drop --threads / --voxel");
  std::uint64_t cache_fingerprint = 0;
  if (options.extraction_cache_dir) {
    std::error_code ec;
    std::filesystem::create_directories(*options.extraction_cache_dir, ec);
    if (ec)
      throw StorageError("replay: extraction cache folder '" + options.extraction_cache_dir->string() +
                         "' cannot be created: " + ec.message());
    cache_fingerprint = extraction_fingerprint(config, sequence.camera, options.gt_disparity);
  }
  if (!(options.rate_hz >= 0.0))
    throw ConfigError("replay: rate " + std::to_string(options.rate_hz) + " Hz: must be >= 0");
  ReplayReport report;
  report.sequence = options.sequence_dir.string();
  report.voxel = options.voxel;
  report.rate_hz = options.rate_hz;

  std::unique_ptr<io::MapStore> store;
  map::GlobalMap global_map(config.map);
  std::set<std::uint64_t> committed;
  if (options.map_path) {
    store = std::make_unique<io::MapStore>(*options.map_path);
    if (store->frame_count() > 0) {
      global_map = io::load_map(*store, config.map);
      for (auto id : store->frame_ids()) committed.insert(id);
      spdlog::info("replay: resuming map '{}' with {} committed frames, {} cells",
                   options.map_path->string(), committed.size(), global_map.cells().size());
    }
  }
  std::unique_ptr<voxel::VoxelMap> voxel_map;
  if (options.voxel) voxel_map = std::make_unique<voxel::VoxelMap>(config.voxel);

  // The scene's surfaces (synthetic sequences), read once: the GT planes of the merge scores and
  // the GT polygons of the map accuracy.
  std::optional<std::vector<io::SyntheticSurface>> scene_surfaces;
  if (const auto scene = sequence.root / "scene.yaml"; std::filesystem::exists(scene)) {
    try {
      scene_surfaces = io::read_scene_surfaces(scene);
    } catch (const InputError& e) {
      spdlog::warn("replay: {}; map accuracy not scored, cross-merging counted per GT surface only", e.what());
    }
  }
  std::optional<eval::MergeEvaluator> merge_evaluator;
  if (io::has_surface_ground_truth(sequence)) {
    merge_evaluator.emplace();
    // Coplanar touching GT surfaces form one GT plane for the cross-merge count. Without a
    // readable scene.yaml, every surface is its own.
    if (scene_surfaces) {
      const auto& surfaces = *scene_surfaces;
      merge_evaluator->set_gt_planes(eval::coplanar_groups(surfaces));
      std::unordered_map<std::uint16_t, Plane3> planes;
      std::unordered_map<std::uint16_t, io::SurfaceKind> kinds;
      std::unordered_set<std::uint16_t> weak_texture;
      for (const auto& surface : surfaces) {
        planes.emplace(surface.id, surface.plane);
        kinds.emplace(surface.id, surface.kind);
        if (io::is_weakly_textured(surface.texture)) weak_texture.insert(surface.id);
      }
      merge_evaluator->set_gt_surface_planes(std::move(planes));
      merge_evaluator->set_gt_kinds(std::move(kinds));
      merge_evaluator->set_gt_weak_texture(std::move(weak_texture));
    }
  }
  const std::vector<eval::GtPolygon> gt_polygons =
      scene_surfaces ? eval::gt_polygons(*scene_surfaces) : std::vector<eval::GtPolygon>{};
  // The sequence's own poses, read once: ground truth of the map completeness and of the
  // refinement's trajectory metrics.
  const bool has_gt_disparity = io::has_disparity_ground_truth(sequence);
  std::optional<std::pair<std::filesystem::path, std::vector<Pose>>> truth;
  if (has_gt_disparity || config.refine.enabled) truth = sequence_ground_truth(options.sequence_dir);
  // Map completeness (sequences with GT disparity and their own pose file): GT points of every
  // kCompletenessFrameStride-th frame, in the world by the GT pose, scored against the final map.
  bool score_completeness = truth && has_gt_disparity;
  std::vector<Eigen::Vector3d> completeness_points;
  // Pose refinement (issue 9): on this thread here; threaded, in the pipeline's merge stage, whose
  // record is copied here once it has finished.
  std::optional<RefineStage> refinement;
  if (config.refine.enabled && !options.threads) refinement.emplace(config.refine);

  double plane_fraction_sum = 0.0;
  /// The last frame in the map (this run's or the store's): the map is settled after it.
  std::optional<std::uint64_t> last_mapped;
  if (!committed.empty()) last_mapped = *committed.rbegin();
  auto sample_memory = [&](std::size_t map_bytes) {
    report.memory.push_back({report.frames, ms_since(start) / 1000.0, resident_bytes(), map_bytes});
  };
  if (options.memory_sample_every > 0) sample_memory(global_map.map_bytes());
  ProgressBar progress("replay", last > first ? last - first : 0);
  // Per-frame bookkeeping, on the calling thread (single-threaded) or the publish thread.
  auto account = [&](const FrameWork& work) {
    if (merge_evaluator && !work.cells.labels.empty()) {  // the threaded pipeline drops labels early
      try {  // an unreadable GT file ends the merge scores, not the replay
        const cv::Mat ids = io::load_surface_ids(sequence, work.frame_id, work.cells.labels.cols,
                                                 work.cells.labels.rows);
        if (!ids.empty()) merge_evaluator->add_frame(work.cells.labels, ids, work.world_cells, work.merge);
      } catch (const InputError& e) {
        spdlog::warn("replay: merging not scored against ground truth: {}", e.what());
        merge_evaluator.reset();
      }
    }
    if (score_completeness && work.frame_id % kCompletenessFrameStride == 0 && work.frame_id < truth->second.size()) {
      try {  // an unreadable GT file ends the score, not the replay
        // --gt-disparity: the frame was mapped from its GT disparity, already loaded.
        const cv::Mat gt = options.gt_disparity && !work.disparity.empty()
                               ? work.disparity
                               : io::load_disparity_ground_truth(sequence, static_cast<std::size_t>(work.frame_id),
                                                                 sequence.camera.width, sequence.camera.height);
        if (!gt.empty()) {
          const auto points = eval::gt_points_world(gt, sequence.camera, truth->second[work.frame_id],
                                                    kCompletenessPixelStride, kCompletenessMaxDepthM);
          completeness_points.insert(completeness_points.end(), points.begin(), points.end());
        }
      } catch (const InputError& e) {
        spdlog::warn("replay: map completeness not scored: {}", e.what());
        score_completeness = false;
        completeness_points.clear();
      }
    }
    ++report.frames;
    last_mapped = std::max(last_mapped.value_or(0), work.frame_id);
    report.cells_extracted += work.cells.cells.size();
    report.fused_cells += work.merge.fused_cells;
    report.redundant_cells += work.merge.redundant_cells;
    report.prefused_cells += work.merge.prefused_cells;
    report.replaced_cells += work.merge.replaced_cells;
    report.consolidated_cells += work.merge.consolidated_cells;
    report.pruned_surfaces += work.merge.pruned_surfaces.size();
    report.merge_ms.push_back(work.merge.merge_ms);
    report.surface_merges += work.merge.surface_merges.size();
    plane_fraction_sum += work.cells.plane_fraction;
    if (work.map_bytes) sample_memory(*work.map_bytes);  // merge measured it: a sampled frame
    if (options.progress)
      progress.update(work.frame_id + 1 - first, "cells " + std::to_string(work.map_cells));
  };

  Pacer pacer(options.rate_hz);
  // Loads frame `index` once it is due (paced: end-to-end latency counts from the due time).
  auto load_when_due = [&](std::size_t index) {
    const auto due = pacer.next();
    FrameWork work = load_stage(sequence, index);
    if (pacer.paced()) work.ingest_time = due;
    return work;
  };
  if (!options.threads) {
    LatencyLog latency;
    StageCostLog costs;
    for (std::size_t index = first; index < last; ++index) {
      if (committed.contains(static_cast<std::uint64_t>(index))) {
        ++report.frames_resumed;
        continue;
      }
      std::optional<std::filesystem::path> cache_path;
      std::optional<extraction::PlanecellFrame> cached;
      std::uint64_t fingerprint = 0;
      if (options.extraction_cache_dir) {
        cache_path = io::extraction_cache_path(*options.extraction_cache_dir, index);
        fingerprint = frame_fingerprint(cache_fingerprint, sequence, index);
        cached = io::read_extraction_cache(*cache_path, fingerprint, index);
      }
      FrameWork work;
      if (cached) {
        work = cached_frame_work(sequence, index);
        work.cells = std::move(*cached);
        ++report.frames_from_extraction_cache;
      } else {
        work = load_when_due(index);
        if (options.gt_disparity)
          work.timed("gt_disparity", [&] { work.disparity = gt_disparity_of(sequence, work); });
        else
          sgm_stage(work, config.sgm);
        extract_stage(work, config.extraction);
        if (cache_path) io::write_extraction_cache(*cache_path, fingerprint, index, work.cells);
      }
      if (refinement) refine_stage(work, *refinement, global_map);
      transform_stage(work);
      const std::size_t every = options.memory_sample_every;
      merge_stage(work, global_map, options.sinks.want_delta, every > 0 && (report.frames + 1) % every == 0);
      if (store) store_stage(work, *store, global_map);
      if (voxel_map) voxel_stage(work, *voxel_map, config.voxel);
      if (options.sinks.publish) work.timed("publish", [&] { options.sinks.publish(work); });
      for (const auto& [stage, ms] : work.stage_ms) latency.add(stage, ms);
      costs.add(work);
      account(work);
      if (options.observe) options.observe(work);
    }
    report.stage_latency = latency.summaries();
    report.stage_cost = costs.summaries();
  } else {
    report.threaded = true;
    PipelineSinks sinks = options.sinks;
    const PublishFn user_publish = sinks.publish;
    sinks.publish = [&, user_publish](const FrameWork& work) {
      if (user_publish) user_publish(work);
      account(work);
      if (options.observe) options.observe(work);
    };
    if (options.observe) sinks.keep_images = true;
    sinks.map_bytes_every = options.memory_sample_every;
    Pipeline pipeline(config, PipelineMode::kReplay, std::move(global_map), store.get(), voxel_map.get(),
                      std::move(sinks));
    // First-frame costs are paid on a synthetic frame before the clock of the first real one.
    pipeline.warm_up(sequence.camera.width, sequence.camera.height);
    pacer.restart();
    try {
      for (std::size_t index = first; index < last; ++index) {
        if (committed.contains(static_cast<std::uint64_t>(index))) {
          ++report.frames_resumed;
          continue;
        }
        if (!pipeline.submit(load_when_due(index))) break;  // a stage failed: drain
      }
    } catch (...) {
      pipeline.finish();  // frames loaded before the bad one are mapped and stored
      throw;
    }
    global_map = pipeline.finish();
    if (const RefineStage* record = pipeline.refinement()) refinement = *record;
    const PipelineStats stats = pipeline.stats();
    report.stage_latency = stats.latency;
    report.stage_cost = stats.stage_cost;
  }
  progress.finish();
  // The map as the last frame left it, then settled (map.settle_at_close) and committed.
  report.map_bytes_live = global_map.map_bytes();
  if (const auto settled = settle_stage(global_map, store.get(), last_mapped)) {
    report.settled = true;
    report.consolidated_cells += settled->consolidated_cells;
    report.pruned_surfaces += settled->pruned_surfaces.size();
    report.surface_merges += settled->surface_merges.size();
    if (merge_evaluator) merge_evaluator->add_map_changes(*settled);
    if (options.sinks.publish) {  // the map's consumers follow the settling like a frame
      FrameWork work;
      work.frame_id = settled->frame_id;
      work.merge = *settled;
      if (options.sinks.want_delta) work.delta = make_delta(work.merge, global_map);
      work.map_cells = global_map.cells().size();
      options.sinks.publish(work);
    }
  }
  report.map_parts = global_map.map_bytes_by_part();
  report.map_bytes = report.map_parts.total();
  if (options.memory_sample_every > 0 && (report.memory.empty() || report.memory.back().frames != report.frames))
    sample_memory(report.map_bytes);
  // The kernel's high-water mark (ru_maxrss) is updated lazily and can trail a later sample.
  report.peak_rss_bytes = peak_resident_bytes();
  for (const auto& sample : report.memory)
    report.peak_rss_bytes = std::max(report.peak_rss_bytes, sample.rss_bytes);

  report.plane_fraction = report.frames > 0 ? plane_fraction_sum / static_cast<double>(report.frames) : 0.0;
  report.cells_in_map = global_map.cells().size();
  report.surfaces = global_map.surfaces().size();
  report.dormant_surfaces = map::dormant_surface_count(global_map);
  const std::size_t frames_in_map = report.frames + committed.size();
  report.bytes_per_frame =
      frames_in_map > 0 ? static_cast<double>(report.map_bytes) / static_cast<double>(frames_in_map) : 0.0;
  if (store) {
    const auto path = store->path();
    report.store_parts =
        close_store(store);  // compacts, closes: checkpoints the WAL into the database
    report.store_bytes = file_bytes(path) + file_bytes(path.string() + "-wal");
  }
  if (voxel_map) {
    const auto stats = voxel_map->stats();
    report.voxel_bytes = stats.memory_bytes;
    report.voxel_ot_bytes = stats.ot_bytes;
    report.voxel_bt_bytes = stats.bt_bytes;
    report.voxel_leaves = stats.occupied_voxels;
    report.voxel_mode = config.voxel.ray_casting ? "insertPointCloud (free-space ray casting)"
                                                 : "per-voxel updateNode + integrateNodeColor, no ray casting";
  }
  if (merge_evaluator) {
    const auto metrics = merge_evaluator->finish();
    if (metrics.cells > 0) report.merge_metrics = metrics;  // none from --threads (labels dropped)
  }
  if (!completeness_points.empty()) report.map_completeness = eval::map_completeness(global_map, completeness_points);
  if (!gt_polygons.empty()) report.map_accuracy = eval::map_accuracy(global_map, gt_polygons);
  if (voxel_map && (!gt_polygons.empty() || !completeness_points.empty())) {
    const std::vector<Eigen::Vector3d> centres = voxel_map->occupied_centres();
    if (!gt_polygons.empty()) report.voxel_accuracy = eval::voxel_accuracy(centres, gt_polygons);
    if (!completeness_points.empty())
      report.voxel_completeness = eval::voxel_completeness(centres, voxel_map->resolution_m(), completeness_points);
  }
  if (refinement) {  // pose refinement (issue 9): ground truth = the sequence's own poses
    report.refine = truth ? refinement->summary(truth->second, truth->first)
                          : refinement->summary({}, std::nullopt);
  }
  report.wall_s = ms_since(start) / 1000.0;
  report.frames_per_s = report.wall_s > 0.0 ? static_cast<double>(report.frames) / report.wall_s : 0.0;
  return report;
}

std::optional<VoxelComparison> compare_with_voxel(const ReplayReport& r) {
  if (!r.voxel || r.map_bytes == 0) return std::nullopt;
  VoxelComparison c;
  c.ram_times_smaller = static_cast<double>(r.voxel_bytes) / static_cast<double>(r.map_bytes);
  if (r.store_bytes > 0) {
    c.store_times_smaller_than_ot =
        static_cast<double>(r.voxel_ot_bytes) / static_cast<double>(r.store_bytes);
    if (r.voxel_bt_bytes > 0)
      c.store_over_bt = static_cast<double>(r.store_bytes) / static_cast<double>(r.voxel_bt_bytes);
  }
  return c;
}

nlohmann::json to_json(const ReplayReport& r) {
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& [name, s] : r.stage_latency)
    stages[name] = {{"count", s.count}, {"p50_ms", s.p50_ms}, {"p95_ms", s.p95_ms},
                    {"p99_ms", s.p99_ms}, {"max_ms", s.max_ms}, {"mean_ms", s.mean_ms}};
  nlohmann::json out = {{"sequence", r.sequence},
                        {"frames", r.frames},
                        {"frames_resumed", r.frames_resumed},
                        {"frames_from_extraction_cache", r.frames_from_extraction_cache},
                        {"cells_extracted", r.cells_extracted},
                        {"plane_fraction", r.plane_fraction},
                        {"cells", r.cells_in_map},
                        {"surfaces", r.surfaces},
                        {"dormant_surfaces", r.dormant_surfaces},
                        {"fused_cells", r.fused_cells},
                        {"redundant_cells", r.redundant_cells},
                        {"prefused_cells", r.prefused_cells},
                        {"replaced_cells", r.replaced_cells},
                        {"consolidated_cells", r.consolidated_cells},
                        {"pruned_surfaces", r.pruned_surfaces},
                        {"surface_merges", r.surface_merges},
                        {"map_bytes", r.map_bytes},
                        {"map_bytes_live", r.map_bytes_live},
                        {"settled", r.settled},
                        {"store_bytes", r.store_bytes},
                        {"bytes_per_frame", r.bytes_per_frame},
                        {"stage_latency", stages},
                        {"wall_s", r.wall_s},
                        {"threaded", r.threaded},
                        {"frames_per_s", r.frames_per_s},
                        {"rate_hz", r.rate_hz}};
  nlohmann::json costs = nlohmann::json::object();
  for (const auto& [name, c] : r.stage_cost)
    costs[name] = {{"cpu_p50_ms", c.cpu.p50_ms}, {"cpu_p95_ms", c.cpu.p95_ms},
                   {"cpu_mean_ms", c.cpu.mean_ms}, {"minor_faults_mean", c.minor_faults_mean}};
  out["stage_cost"] = costs;
  const map::MapBytes& ram = r.map_parts;
  out["map_bytes_by_part"] = {{"cells", ram.cells},
                              {"vertices", ram.vertices},
                              {"surfaces", ram.surfaces},
                              {"footprints", ram.footprints},
                              {"index", ram.index}};
  if (r.store_parts) {
    const io::StoreBytes& disk = *r.store_parts;
    out["store_bytes_by_part"] = {{"cells", disk.cells},       {"cell_bounds_rtree", disk.bounds},
                                  {"surfaces", disk.surfaces}, {"frames", disk.frames},
                                  {"merges", disk.merges},     {"schema", disk.other},
                                  {"free", disk.free}};
  }
  constexpr double kMb = 1024.0 * 1024.0;
  nlohmann::json rss = nlohmann::json::array();
  for (const auto& m : r.memory)
    rss.push_back({{"frames", m.frames}, {"t_s", m.elapsed_s},
                   {"rss_mb", static_cast<double>(m.rss_bytes) / kMb},
                   {"map_mb", static_cast<double>(m.map_bytes) / kMb}});
  out["rss_mb"] = rss;
  out["merge_ms_per_frame"] = r.merge_ms;
  out["peak_rss_mb"] = static_cast<double>(r.peak_rss_bytes) / kMb;
  if (r.merge_metrics) {
    const auto& m = *r.merge_metrics;
    out["merge_vs_ground_truth"] = {
        {"cells", m.cells}, {"mixed_cells", m.mixed_cells}, {"gt_surfaces", m.gt_surfaces},
        {"labels", m.labels}, {"area_in_dominant_label", m.area_in_dominant_label},
        {"area_one_label", m.area_one_label}, {"cross_merged_cells", m.cross_merged_cells},
        {"cross_merged_cells_between_planes", m.cross_merged_cells_between_planes},
        {"cross_merged_cells_boundary", m.cross_merged_cells_boundary}};
    const auto share_json = [](const eval::MergeMetrics::KindShare& k) {
      return nlohmann::json{{"kind", k.kind}, {"gt_surfaces", k.gt_surfaces}, {"area", k.area},
                            {"area_one_label", k.one_label}, {"area_not_one_label", k.lost}};
    };
    auto by_kind = nlohmann::json::array();
    for (const auto& k : m.by_kind) by_kind.push_back(share_json(k));
    out["merge_vs_ground_truth"]["by_kind"] = by_kind;
    out["merge_vs_ground_truth"]["weak_texture"] = share_json(m.weak_texture);
    auto split = nlohmann::json::array();
    for (const auto& g : m.split_surfaces)
      split.push_back({{"gt", g.gt}, {"kind", g.kind}, {"area_m2", g.area_m2}, {"dominant_share", g.dominant_share},
                       {"labels", g.labels}, {"weak_texture", g.weak_texture}});
    out["merge_vs_ground_truth"]["largest_split_surfaces"] = split;
    auto crossed = nlohmann::json::array();
    for (const auto& c : m.crossed_by_kinds)
      crossed.push_back({{"own_kind", c.own_kind}, {"label_kind", c.label_kind}, {"cells", c.cells}});
    out["merge_vs_ground_truth"]["crossed_planes_by_kinds"] = crossed;
    auto by_fate = nlohmann::json::array();
    for (const auto& f : m.crossed_by_fate)
      by_fate.push_back({{"fate", f.fate}, {"cells", f.cells}, {"crossed", f.crossed}});
    out["merge_vs_ground_truth"]["crossed_planes_by_fate"] = by_fate;
    if (m.plane_error_cells > 0) {  // GT planes known
      out["merge_vs_ground_truth"]["cross_merged_cells_resolvable"] = m.cross_merged_cells_resolvable;
      out["cell_planes_vs_ground_truth"] = {
          {"cells", m.plane_error_cells}, {"rms_distance_median_m", m.plane_error_median_m},
          {"rms_distance_p90_m", m.plane_error_p90_m}, {"depth_sigma_median_m", m.depth_sigma_median_m},
          {"rms_distance_over_depth_sigma_median", m.plane_error_over_sigma_median},
          {"normal_angle_median_deg", m.normal_error_median_deg},
          {"centroid_distance_median_m", m.centroid_offset_median_m},
          {"weak_texture",
           {{"cells", m.weak_plane_error_cells}, {"rms_distance_median_m", m.weak_plane_error_median_m},
            {"rms_distance_over_depth_sigma_median", m.weak_plane_error_over_sigma_median},
            {"normal_angle_median_deg", m.weak_normal_error_median_deg},
            {"centroid_distance_median_m", m.weak_centroid_offset_median_m}}}};
    }
  }
  if (r.map_completeness) {
    const auto& c = *r.map_completeness;
    out["map_vs_ground_truth"] = {
        {"points", c.points}, {"frame_stride", kCompletenessFrameStride},
        {"pixel_stride", kCompletenessPixelStride}, {"max_depth_m", kCompletenessMaxDepthM},
        {"within_0_10_m", c.within[0]}, {"within_0_20_m", c.within[1]}, {"within_0_50_m", c.within[2]}};
  }
  if (r.map_accuracy) {
    const auto& a = *r.map_accuracy;
    out["map_accuracy_vs_ground_truth"] = {
        {"cells", a.cells}, {"area_m2", a.area_m2}, {"samples_per_cell", map::kCoverageSamples},
        {"within_0_10_m", a.within[0]}, {"within_0_20_m", a.within[1]}, {"within_0_50_m", a.within[2]}};
  }
  if (r.voxel) {
    out["voxel"] = {{"mode", r.voxel_mode}, {"voxel_bytes", r.voxel_bytes},
                    {"voxel_ot_bytes", r.voxel_ot_bytes}, {"voxel_bt_bytes", r.voxel_bt_bytes},
                    {"voxel_leaves", r.voxel_leaves}};
    if (r.voxel_accuracy) {
      const auto& a = *r.voxel_accuracy;
      out["voxel"]["accuracy_vs_ground_truth"] = {
          {"voxels", a.voxels}, {"within_0_10_m", a.within[0]}, {"within_0_20_m", a.within[1]}, {"within_0_50_m", a.within[2]}};
    }
    if (r.voxel_completeness) {
      const auto& c = *r.voxel_completeness;
      out["voxel"]["completeness_vs_ground_truth"] = {
          {"points", c.points}, {"within_0_10_m", c.within[0]}, {"within_0_20_m", c.within[1]}, {"within_0_50_m", c.within[2]}};
    }
  }
  if (const auto c = compare_with_voxel(r)) {
    auto& vs = out["map_vs_voxel"] = {{"ram_times_smaller", c->ram_times_smaller}};
    if (c->store_times_smaller_than_ot)
      vs["store_times_smaller_than_ot"] = *c->store_times_smaller_than_ot;
    if (c->store_over_bt) vs["store_over_bt"] = *c->store_over_bt;
  }
  if (r.refine) out["refine"] = to_json(*r.refine);
  return out;
}

std::string summary_text(const ReplayReport& r) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(1);
  out << "replay: " << r.frames << " frames";
  if (r.frames_resumed > 0) out << " (+" << r.frames_resumed << " already in the store)";
  if (r.frames_from_extraction_cache > 0)
    out << " (" << r.frames_from_extraction_cache << " with SGM and extraction from the cache)";
  out << " in " << r.wall_s << " s (" << r.frames_per_s << " frames/s" << (r.threaded ? ", threaded" : "");
  if (r.rate_hz > 0.0) out << ", input paced at " << r.rate_hz << " Hz";
  out << "); " << r.cells_extracted << " cells extracted ("
      << 100.0 * r.plane_fraction << " % with a plane)\n";
  out << "  map: " << r.cells_in_map << " cells, " << r.surfaces << " surfaces ("
      << r.dormant_surfaces << " dormant), " << r.fused_cells << " re-observations fused ("
      << r.redundant_cells << " by coverage, " << r.prefused_cells
      << " found before the neighbour search), " << r.replaced_cells
      << " cells replaced by nearer ones, " << r.consolidated_cells << " old cells consolidated, "
      << r.surface_merges << " surface merges, " << r.pruned_surfaces
      << " unconfirmed surfaces pruned\n";
  out << "  size: " << r.map_bytes / 1024.0 << " KiB in RAM (" << r.bytes_per_frame / 1024.0
      << " KiB/frame";
  if (r.settled) out << "; settled at the end, " << r.map_bytes_live / 1024.0 << " KiB after the last frame";
  out << ")";
  if (r.store_bytes > 0) out << ", store " << r.store_bytes / 1024.0 << " KiB on disk";
  out << "\n";
  if (r.merge_metrics) {
    const auto& m = *r.merge_metrics;
    out << "  merging vs GT surfaces: " << 100.0 * m.area_one_label << " % of GT area in one label each ("
        << 100.0 * m.area_in_dominant_label << " % in its dominant label), " << 100.0 * m.cross_merged_cells
        << " % of cells merged across GT surfaces, " << 100.0 * m.cross_merged_cells_between_planes
        << " % across GT planes (" << m.gt_surfaces << " GT surfaces -> " << m.labels
        << " labels, " << m.cells << " cells, " << m.mixed_cells << " mixed cells left out)\n";
    if (m.cross_merged_cells_between_planes > 0.0)
      out << "  of those across GT planes, boundary cells (under "
          << 100.0 * eval::MergeMetrics::kPureCellShare << " % of their pixels on their GT surface): "
          << 100.0 * m.cross_merged_cells_boundary << " % of cells\n";
    if (m.area_one_label < 1.0 && !m.by_kind.empty()) {
      out << "  GT area not in one label, by kind (% of all GT area):";
      for (const auto& k : m.by_kind)
        if (k.lost > 0.0) out << " " << k.kind << " " << 100.0 * k.lost;
      out << "\n";
      if (m.weak_texture.gt_surfaces > 0)
        out << "  of it on weakly textured surfaces (any kind): " << 100.0 * m.weak_texture.lost << " (they hold "
            << 100.0 * m.weak_texture.area << " % of GT area)\n";
    }
    if (!m.crossed_by_kinds.empty()) {
      out << "  across GT planes by kind, cell's -> its label's (% of cells):";
      const std::size_t shown = std::min<std::size_t>(m.crossed_by_kinds.size(), 6);
      for (std::size_t k = 0; k < shown; ++k)
        out << (k ? ", " : " ") << m.crossed_by_kinds[k].own_kind << " -> " << m.crossed_by_kinds[k].label_kind << " "
            << 100.0 * m.crossed_by_kinds[k].cells;
      if (shown < m.crossed_by_kinds.size()) out << ", ...";
      out << "\n";
    }
    if (!m.crossed_by_fate.empty()) {
      out << "  cells by the path that placed them (% of cells / of them across GT planes):";
      for (std::size_t k = 0; k < m.crossed_by_fate.size(); ++k) {
        const auto& f = m.crossed_by_fate[k];
        out << (k ? ", " : " ") << f.fate << " " << 100.0 * f.cells << " / "
            << (f.cells > 0.0 ? 100.0 * f.crossed / f.cells : 0.0);
      }
      out << "\n";
    }
    if (m.plane_error_cells > 0) {
      out << "  merged across GT planes further than 2 sigma_Z (the cell's own depth noise) from its GT plane: "
          << 100.0 * m.cross_merged_cells_resolvable << " % of cells\n";
      out.precision(3);
      out << "  cell planes vs GT planes: RMS vertex distance median " << m.plane_error_median_m << " m, p90 "
          << m.plane_error_p90_m << " m; modelled depth noise sigma_Z median " << m.depth_sigma_median_m
          << " m (distance / sigma_Z median " << m.plane_error_over_sigma_median << "); normal off by "
          << m.normal_error_median_deg << " deg, centroid " << m.centroid_offset_median_m << " m (medians)\n";
      if (m.weak_plane_error_cells > 0)
        out << "  ... of the " << m.weak_plane_error_cells << " cells on weakly textured surfaces: median "
            << m.weak_plane_error_median_m << " m (distance / sigma_Z median " << m.weak_plane_error_over_sigma_median
            << "); normal off by " << m.weak_normal_error_median_deg << " deg, centroid "
            << m.weak_centroid_offset_median_m << " m\n";
      out.precision(1);
    }
  }
  if (r.map_completeness) {
    const auto& c = *r.map_completeness;
    out << "  map vs GT points (every " << kCompletenessFrameStride << "th frame, depth <= " << kCompletenessMaxDepthM
        << " m): " << 100.0 * c.within[0] << " / " << 100.0 * c.within[1] << " / " << 100.0 * c.within[2]
        << " % within 10 / 20 / 50 cm of a stored planecell (" << c.points << " points)\n";
  }
  if (r.map_accuracy) {
    const auto& a = *r.map_accuracy;
    out << "  map area vs GT surfaces: " << 100.0 * a.within[0] << " / " << 100.0 * a.within[1] << " / "
        << 100.0 * a.within[2] << " % of the stored cells' " << a.area_m2
        << " m2 within 10 / 20 / 50 cm of a GT surface\n";
  }
  if (r.merge_ms.size() >= 20) {
    // Median merge time of the first and the last tenth of the frames: flat as the map grows?
    const auto tenth = static_cast<std::ptrdiff_t>(r.merge_ms.size() / 10);
    out << "  merge time as the map grows: median "
        << summarise({r.merge_ms.begin(), r.merge_ms.begin() + tenth}).p50_ms
        << " ms over the first tenth of the frames, "
        << summarise({r.merge_ms.end() - tenth, r.merge_ms.end()}).p50_ms << " ms over the last tenth\n";
  }
  if (r.voxel)
    out << "  voxel baseline (" << r.voxel_mode << "): " << r.voxel_leaves << " voxels, "
        << r.voxel_bytes / 1024.0 << " KiB in RAM, .ot " << r.voxel_ot_bytes / 1024.0 << " KiB, .bt "
        << r.voxel_bt_bytes / 1024.0 << " KiB\n";
  if (r.voxel_completeness) {
    const auto& c = *r.voxel_completeness;
    out << "  GT points vs voxels: " << 100.0 * c.within[0] << " / " << 100.0 * c.within[1] << " / "
        << 100.0 * c.within[2] << " % within 10 / 20 / 50 cm of an occupied voxel\n";
  }
  if (r.voxel_accuracy) {
    const auto& a = *r.voxel_accuracy;
    out << "  voxels vs GT surfaces: " << 100.0 * a.within[0] << " / " << 100.0 * a.within[1] << " / "
        << 100.0 * a.within[2] << " % of the occupied voxels' centres within 10 / 20 / 50 cm of a GT surface\n";
  }
  if (const auto c = compare_with_voxel(r)) {
    out << "  map vs voxel baseline: " << c->ram_times_smaller << "x smaller in RAM";
    if (c->store_times_smaller_than_ot)
      out << "; store " << *c->store_times_smaller_than_ot << "x smaller than the .ot";
    if (c->store_over_bt) {
      out.precision(2);
      out << ", " << *c->store_over_bt << "x the .bt";
      out.precision(1);
    }
    out << "\n";
  }
  if (r.refine) out << summary_text(*r.refine);
  out << "  per-stage latency (ms, p50 / p95 / max; CPU ms p50, page faults per frame):";
  for (const auto& [name, s] : r.stage_latency) {
    out.precision(1);
    out << "\n    " << name << ": " << s.p50_ms << " / " << s.p95_ms << " / " << s.max_ms;
    for (const auto& [cost_name, c] : r.stage_cost)
      if (cost_name == name)
        out << "; CPU " << c.cpu.p50_ms << ", faults " << static_cast<long>(c.minor_faults_mean);
  }
  out << "\n";
  if (!r.memory.empty()) {
    constexpr double kMb = 1024.0 * 1024.0;
    out << "  memory: RSS " << static_cast<double>(r.memory.front().rss_bytes) / kMb << " MB before the first frame, "
        << static_cast<double>(r.memory.back().rss_bytes) / kMb << " MB after the last (map "
        << static_cast<double>(r.memory.back().map_bytes) / kMb << " MB), peak "
        << static_cast<double>(r.peak_rss_bytes) / kMb << " MB\n";
  }
  return out.str();
}

}  // namespace planecell::services
