#include "services/pipeline/stages.hpp"

#include <spdlog/spdlog.h>

#include "core/error.hpp"
#include "io/kitti_odometry.hpp"
#include "io/map_store.hpp"
#include "mapping/map/pose_transform.hpp"
#include "mapping/stereo/sgm.hpp"
#include "mapping/voxel/voxel_map.hpp"

namespace planecell::services {

FrameWork load_stage(const io::KittiOdometrySequence& sequence, std::size_t index) {
  FrameWork work;
  work.ingest_time = StageClock::now();
  work.frame_id = static_cast<std::uint64_t>(index);
  work.timed("load", [&] { work.frame = io::load_kitti_frame(sequence, index); });
  work.frame.frame_id = work.frame_id;
  return work;
}

void sgm_stage(FrameWork& work, const SgmConfig& config) {
  work.timed("sgm", [&] {
    work.disparity = stereo::compute_disparity(work.frame.left, work.frame.right, config);
  });
}

void extract_stage(FrameWork& work, const ExtractionConfig& config) {
  work.timed("extract", [&] {
    work.cells = extraction::extract_planecells(work.frame.left, work.frame.right, work.disparity,
                                                    work.frame.camera, config);
    for (auto& cell : work.cells.cells) cell.frame_id = work.frame_id;
  });
}

void transform_stage(FrameWork& work) {
  if (!work.frame.pose)
    throw InputError("frame " + std::to_string(work.frame_id) + ": no pose to place it in the world");
  work.timed("transform", [&] {
    work.world_cells = map::to_world(work.cells.cells, *work.frame.pose);
    work.adjacency = map::label_adjacency(work.cells.labels);
  });
}

void merge_stage(FrameWork& work, map::GlobalMap& map, bool want_delta, bool want_map_bytes) {
  if (!work.frame.pose)
    throw InputError("frame " + std::to_string(work.frame_id) + ": no pose to merge it with");
  work.timed("merge", [&] {
    work.merge = map.integrate(work.frame_id, *work.frame.pose, work.world_cells, work.adjacency);
    work.map_cells = map.cells().size();
    if (want_delta) work.delta = make_delta(work.merge, map);
  });
  if (want_map_bytes) work.map_bytes = map.map_bytes();  // O(cells), outside the merge time
}

void refine_stage(FrameWork& work, RefineStage& refinement, const map::GlobalMap& map) {
  work.timed("refine", [&] {
    work.input_pose = work.frame.pose;
    work.frame.pose = refinement.refine(work.frame_id, work.cells.cells, *work.frame.pose, map, work.frame.camera);
  });
}

void store_stage(FrameWork& work, io::MapStore& store, const map::GlobalMap& map) {
  work.timed("store", [&] { store.commit_frame(work.frame_id, *work.frame.pose, work.merge, map, work.input_pose); });
}

std::optional<map::MergeReport> settle_stage(map::GlobalMap& map, io::MapStore* store,
                                             std::optional<std::uint64_t> last_frame_id) {
  if (!map.config().settle_at_close || !last_frame_id) return std::nullopt;
  map::MergeReport report = map.settle(*last_frame_id);
  spdlog::debug("settled the map after frame {} in {:.1f} ms: {} cells consolidated, {} surfaces dormant, "
                "{} joined, {} pruned", *last_frame_id, report.merge_ms, report.consolidated_cells,
                report.dormant_surfaces.size(), report.surface_merges.size(), report.pruned_surfaces.size());
  if (store) {
    try {
      store->commit_settle(report, map);
    } catch (const StorageError& e) {
      spdlog::warn("{}; every frame is committed, the store is only not settled", e.what());
    }
  }
  return report;
}

std::optional<io::StoreBytes> close_store(std::unique_ptr<io::MapStore>& store) {
  if (!store) return std::nullopt;
  try {
    store->compact();
  } catch (const StorageError& e) {
    spdlog::warn("{}; every frame is committed, the store is only not compacted", e.what());
  }
  std::optional<io::StoreBytes> parts;
  try {
    parts = store->bytes_by_part();
  } catch (const StorageError& e) {
    spdlog::warn("{}; the store's pages by table are not reported", e.what());
  }
  store.reset();
  return parts;
}

void voxel_stage(FrameWork& work, voxel::VoxelMap& voxels, const VoxelConfig& config) {
  work.timed("voxel", [&] {
    const auto points = voxel::back_project(work.disparity, work.frame.left, work.frame.camera,
                                            *work.frame.pose, config.max_range_m);
    voxels.insert(points);
  });
}

MapDelta make_delta(const map::MergeReport& report, const map::GlobalMap& map) {
  MapDelta delta;
  delta.frame_id = report.frame_id;
  delta.settled = report.settled;
  delta.added_cells.reserve(report.added_cells.size());
  for (const auto id : report.added_cells)
    if (const map::MapCell* cell = map.cell(id)) delta.added_cells.push_back(*cell);
  delta.relabelled_cells.reserve(report.relabelled_cells.size());
  for (const auto id : report.relabelled_cells)
    if (const map::MapCell* cell = map.cell(id)) delta.relabelled_cells.emplace_back(id, cell->surface);
  delta.removed_cells = report.removed_cells;
  delta.surface_merges = report.surface_merges;
  delta.removed_surfaces = report.removed_surfaces;
  delta.next_cell_id = map.next_cell_id();
  delta.next_surface_id = map.next_surface_id();
  delta.map_cells = map.cells().size();
  delta.map_surfaces = map.surfaces().size();
  return delta;
}

}  // namespace planecell::services
