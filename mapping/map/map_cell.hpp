#pragma once
/// The planecell as the global map keeps it: its world-frame plane and polygon, colour, depth
/// noise, provenance and surface label. The image-side fields of a Planecell (disparity plane,
/// pixel polygon, colour histogram, pixel and inlier counts) stay with the frame: a stored cell's
/// colour evidence lives in its surface's histogram. Header-only: io (map store, LCM) uses it
/// without linking planecell_mapping.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/plane.hpp"
#include "core/planecell.hpp"
#include "mapping/map/geometry.hpp"
#include "mapping/map/stored_polygon.hpp"

namespace planecell::map {

struct MapCell {
  std::uint32_t id = 0;                 ///< map cell id
  std::uint32_t surface = kNoSurface;   ///< CRF surface label
  std::uint64_t frame_id = 0;           ///< frame it was extracted from
  StoredPlane plane;                    ///< n·X + e = 0, world frame (storage precision)
  StoredPolygon vertices_m;  ///< ordered polygon, world frame (mm grid: 6 B a vertex)
  StoredColour mean_rgb;  ///< 0..255, R G B order, whole numbers (a byte a channel)
  /// 1-σ depth uncertainty of the plane at the polygon's centroid (m; Planecell::depth_sigma_m).
  float depth_sigma_m = 0.0f;

  bool operator==(const MapCell& o) const {
    return id == o.id && surface == o.surface && frame_id == o.frame_id &&
           plane == o.plane &&
           vertices_m == o.vertices_m && mean_rgb == o.mean_rgb && depth_sigma_m == o.depth_sigma_m;
  }
};

/// The map's record of world-frame planecell `cell` under map id `id`, from frame `frame_id`,
/// on surface `surface`, at storage precision: plane as floats, vertices on the 1 mm grid
/// (on_mm_grid), colour as bytes.
inline MapCell map_cell_of(const Planecell& cell, std::uint32_t id, std::uint64_t frame_id,
                           std::uint32_t surface) {
  MapCell m;
  m.id = id;
  m.surface = surface;
  m.frame_id = frame_id;
  m.plane = cell.plane;
  m.vertices_m = on_mm_grid(cell.vertices_m);
  m.mean_rgb = cell.mean_rgb;
  m.depth_sigma_m = cell.depth_sigma_m;
  return m;
}

}  // namespace planecell::map
