#include "io/outline_export.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "mapping/map/surface_outline.hpp"

namespace planecell::io {
namespace {

/// x rounded to 0.1 mm (the outline is exact to the footprint's bits, 10 cm by default).
double round_m(double x) { return std::round(x * 1e4) / 1e4; }

}  // namespace

OutlineExport write_outlines_json(const std::filesystem::path& path, const map::GlobalMap& map,
                                  double tolerance_m) {
  if (!(tolerance_m >= 0.0) || !std::isfinite(tolerance_m))
    throw InputError("outlines '" + path.string() +
                     "': tolerance must be a finite number ≥ 0 m, got " +
                     std::to_string(tolerance_m));
  std::vector<std::uint32_t> ids;
  ids.reserve(map.surfaces().size());
  for (const auto& [id, surface] : map.surfaces()) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  OutlineExport counts;
  nlohmann::json surfaces = nlohmann::json::array();
  for (const std::uint32_t id : ids) {
    const map::Surface& surface = *map.surface(id);
    const std::vector<map::OutlineRing> outline = map::surface_outline(surface.plane, map.surface_detail(id), tolerance_m);
    if (outline.empty()) continue;
    nlohmann::json rings = nlohmann::json::array();
    for (const auto& ring : outline) {
      nlohmann::json vertices = nlohmann::json::array();
      for (const auto& v : ring.vertices_m)
        vertices.push_back({round_m(v.x()), round_m(v.y()), round_m(v.z())});
      counts.vertices += ring.vertices_m.size();
      rings.push_back({{"hole", ring.hole}, {"vertices", std::move(vertices)}});
    }
    counts.rings += outline.size();
    ++counts.surfaces;
    const Eigen::Vector3d n = surface.plane.normal();
    surfaces.push_back(
        {{"id", id},
         {"plane", {n.x(), n.y(), n.z(), surface.plane.offset()}},
         {"mean_rgb", {surface.mean_rgb.x(), surface.mean_rgb.y(), surface.mean_rgb.z()}},
         {"area_m2", surface.area_m2},
         {"observations", surface.observations},
         {"rings", std::move(rings)}});
  }
  const nlohmann::json out = {{"format", "planecell-outlines"},
                              {"version", 1},
                              {"frame", "world"},
                              {"units", "m"},
                              {"footprint_resolution_m", map.config().footprint_resolution_m},
                              {"tolerance_m", tolerance_m},
                              {"surfaces", std::move(surfaces)}};
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  std::ofstream file(path, std::ios::trunc);
  if (!file) throw StorageError("outlines '" + path.string() + "': cannot open for writing");
  file << out.dump() << '\n';
  file.flush();
  if (!file) throw StorageError("outlines '" + path.string() + "': write failed (disk full?)");
  return counts;
}

}  // namespace planecell::io
