#pragma once
/// JSON export of the map's surfaces as outlines (map::surface_outline): a compact vector map of
/// planes and their rings for planners and GIS-style tools.
#include <cstddef>
#include <filesystem>

#include "mapping/map/global_map.hpp"

namespace planecell::io {

/// What write_outlines_json wrote.
struct OutlineExport {
  std::size_t surfaces = 0;  ///< surfaces with at least one ring
  std::size_t rings = 0;     ///< outer rings and holes
  std::size_t vertices = 0;
};

/// Writes every surface of `map` with a non-empty outline, by id, as
///   {"format": "planecell-outlines", "version": 1, "frame": "world", "units": "m",
///    "footprint_resolution_m", "tolerance_m",
///    "surfaces": [{"id", "plane": [n_x, n_y, n_z, e] (n·X + e = 0), "mean_rgb": [r, g, b],
///                  "area_m2" (footprint), "observations",
///                  "rings": [{"hole": bool, "vertices": [[x, y, z], ...]}, ...]}, ...]}
/// (an outer ring is followed by its holes; coordinates rounded to 0.1 mm). Throws StorageError
/// naming the path when it cannot be written, InputError on a negative tolerance.
OutlineExport write_outlines_json(const std::filesystem::path& path, const map::GlobalMap& map,
                                  double tolerance_m);

}  // namespace planecell::io
