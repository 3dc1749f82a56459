#pragma once
/// Replay of a KITTI-odometry-layout sequence through the whole single-threaded pipeline:
/// SGM → planecell extraction → pose transform → CRF merge into the global map → map store,
/// with the OctoMap voxel baseline optionally fed the same frames.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/config/app_config.hpp"
#include "io/map_store.hpp"
#include "mapping/map/global_map.hpp"
#include "services/eval/map_accuracy.hpp"
#include "services/eval/map_completeness.hpp"
#include "services/eval/merge_metrics.hpp"
#include "services/latency_stats.hpp"
#include "services/pipeline/pipeline.hpp"
#include "services/refine_stage.hpp"

namespace planecell::services {

struct ReplayOptions {
  std::filesystem::path sequence_dir;
  std::optional<std::filesystem::path> map_path;    ///< SQLite map store; resumes when it exists
  std::optional<std::filesystem::path> poses_path;  ///< overrides the sequence's own poses
  bool voxel = false;                               ///< also build the OctoMap baseline
  std::size_t first_frame = 0;                      ///< frames [first, last) are replayed
  std::size_t last_frame = std::numeric_limits<std::size_t>::max();
  bool progress = true;
  /// Run the stages as the threaded pipeline (services/pipeline) instead of one after another on
  /// this thread; the map is the same.
  bool threads = false;
  /// Diagnostic: the sequence's ground-truth disparity (disp_occ_0/) replaces SGM, so the map,
  /// the merging scores and the pose refinement show what perfect stereo would give. Needs GT
  /// disparity for every frame (InputError otherwise) and the single-threaded replay (ConfigError).
  bool gt_disparity = false;
  /// Extraction products (camera-frame planecells, label image) of each frame are read from
  /// this folder when it holds them for the same inputs (io/extraction_cache: the SGM and
  /// extraction configuration, camera, image files and --gt-disparity), else computed and written
  /// there: a second replay re-runs only the mapping stages (tuning and profiling the map).
  /// Single-threaded, without the voxel baseline (it needs the disparity; ConfigError).
  std::optional<std::filesystem::path> extraction_cache_dir;
  /// Called with every finished frame (e.g. LCM map updates; work.delta filled when
  /// sinks.want_delta): threaded on the publish thread, single-threaded on the calling thread
  /// after the store.
  PipelineSinks sinks;
  /// Input pacing like a camera: frame k of this run is due at start + k / rate_hz and is not
  /// loaded before (0 = as fast as the stages take frames). End-to-end latency then counts from
  /// the due time, so a pipeline slower than the rate shows as a growing latency.
  double rate_hz = 0.0;
  /// Resident memory is sampled every this many frames (0 = never): ReplayReport::memory.
  std::size_t memory_sample_every = 10;
  /// Called once per replayed frame, in frame order, after every stage has run on it, with the
  /// frame's images, SGM disparity and planecells (labels, dense disparity) still in `work`
  /// (e.g. `planecell bench` scores them against ground truth). Single-threaded: on the calling
  /// thread; threaded: on the publish thread (the pipeline then keeps the images until publish).
  std::function<void(const FrameWork& work)> observe;
};

/// Parses "A:B", "A:" or ":B" into [A, B) (B exclusive). Throws ConfigError on anything else.
std::pair<std::size_t, std::size_t> parse_frame_range(const std::string& text);

/// Process memory at one point of a replay.
struct MemorySample {
  std::size_t frames = 0;     ///< frames finished in this run when sampled
  double elapsed_s = 0.0;     ///< since the replay started
  std::size_t rss_bytes = 0;  ///< resident set size of the process
  std::size_t map_bytes = 0;  ///< GlobalMap::map_bytes after the last finished frame
};

/// Map completeness in replay: GT points of every kCompletenessFrameStride-th frame, on a grid of
/// kCompletenessPixelStride px, at depths up to kCompletenessMaxDepthM (the default map range,
/// fixed so that a shorter MapConfig::max_range_m shows as a smaller map, not a better one).
inline constexpr std::uint64_t kCompletenessFrameStride = 10;
inline constexpr int kCompletenessPixelStride = 8;
inline constexpr double kCompletenessMaxDepthM = 20.0;

struct ReplayReport {
  std::string sequence;
  std::size_t frames = 0;          ///< frames processed in this run
  std::size_t frames_resumed = 0;  ///< frames skipped because the store already had them
  /// frames whose extraction products came from ReplayOptions::extraction_cache_dir
  std::size_t frames_from_extraction_cache = 0;
  std::size_t cells_extracted = 0;
  double plane_fraction = 0.0;     ///< mean share of segments with a plane
  std::size_t cells_in_map = 0;
  std::size_t surfaces = 0;
  std::size_t dormant_surfaces = 0;  ///< of those, asleep at the end (map.dormant_after_frames)
  std::size_t fused_cells = 0;     ///< re-observations folded into surfaces, not stored
  std::size_t redundant_cells = 0;  ///< of those, space the map already held (coverage rule)
  /// Of the fused cells, those found before the neighbour search (map.prefuse_reobservations).
  std::size_t prefused_cells = 0;
  std::size_t replaced_cells = 0;   ///< stored cells replaced by nearer, more precise ones
  std::size_t consolidated_cells =
      0;                            ///< old cells united into fewer (map.consolidate_after_frames)
  std::size_t pruned_surfaces = 0;  ///< single-observation surfaces pruned as unconfirmed
  std::size_t surface_merges = 0;
  std::size_t map_bytes = 0;       ///< global map in RAM (GlobalMap::map_bytes), settled
  /// map_bytes after the last frame, before the map was settled (map.settle_at_close): with the
  /// last frames' working set (live surfaces' detail, cells not yet consolidated).
  std::size_t map_bytes_live = 0;
  bool settled = false;            ///< the map was settled at the end (GlobalMap::settle)
  map::MapBytes map_parts;         ///< map_bytes by part (GlobalMap::map_bytes_by_part)
  std::size_t store_bytes = 0;     ///< map store on disk (database + WAL), 0 without --map
  /// The compacted store's pages by table (close_store); nullopt without --map.
  std::optional<io::StoreBytes> store_parts;
  double bytes_per_frame = 0.0;    ///< map_bytes / frames in the map
  bool voxel = false;
  std::size_t voxel_bytes = 0;     ///< OctoMap memoryUsage
  std::size_t voxel_ot_bytes = 0;  ///< .ot (with colour)
  std::size_t voxel_bt_bytes = 0;  ///< .bt (occupancy only)
  std::size_t voxel_leaves = 0;    ///< occupied voxels
  std::string voxel_mode;          ///< "per-voxel update, no ray casting" or "insertPointCloud"
  /// Merging against the synthetic GT surface ids (sequences with surface_0/), this run's frames.
  std::optional<eval::MergeMetrics> merge_metrics;
  /// The final map against GT points of every kCompletenessFrameStride-th frame of this run
  /// (sequences with GT disparity and poses; see eval::map_completeness).
  std::optional<eval::MapCompleteness> map_completeness;
  /// The final map's stored cells against the scene's GT polygons (synthetic sequences with
  /// scene.yaml; see eval::map_accuracy): how much of the map lies on a real surface.
  std::optional<eval::MapAccuracy> map_accuracy;
  /// The voxel baseline (--voxel) scored the same two ways: its occupied voxels against the GT
  /// polygons, and the same GT points as map_completeness against its voxels.
  std::optional<eval::VoxelAccuracy> voxel_accuracy;
  std::optional<eval::MapCompleteness> voxel_completeness;
  std::vector<std::pair<std::string, LatencySummary>> stage_latency;  ///< per stage, ms
                                                                      ///< (threaded: + end_to_end)
  /// Per stage: CPU time of the thread that ran it and first-touch page faults, per frame.
  std::vector<std::pair<std::string, StageCostSummary>> stage_cost;
  /// RSS before the first frame, every memory_sample_every frames and after the last one.
  std::vector<MemorySample> memory;
  /// Wall time of GlobalMap::integrate per frame of this run, in frame order (ms): the merge
  /// time as the map grows.
  std::vector<double> merge_ms;
  std::size_t peak_rss_bytes = 0;  ///< max(getrusage ru_maxrss at the end, every RSS sample)
  double rate_hz = 0.0;            ///< input pacing (0 = as fast as possible)
  bool threaded = false;
  double frames_per_s = 0.0;  ///< frames / wall_s
  double wall_s = 0.0;
  std::optional<RefineSummary> refine;  ///< pose refinement (config.refine.enabled)
};

/// Runs the replay (single-threaded, or the threaded pipeline with options.threads). Throws InputError on a bad sequence (missing poses, unreadable frames
/// stop the run with the frame named; frames already committed stay in the store).
ReplayReport run_replay(const ReplayOptions& options, const AppConfig& config);

/// The map against the voxel baseline fed the same frames, as the memory targets state it: the
/// map in RAM voxel_bytes / map_bytes times smaller than OctoMap's memoryUsage; the store
/// voxel_ot_bytes / store_bytes times smaller than the .ot and store_bytes / voxel_bt_bytes of
/// the .bt (store ratios nullopt without a store).
struct VoxelComparison {
  double ram_times_smaller = 0.0;
  std::optional<double> store_times_smaller_than_ot;
  std::optional<double> store_over_bt;
};
/// nullopt without a voxel baseline (--voxel) or with an empty map.
std::optional<VoxelComparison> compare_with_voxel(const ReplayReport& report);

nlohmann::json to_json(const ReplayReport& report);

/// A few human-readable lines summarising the report.
std::string summary_text(const ReplayReport& report);

}  // namespace planecell::services
