#include "mapping/map/global_map.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>

#include "core/error.hpp"

namespace planecell::map {
namespace {

bool cell_is_usable(const Planecell& cell) {
  if (!cell.has_plane || cell.vertices_m.size() < 3) return false;
  if (!cell.plane.normal.allFinite() || !std::isfinite(cell.plane.offset)) return false;
  for (const auto& v : cell.vertices_m)
    if (!v.allFinite()) return false;
  return polygon_area_m2(cell.vertices_m) > 1e-9;
}

LabelState state_of_cell(const Planecell& cell, double area_m2) {
  LabelState s;
  s.plane = cell.plane;
  s.moments.add_polygon(cell.vertices_m, area_m2);
  s.histogram = cell.histogram;
  s.histogram_weight_m2 = area_m2;
  s.area_m2 = area_m2;
  return s;
}

LabelState state_of_surface(const Surface& surface) {
  LabelState s;
  s.plane = surface.plane;
  s.moments = surface.moments;
  s.histogram = surface.histogram;
  s.histogram_weight_m2 = surface.histogram_weight_m2;
  s.area_m2 = surface.area_m2;
  return s;
}

template <class Map>
std::size_t hash_map_bytes(const Map& m) {
  return m.bucket_count() * sizeof(void*) +
         m.size() * (sizeof(typename Map::value_type) + sizeof(void*));
}

bool cells_equal(const Planecell& a, const Planecell& b) {
  return a.id == b.id && a.frame_id == b.frame_id && a.has_plane == b.has_plane &&
         a.disparity_plane.a == b.disparity_plane.a && a.disparity_plane.b == b.disparity_plane.b &&
         a.disparity_plane.c == b.disparity_plane.c && a.plane.normal == b.plane.normal &&
         a.plane.offset == b.plane.offset && a.vertices_px == b.vertices_px &&
         a.vertices_m == b.vertices_m && a.mean_rgb == b.mean_rgb && a.histogram == b.histogram &&
         a.area_px == b.area_px && a.inlier_count == b.inlier_count &&
         a.inlier_ratio == b.inlier_ratio && a.depth_sigma_m == b.depth_sigma_m &&
         a.surface == b.surface;
}

bool surfaces_equal(const Surface& a, const Surface& b) {
  if (!(a.id == b.id && a.plane.normal == b.plane.normal && a.plane.offset == b.plane.offset &&
        a.moments == b.moments && a.histogram == b.histogram &&
        a.histogram_weight_m2 == b.histogram_weight_m2 && a.mean_rgb == b.mean_rgb &&
        a.observed_area_m2 == b.observed_area_m2 && a.area_m2 == b.area_m2 &&
        a.bounds == b.bounds && a.basis == b.basis && a.cells == b.cells &&
        a.observations == b.observations && a.footprint == b.footprint))
    return false;
  return true;
}

}  // namespace

GlobalMap::GlobalMap(const MapConfig& config)
    : config_(config),
      up_(config.up_x, config.up_y, config.up_z),
      merger_(config),
      index_(config.index_cell_m) {
  if (!(up_.norm() > 1e-9) || !up_.allFinite())
    throw ConfigError("map.up_x/up_y/up_z: the up vector must be non-zero and finite");
  up_.normalize();
  if (!(config.max_range_m > 0.0))
    throw ConfigError("map.max_range_m: must be > 0, got " + std::to_string(config.max_range_m));
  (void)Footprint(config.footprint_resolution_m);  // validates the resolution (ConfigError)
  if (!(config.neighbour_gap_m >= 0.0))
    throw ConfigError("map.neighbour_gap_m: must be >= 0, got " + std::to_string(config.neighbour_gap_m));
}

std::vector<std::uint32_t> GlobalMap::cells_near(const Aabb& box) const { return index_.query(box); }

void GlobalMap::absorb_surface(Surface& into, Surface& absorbed, MergeReport& report) {
  for (std::uint32_t id : absorbed.cells) {
    cells_.at(id).surface = into.id;
    into.cells.push_back(id);
    report.relabelled_cells.push_back(id);
  }
  // Footprint bits move to into's basis through 3D (bit centres; ≤ one bit of blur).
  for (const Eigen::Vector2d& st : absorbed.footprint.covered_centres()) {
    const Eigen::Vector2d moved = into.basis.to_2d(absorbed.basis.to_3d(st));
    into.footprint.add_point(moved.x(), moved.y());
  }
  const double w = into.observed_area_m2 + absorbed.observed_area_m2;
  if (w > 0.0)
    into.mean_rgb = ((into.mean_rgb * into.observed_area_m2 + absorbed.mean_rgb * absorbed.observed_area_m2) / w)
                        .cast<float>();
  into.observed_area_m2 = w;
  into.area_m2 = into.footprint.area_m2();
  into.bounds.extend(absorbed.bounds);
  into.observations += absorbed.observations;
}

MergeReport GlobalMap::integrate(std::uint64_t frame_id, const Pose& T_world_cam,
                                 std::span<const Planecell> cells_world,
                                 std::span<const LabelEdge> image_adjacency) {
  const auto start = std::chrono::steady_clock::now();
  validate_pose(T_world_cam, "frame " + std::to_string(frame_id));
  MergeReport report;
  report.frame_id = frame_id;
  report.input_cells = cells_world.size();

  // 1. Usable new cells within range; fresh labels next_surface_id_ + k.
  const Eigen::Vector3d camera_centre = T_world_cam.translation();
  std::vector<const Planecell*> fresh;
  std::vector<std::size_t> fresh_input;  ///< index of fresh[k] in cells_world
  std::vector<double> fresh_area;
  report.cell_surfaces.assign(cells_world.size(), kNoSurface);
  std::unordered_map<std::uint32_t, std::uint32_t> unit_of_extraction_id;
  for (std::size_t i = 0; i < cells_world.size(); ++i) {
    const Planecell& cell = cells_world[i];
    if (!cell_is_usable(cell) ||
        (vertex_centroid(cell.vertices_m) - camera_centre).norm() > config_.max_range_m) {
      ++report.rejected_cells;
      continue;
    }
    unit_of_extraction_id[cell.id] = static_cast<std::uint32_t>(fresh.size());
    fresh.push_back(&cell);
    fresh_input.push_back(i);
    fresh_area.push_back(polygon_area_m2(cell.vertices_m));
  }
  if (fresh.size() > 0xFFFFFFFFull - next_surface_id_)
    throw StorageError("global map: surface labels exhausted");

  std::vector<MergeUnit> units;
  std::unordered_map<std::uint32_t, LabelState> labels;
  for (std::size_t k = 0; k < fresh.size(); ++k) {
    const auto label = next_surface_id_ + static_cast<std::uint32_t>(k);
    units.push_back({label, fresh[k], fresh_area[k]});
    labels.emplace(label, state_of_cell(*fresh[k], fresh_area[k]));
  }

  // 2. Neighbour edges: same frame (image adjacency, or 3D proximity), earlier cells (index).
  std::vector<MergeEdge> edges;
  const double gap = config_.neighbour_gap_m;
  auto metres_per_px = [&](std::size_t k) {
    const auto px = fresh[k]->area_px;
    return px > 0 ? std::sqrt(fresh_area[k] / px) : 0.01;
  };
  if (!image_adjacency.empty()) {
    for (const auto& e : image_adjacency) {
      auto ia = unit_of_extraction_id.find(e.a), ib = unit_of_extraction_id.find(e.b);
      if (ia == unit_of_extraction_id.end() || ib == unit_of_extraction_id.end()) continue;
      const double m_per_px = 0.5 * (metres_per_px(ia->second) + metres_per_px(ib->second));
      edges.push_back({ia->second, ib->second, e.boundary_px * m_per_px});
    }
  } else {
    SpatialIndex frame_index(config_.index_cell_m);
    for (std::size_t k = 0; k < fresh.size(); ++k)
      frame_index.insert(static_cast<std::uint32_t>(k), bounds_of(fresh[k]->vertices_m));
    for (std::size_t k = 0; k < fresh.size(); ++k)
      for (std::uint32_t j : frame_index.query(bounds_of(fresh[k]->vertices_m).inflated(gap))) {
        if (j <= k) continue;
        if (polygon_gap_m(fresh[k]->plane, fresh[k]->vertices_m, fresh[j]->plane,
                          fresh[j]->vertices_m) > gap)
          continue;
        edges.push_back({static_cast<std::uint32_t>(k), j,
                         std::sqrt(std::min(fresh_area[k], fresh_area[j]))});
      }
  }
  std::unordered_map<std::uint32_t, std::uint32_t> unit_of_map_cell;
  for (std::size_t k = 0; k < fresh.size(); ++k) {
    for (std::uint32_t id : index_.query(bounds_of(fresh[k]->vertices_m).inflated(gap))) {
      const Planecell& old = cells_.at(id);
      if (polygon_gap_m(fresh[k]->plane, fresh[k]->vertices_m, old.plane, old.vertices_m) > gap)
        continue;
      auto [it, inserted] = unit_of_map_cell.try_emplace(id, static_cast<std::uint32_t>(units.size()));
      if (inserted) {
        units.push_back({old.surface, &old, polygon_area_m2(old.vertices_m)});
        if (!labels.contains(old.surface)) labels.emplace(old.surface, state_of_surface(surfaces_.at(old.surface)));
      }
      edges.push_back({static_cast<std::uint32_t>(k), it->second,
                       std::sqrt(std::min(fresh_area[k], units[it->second].area_m2))});
    }
  }

  // 3. Circular greedy CRF merging.
  UnionFind union_find;
  const auto merges = merger_.merge(units, edges, labels, union_find);

  // 4. Surface merges between existing surfaces (root < absorbed, both existed before).
  std::set<std::uint32_t> touched;
  for (const auto& [absorbed, root] : merges) {
    if (absorbed >= next_surface_id_) continue;  // a fresh label joined a surface: not an event
    Surface& into = surfaces_.at(root);
    Surface& gone = surfaces_.at(absorbed);
    absorb_surface(into, gone, report);
    surfaces_.erase(absorbed);
    touched.erase(absorbed);
    touched.insert(root);
    report.removed_surfaces.push_back(absorbed);
    report.surface_merges.push_back({frame_id, absorbed, root});
  }
  for (const auto& [absorbed, root] : merges)
    if (root < next_surface_id_ && surfaces_.contains(root)) touched.insert(root);

  // 5. New cells: create surfaces for fresh roots, fuse or store each cell.
  for (std::size_t k = 0; k < fresh.size(); ++k) {
    const Planecell& cell = *fresh[k];
    const std::uint32_t root = union_find.find(units[k].label);
    auto [it, created] = surfaces_.try_emplace(root);
    Surface& surface = it->second;
    if (created) {
      surface.id = root;
      surface.basis = make_basis(labels.at(root).plane, vertex_centroid(cell.vertices_m));
      surface.footprint = Footprint(config_.footprint_resolution_m);
    }
    touched.insert(root);
    report.cell_surfaces[fresh_input[k]] = root;
    const double area = fresh_area[k];
    const bool had_footprint = !surface.footprint.empty();
    const double added = surface.footprint.add_polygon(to_polygon2(cell.vertices_m, surface.basis));
    const double w = surface.observed_area_m2 + area;
    surface.mean_rgb = ((surface.mean_rgb * surface.observed_area_m2 + cell.mean_rgb * area) / w).cast<float>();
    surface.observed_area_m2 = w;
    surface.area_m2 += added;  // incremental: per-frame work stays local to the new cells
    surface.bounds.extend(bounds_of(cell.vertices_m));
    ++surface.observations;
    if (had_footprint && added < config_.fuse_new_area_fraction * area) {
      ++report.fused_cells;
      continue;
    }
    Planecell stored = cell;
    stored.id = next_cell_id_++;
    stored.frame_id = frame_id;
    stored.surface = root;
    index_.insert(stored.id, bounds_of(stored.vertices_m));
    surface.cells.push_back(stored.id);
    report.added_cells.push_back(stored.id);
    cells_.emplace(stored.id, std::move(stored));
  }

  // 6. Surface descriptors from the merged label states.
  for (std::uint32_t id : touched) {
    Surface& surface = surfaces_.at(id);
    const LabelState& state = labels.at(id);
    surface.plane = state.plane;
    surface.moments = state.moments;
    surface.histogram = state.histogram;
    surface.histogram_weight_m2 = state.histogram_weight_m2;
  }
  report.updated_surfaces.assign(touched.begin(), touched.end());
  std::sort(report.relabelled_cells.begin(), report.relabelled_cells.end());
  report.relabelled_cells.erase(std::unique(report.relabelled_cells.begin(), report.relabelled_cells.end()),
                                report.relabelled_cells.end());
  next_surface_id_ += static_cast<std::uint32_t>(fresh.size());
  report.merge_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return report;
}

std::size_t GlobalMap::map_bytes() const {
  std::size_t total = hash_map_bytes(cells_) + hash_map_bytes(surfaces_) + index_.bytes();
  for (const auto& [id, cell] : cells_)
    total += cell.vertices_px.capacity() * sizeof(Eigen::Vector2f) +
             cell.vertices_m.capacity() * sizeof(Eigen::Vector3f);
  for (const auto& [id, surface] : surfaces_) {
    total += surface.cells.capacity() * sizeof(std::uint32_t);
    total += surface.footprint.bytes();
  }
  return total;
}

GlobalMap GlobalMap::restore(const MapConfig& config, std::vector<Planecell> cells,
                             std::vector<Surface> surfaces, std::uint32_t next_cell_id,
                             std::uint32_t next_surface_id) {
  GlobalMap map(config);
  for (auto& surface : surfaces) {
    const auto id = surface.id;
    map.surfaces_.emplace(id, std::move(surface));
  }
  for (auto& cell : cells) {
    if (!map.surfaces_.contains(cell.surface))
      throw StorageError("map restore: cell " + std::to_string(cell.id) + " names missing surface " +
                         std::to_string(cell.surface));
    map.index_.insert(cell.id, bounds_of(cell.vertices_m));
    const auto id = cell.id;
    map.cells_.emplace(id, std::move(cell));
  }
  map.next_cell_id_ = next_cell_id;
  map.next_surface_id_ = next_surface_id;
  return map;
}

bool GlobalMap::same_content(const GlobalMap& other) const {
  if (next_cell_id_ != other.next_cell_id_ || next_surface_id_ != other.next_surface_id_ ||
      cells_.size() != other.cells_.size() || surfaces_.size() != other.surfaces_.size())
    return false;
  for (const auto& [id, cell] : cells_) {
    const Planecell* o = other.cell(id);
    if (!o || !cells_equal(cell, *o)) return false;
  }
  for (const auto& [id, surface] : surfaces_) {
    const Surface* o = other.surface(id);
    if (!o || !surfaces_equal(surface, *o)) return false;
  }
  return true;
}

}  // namespace planecell::map
