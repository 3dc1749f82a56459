#pragma once
/// A queryable map rebuilt from the cells a map-update subscriber mirrors (io::MapMirror).
#include <filesystem>

#include "core/config/map_config.hpp"
#include "io/lcm/map_update.hpp"
#include "mapping/map/global_map.hpp"

namespace planecell::services {

/// GlobalMap holding exactly the mirror's cells (same ids, planes, polygons, surface labels) and
/// one dormant surface per label (no SurfaceDetail): the plane of its largest cell, the area of
/// its cells' union (a footprint rasterised for the count), and their bounds. nearest_cell answers
/// exactly as on the daemon's map; ground_under approximately (the daemon's surface planes are
/// fitted over every observation, fused ones included, which updates do not carry).
map::GlobalMap mirror_to_map(const io::MapMirror& mirror, const MapConfig& config);

/// Writes `map` as a new map store at `path` (one frame, `frame_id`). Throws StorageError when the
/// file exists (a mirror is never merged into an existing store) or cannot be written.
void write_mirror_store(const map::GlobalMap& map, std::uint64_t frame_id, const std::filesystem::path& path);

}  // namespace planecell::services
