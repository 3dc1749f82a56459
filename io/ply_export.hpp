#pragma once
/// PLY export of planecells as coloured polygons (for MeshLab / CloudCompare).
#include <filesystem>
#include <vector>

#include "core/planecell.hpp"
#include "mapping/map/map_cell.hpp"

namespace planecell::io {

/// Writes every cell with a plane and ≥ 3 3D vertices as its polygon cut into triangles
/// (map::triangulate_polygon: n − 2 per n-gon, covering non-convex cells exactly): per cell its
/// polygon's vertices, each with the cell's mean colour (uchar red, green, blue), and its
/// triangles (property list uchar int vertex_indices). `binary` selects binary_little_endian
/// 1.0, else ascii 1.0. Coordinates are the cells' vertices_m (camera or world frame, metres).
/// Returns the number of triangles written. Throws StorageError naming the path when the file
/// cannot be written.
std::size_t write_planecells_ply(const std::filesystem::path& path,
                                 const std::vector<Planecell>& cells, bool binary = true);
/// The same for the map's cells (all have a plane).
std::size_t write_planecells_ply(const std::filesystem::path& path,
                                 const std::vector<map::MapCell>& cells, bool binary = true);

}  // namespace planecell::io
