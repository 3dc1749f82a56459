#pragma once
/// The per-frame stages of the mapping pipeline, one function per stage. `planecell replay` calls
/// them in sequence on one thread; services/pipeline/pipeline runs each on its own thread. Every
/// stage reads and writes one FrameWork (the frame, its products and per-stage wall times), so a
/// new stage (e.g. pose refinement between transform and merge) is one more function here and one
/// more thread in the pipeline.
#include <chrono>
#include <cstdint>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <utility>
#include <optional>
#include <vector>

#include "core/config/app_config.hpp"
#include "core/frame.hpp"
#include "core/planecell.hpp"
#include "core/pose.hpp"
#include "io/lcm/map_update.hpp"
#include "mapping/map/crf_merger.hpp"
#include "mapping/map/global_map.hpp"
#include "mapping/planecell/extraction.hpp"
#include "services/pipeline/thread_usage.hpp"
#include "services/refine_stage.hpp"

namespace planecell::io {
class MapStore;
struct StoreBytes;
struct KittiOdometrySequence;
}  // namespace planecell::io
namespace planecell::voxel {
class VoxelMap;
}

namespace planecell::services {

using StageClock = std::chrono::steady_clock;

/// What the merge stage changed in the map, copied out of it so that a later stage (publish) can
/// read it while the merge stage already integrates the next frame.
using MapDelta = io::MapUpdate;

/// What one stage run cost its thread (see thread_usage.hpp): CPU time and first-touch page faults.
/// A stage that hands work to extra threads (SGM with sgm.threads ≥ 2) counts only its own.
struct StageCost {
  double cpu_ms = 0.0;
  std::int64_t minor_faults = 0;
};

/// One frame on its way through the pipeline.
struct FrameWork {
  std::uint64_t frame_id = 0;
  /// A synthetic frame of Pipeline::warm_up: run through sgm and extract only, never mapped,
  /// published or counted.
  bool warm_up = false;
  StereoFrame frame;   ///< input images, camera, pose (required from the transform stage on)
  /// The pose the frame came with, when pose refinement replaced frame.pose (stored beside it).
  std::optional<Pose> input_pose;
  StageClock::time_point ingest_time{};  ///< when the frame entered the pipeline (end-to-end start)
  cv::Mat disparity;                     ///< sgm: CV_32F px, NaN = invalid
  extraction::PlanecellFrame cells;      ///< extract: camera-frame cells and label image
  std::vector<Planecell> world_cells;    ///< transform: cells with a plane, world frame
  std::vector<map::LabelEdge> adjacency; ///< transform: label_adjacency of cells.labels
  map::MergeReport merge;                ///< merge: what integrate() changed
  MapDelta delta;                        ///< merge (when asked for): copy of the changes
  std::size_t map_cells = 0;             ///< merge: cells in the map after this frame
  /// merge, when asked for: GlobalMap::map_bytes() after this frame (O(cells), so not every frame)
  std::optional<std::size_t> map_bytes;
  /// Wall time of each stage run on this frame, in order ("sgm", "extract", ...), ms.
  std::vector<std::pair<std::string, double>> stage_ms;
  /// CPU time and page faults of the same stage runs, same order as stage_ms.
  std::vector<std::pair<std::string, StageCost>> stage_cost;

  /// Runs `fn()` and appends its wall time under `stage` (stage_ms) and what it cost the calling
  /// thread (stage_cost).
  template <class Fn>
  void timed(const char* stage, Fn&& fn) {
    const ThreadUsage usage_before = thread_usage();
    const auto start = StageClock::now();
    fn();
    const auto end = StageClock::now();
    const ThreadUsage usage_after = thread_usage();
    stage_ms.emplace_back(stage, std::chrono::duration<double, std::milli>(end - start).count());
    stage_cost.emplace_back(stage, StageCost{usage_after.cpu_ms - usage_before.cpu_ms,
                                             usage_after.minor_faults - usage_before.minor_faults});
  }
};

/// load: frame `index` of a KITTI-odometry-layout sequence, frame_id = index. Throws InputError
/// on an unreadable frame or a frame without a pose.
FrameWork load_stage(const io::KittiOdometrySequence& sequence, std::size_t index);

/// sgm: disparity of the rectified pair (stereo::compute_disparity).
void sgm_stage(FrameWork& work, const SgmConfig& config);

/// extract: planecells from the left image and the disparity; every cell gets frame_id.
void extract_stage(FrameWork& work, const ExtractionConfig& config);

/// transform: cells to the world frame by the frame's pose T_world_cam (map::to_world, planeless
/// cells dropped) and the frame's label adjacency for the merger. Throws InputError when the
/// frame has no pose or a bad one.
void transform_stage(FrameWork& work);

/// refine: pose refinement of the frame's camera-frame cells against `map` (RefineStage::refine);
/// the input pose moves to work.input_pose and frame.pose becomes the refined one, used from
/// here on (transform, voxel, merge, store). Runs where `map` is not being written.
void refine_stage(FrameWork& work, RefineStage& refinement, const map::GlobalMap& map);

/// merge: GlobalMap::integrate of the world cells. With `want_delta`, copies the changes into
/// work.delta (MapDelta) for consumers that run after the map has moved on; with
/// `want_map_bytes`, measures the map's RAM into work.map_bytes (it walks every cell and surface:
/// a cost that grows with the map, so callers ask for it only on the frames they sample).
void merge_stage(FrameWork& work, map::GlobalMap& map, bool want_delta = false, bool want_map_bytes = false);

/// store: commits the merged frame to the map store (one transaction).
void store_stage(FrameWork& work, io::MapStore& store, const map::GlobalMap& map);

/// End of a session, before close_store: settles `map` after its last frame `last_frame_id`
/// (map::GlobalMap::settle) when map.settle_at_close is set and a frame was mapped, and commits
/// the settling to `store` when there is one (a failure, e.g. a full disk, is logged as a
/// warning: the store keeps every frame, unsettled). Returns the settling's report (nullopt when
/// the map was not settled) for the map's consumers and scores.
std::optional<map::MergeReport> settle_stage(map::GlobalMap& map, io::MapStore* store,
                                             std::optional<std::uint64_t> last_frame_id);

/// End of a session: compacts the store (io::MapStore::compact; a failure, e.g. a full disk,
/// is logged as a warning: every frame is already committed) and closes it, which checkpoints
/// the WAL into the database. Returns the compacted store's pages by table
/// (io::MapStore::bytes_by_part; nullopt, with a warning, when they cannot be read). Does
/// nothing when `store` is empty.
std::optional<io::StoreBytes> close_store(std::unique_ptr<io::MapStore>& store);

/// voxel: back-projects the disparity into the OctoMap voxel baseline.
void voxel_stage(FrameWork& work, voxel::VoxelMap& voxels, const VoxelConfig& config);

/// The MapDelta of one integrate() report, read from `map` right after it.
MapDelta make_delta(const map::MergeReport& report, const map::GlobalMap& map);

}  // namespace planecell::services
