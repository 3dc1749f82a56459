#pragma once
/// Configuration of the global map, CRF merger and voxel baseline (mapping/map, mapping/voxel).

namespace planecell {

/// Global planecell map and incremental CRF merging (paper §5.2).
struct MapConfig {
  double max_range_m = 40.0;  ///< cells farther than this from the camera are not mapped
};

template <class Visitor>
void visit_fields(MapConfig& c, Visitor&& visit) {
  visit("max_range_m", c.max_range_m);
}

/// OctoMap voxel baseline (paper's 10 cm voxel map).
struct VoxelConfig {
  double resolution_m = 0.10;
  double max_range_m = 40.0;
  bool ray_casting = false;  ///< insertPointCloud with free-space ray casting (slow)
};

template <class Visitor>
void visit_fields(VoxelConfig& c, Visitor&& visit) {
  visit("resolution_m", c.resolution_m);
  visit("max_range_m", c.max_range_m);
  visit("ray_casting", c.ray_casting);
}

}  // namespace planecell
