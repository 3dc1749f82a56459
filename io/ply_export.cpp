/// PLY export of planecells as triangulated polygons (see ply_export.hpp).
#include "io/ply_export.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>

#include "core/error.hpp"
#include "mapping/map/triangulate.hpp"

namespace planecell::io {
namespace {

struct ColouredVertex {
  Eigen::Vector3f position;
  std::array<std::uint8_t, 3> rgb;
};

template <class T>
void put(std::ofstream& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // little-endian host (x86-64 / ARM64 Linux)
  out.write(bytes, sizeof(T));
}

bool drawable(const Planecell& cell) { return cell.has_plane; }
bool drawable(const map::MapCell&) { return true; }

/// The body of write_planecells_ply for either cell type (vertices_m, mean_rgb).
template <class Cell>
std::size_t write_polygons(const std::filesystem::path& path, const std::vector<Cell>& cells,
                           bool binary) {
  std::vector<ColouredVertex> vertices;
  std::vector<std::array<std::int32_t, 3>> faces;
  for (const Cell& cell : cells) {
    const std::size_t n = cell.vertices_m.size();
    if (!drawable(cell) || n < 3) continue;
    std::array<std::uint8_t, 3> rgb;
    for (int c = 0; c < 3; ++c)
      rgb[c] = static_cast<std::uint8_t>(std::clamp(std::round(cell.mean_rgb[c]), 0.0f, 255.0f));
    const auto base = static_cast<std::int32_t>(vertices.size());
    for (const auto& v : cell.vertices_m) vertices.push_back({v, rgb});
    std::vector<Eigen::Vector3f> scratch;
    for (const auto& [i, j, k] : map::triangulate_polygon(map::as_span(cell.vertices_m, scratch)))
      faces.push_back({base + i, base + j, base + k});
  }

  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw StorageError("PLY '" + path.string() + "': cannot open for writing");
  out << "ply\nformat " << (binary ? "binary_little_endian" : "ascii") << " 1.0\n"
      << "comment planecell cells as triangulated polygons\n"
      << "element vertex " << vertices.size() << "\n"
      << "property float x\nproperty float y\nproperty float z\n"
      << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      << "element face " << faces.size() << "\n"
      << "property list uchar int vertex_indices\nend_header\n";
  if (binary) {
    for (const auto& v : vertices) {
      for (int k = 0; k < 3; ++k) put(out, v.position[k]);
      for (std::uint8_t c : v.rgb) put(out, c);
    }
    for (const auto& f : faces) {
      put(out, static_cast<std::uint8_t>(3));
      for (std::int32_t i : f) put(out, i);
    }
  } else {
    for (const auto& v : vertices)
      out << v.position.x() << ' ' << v.position.y() << ' ' << v.position.z() << ' '
          << int(v.rgb[0]) << ' ' << int(v.rgb[1]) << ' ' << int(v.rgb[2]) << '\n';
    for (const auto& f : faces) out << "3 " << f[0] << ' ' << f[1] << ' ' << f[2] << '\n';
  }
  out.flush();
  if (!out) throw StorageError("PLY '" + path.string() + "': write failed (disk full?)");
  return faces.size();
}

}  // namespace

std::size_t write_planecells_ply(const std::filesystem::path& path,
                                 const std::vector<Planecell>& cells, bool binary) {
  return write_polygons(path, cells, binary);
}

std::size_t write_planecells_ply(const std::filesystem::path& path,
                                 const std::vector<map::MapCell>& cells, bool binary) {
  return write_polygons(path, cells, binary);
}

}  // namespace planecell::io
