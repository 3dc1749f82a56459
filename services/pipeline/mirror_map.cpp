#include "services/pipeline/mirror_map.hpp"

#include <algorithm>
#include <map>

#include "core/error.hpp"
#include "io/map_store.hpp"
#include "mapping/map/geometry.hpp"

namespace planecell::services {

map::GlobalMap mirror_to_map(const io::MapMirror& mirror, const MapConfig& config) {
  std::map<std::uint32_t, std::vector<const map::MapCell*>> by_surface;
  for (const auto& [id, cell] : mirror.cells) by_surface[cell.surface].push_back(&cell);
  std::vector<map::Surface> surfaces;
  for (auto& [label, cells] : by_surface) {
    std::sort(cells.begin(), cells.end(), [](const map::MapCell* a, const map::MapCell* b) { return a->id < b->id; });
    const map::MapCell* largest = *std::max_element(cells.begin(), cells.end(), [](const map::MapCell* a, const map::MapCell* b) {
      return map::polygon_area_m2(a->vertices_m) < map::polygon_area_m2(b->vertices_m);
    });
    map::Surface surface;
    surface.id = label;
    surface.plane = largest->plane;
    for (const map::MapCell* cell : cells) {
      const double area = map::polygon_area_m2(cell->vertices_m);
      surface.bounds.extend(map::bounds_of(cell->vertices_m));
      surface.observed_area_m2 += area;
      surface.mean_rgb += static_cast<float>(area) * Eigen::Vector3f(cell->mean_rgb);
      surface.cells.push_back(cell->id);
      ++surface.observations;
      surface.last_observed_frame = std::max(surface.last_observed_frame, cell->frame_id);
    }
    // Updates do not carry the frame counts: each mirrored cell counts as one frame's observation.
    surface.frames_observed = surface.observations;
    if (surface.observed_area_m2 > 0.0) surface.mean_rgb /= static_cast<float>(surface.observed_area_m2);
    // Dormant (no detail: queries need the cells only); the area of the cells' union.
    surface.area_m2 = map::rebuild_detail(surface, cells, config.footprint_resolution_m).footprint.area_m2();
    surfaces.push_back(std::move(surface));
  }
  std::vector<map::MapCell> cells;
  cells.reserve(mirror.cells.size());
  for (const auto& [id, cell] : mirror.cells) cells.push_back(cell);
  return map::GlobalMap::restore(config, std::move(cells), std::move(surfaces), mirror.next_cell_id,
                                 mirror.next_surface_id);
}

void write_mirror_store(const map::GlobalMap& map, std::uint64_t frame_id, const std::filesystem::path& path) {
  if (std::filesystem::exists(path))
    throw StorageError("mirror store '" + path.string() + "' already exists (remove it first)");
  map::MergeReport report;
  report.frame_id = frame_id;
  for (const auto& [id, cell] : map.cells()) report.added_cells.push_back(id);
  for (const auto& [id, surface] : map.surfaces()) report.updated_surfaces.push_back(id);
  std::sort(report.added_cells.begin(), report.added_cells.end());
  std::sort(report.updated_surfaces.begin(), report.updated_surfaces.end());
  report.input_cells = report.added_cells.size();
  io::MapStore store(path);
  store.commit_frame(frame_id, Pose::Identity(), report, map);
}

}  // namespace planecell::services
