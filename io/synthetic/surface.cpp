/// Synthetic surfaces: construction helpers and kind names.
#include <array>
#include <cmath>

#include "core/error.hpp"
#include "io/synthetic/synthetic_world.hpp"

namespace planecell::io {
namespace {

constexpr std::array<const char*, 12> kKindNames{"road",   "curb",   "sidewalk", "facade",
                                                 "wall",   "door",   "window",   "awning",
                                                 "car",    "pole",   "background", "box"};

}  // namespace

std::string to_string(SurfaceKind kind) { return kKindNames.at(static_cast<std::size_t>(kind)); }

SurfaceKind surface_kind_from_string(const std::string& text) {
  for (std::size_t i = 0; i < kKindNames.size(); ++i)
    if (text == kKindNames[i]) return static_cast<SurfaceKind>(i);
  throw InputError("surface kind '" + text + "' is unknown");
}

std::vector<Eigen::Vector3d> SyntheticSurface::corners_world() const {
  std::vector<Eigen::Vector3d> corners;
  corners.reserve(polygon.size());
  for (const auto& p : polygon) corners.push_back(origin + p.x() * u_axis + p.y() * v_axis);
  return corners;
}

SyntheticSurface make_surface(std::uint16_t id, SurfaceKind kind, const Eigen::Vector3d& origin,
                              const Eigen::Vector3d& u_axis, const Eigen::Vector3d& v_axis,
                              std::vector<Eigen::Vector2d> polygon, const SurfaceTexture& texture) {
  if (std::abs(u_axis.norm() - 1.0) > 1e-9 || std::abs(v_axis.norm() - 1.0) > 1e-9 ||
      std::abs(u_axis.dot(v_axis)) > 1e-9)
    throw InputError("synthetic surface " + std::to_string(id) +
                     ": u_axis and v_axis must be orthonormal");
  if (polygon.size() < 3)
    throw InputError("synthetic surface " + std::to_string(id) + ": polygon needs >= 3 corners");
  SyntheticSurface s;
  s.id = id;
  s.kind = kind;
  s.origin = origin;
  s.u_axis = u_axis;
  s.v_axis = v_axis;
  s.polygon = std::move(polygon);
  s.texture = texture;
  s.plane.normal = u_axis.cross(v_axis).normalized();
  s.plane.offset = -s.plane.normal.dot(origin);
  return s;
}

SyntheticSurface make_rectangle(std::uint16_t id, SurfaceKind kind, const Eigen::Vector3d& origin,
                                const Eigen::Vector3d& u_axis, const Eigen::Vector3d& v_axis,
                                double width_m, double height_m, const SurfaceTexture& texture) {
  if (!(width_m > 0.0) || !(height_m > 0.0))
    throw InputError("synthetic surface " + std::to_string(id) + ": rectangle size must be > 0");
  return make_surface(id, kind, origin, u_axis, v_axis,
                      {{0.0, 0.0}, {width_m, 0.0}, {width_m, height_m}, {0.0, height_m}}, texture);
}

}  // namespace planecell::io
