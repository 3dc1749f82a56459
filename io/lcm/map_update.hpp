#pragma once
/// What one frame changed in the global map, as a value that can leave the merge thread and the
/// process (services/pipeline fills it, io/lcm encodes it, `planecell listen` applies it).
#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/planecell.hpp"
#include "mapping/map/global_map.hpp"

namespace planecell::io {

struct MapUpdate {
  std::uint64_t frame_id = 0;
  /// The map settled after frame frame_id (GlobalMap::settle at the end of a session): an
  /// update that follows the frame's own, no new frame.
  bool settled = false;
  std::vector<map::MapCell> added_cells;  ///< new stored cells, world frame, with their surface
  std::vector<std::pair<std::uint32_t, std::uint32_t>> relabelled_cells;  ///< (cell id, surface)
  std::vector<std::uint32_t> removed_cells;
  std::vector<map::SurfaceMerge> surface_merges;
  std::vector<std::uint32_t> removed_surfaces;
  std::uint32_t next_cell_id = 0;  ///< the map's id counters after this frame
  std::uint32_t next_surface_id = 0;
  std::size_t map_cells = 0;  ///< cells in the map after this frame
  std::size_t map_surfaces = 0;
};

/// The cells of a map rebuilt from updates only: id → cell (world frame, surface label).
struct MapMirror {
  std::unordered_map<std::uint32_t, map::MapCell> cells;
  std::uint32_t next_cell_id = 0;
  std::uint32_t next_surface_id = 0;
  std::uint64_t frames = 0;  ///< frame updates applied (settling updates not counted)
  std::uint64_t last_frame_id = 0;

  /// Adds, relabels and removes cells as the update says. Throws InputError when it names a cell
  /// the mirror does not have (relabel/remove) or adds one it already has.
  void apply(const MapUpdate& update);
};

}  // namespace planecell::io
