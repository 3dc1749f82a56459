/// A small box scene with exact planes for other modules' unit tests.
#include <cmath>

#include "core/error.hpp"
#include "io/synthetic/synthetic_world.hpp"

namespace planecell::io {

SyntheticWorld make_box_world(int width, int height, std::uint64_t seed, int frames) {
  if (width < 16 || height < 16 || width > 8192 || height > 8192)
    throw ConfigError("make_box_world: width/height must be in 16..8192 px, got " +
                      std::to_string(width) + "x" + std::to_string(height));
  if (frames < 1) throw ConfigError("make_box_world: frames must be >= 1");
  SyntheticWorld world;
  world.seed = seed;
  world.camera.fx = 721.5377 * width / 1242.0;
  world.camera.fy = world.camera.fx;
  world.camera.cx = width / 2.0 - 0.5;
  world.camera.cy = height / 2.0 - 0.5;
  world.camera.baseline_m = 0.54;
  world.camera.width = width;
  world.camera.height = height;

  auto texture = [&](const Eigen::Vector3d& rgb, double amplitude, double wavelength_m,
                     std::uint32_t k) {
    SurfaceTexture t;
    t.colour_rgb = rgb;
    t.amplitude = amplitude;
    t.base_wavelength_m = wavelength_m;
    t.seed = static_cast<std::uint32_t>(seed * 1000003u + k);
    return t;
  };
  const Eigen::Vector3d up(0, -1, 0), x(1, 0, 0), z(0, 0, 1);
  auto& s = world.surfaces;
  // Ground y = 1.5 (normal up), x ∈ [−20, 20], z ∈ [0.5, 30].
  s.push_back(make_surface(1, SurfaceKind::kRoad, Eigen::Vector3d(0, 1.5, 0), x, z,
                           {{-20, 0.5}, {20, 0.5}, {20, 30}, {-20, 30}},
                           texture({0.4, 0.4, 0.42}, 0.4, 0.01, 1)));
  // Back wall z = 14 facing the camera (u = +x, v = up → n = u × v = (0, 0, −1)).
  s.push_back(make_rectangle(2, SurfaceKind::kFacade, Eigen::Vector3d(-15, 1.5, 14), x, up, 30,
                             9.5, texture({0.7, 0.6, 0.5}, 0.45, 0.02, 2)));
  // Fronto-parallel box face at z = 6: x ∈ [−1.8, −0.2], height 1.8.
  s.push_back(make_rectangle(3, SurfaceKind::kBox, Eigen::Vector3d(-1.8, 1.5, 6), x, up, 1.6,
                             1.8, texture({0.2, 0.4, 0.7}, 0.4, 0.01, 3)));
  // Slanted panel: normal (sin 40°, 0, −cos 40°), 2 m × 1.6 m, from (0.8, 1.1, 7.5).
  const double a = 40.0 * M_PI / 180.0;
  s.push_back(make_rectangle(4, SurfaceKind::kBox, Eigen::Vector3d(0.8, 1.1, 7.5),
                             Eigen::Vector3d(std::cos(a), 0, std::sin(a)), up, 2.0, 1.6,
                             texture({0.7, 0.3, 0.2}, 0.4, 0.01, 4)));
  // Weakly textured panel at z = 10, x ∈ [−4.5, −3.0].
  s.push_back(make_rectangle(5, SurfaceKind::kBox, Eigen::Vector3d(-4.5, 0.5, 10), x, up, 1.5,
                             1.5, texture({0.5, 0.55, 0.6}, 0.03, 0.05, 5)));
  for (int i = 0; i < frames; ++i) {
    Pose pose = Pose::Identity();
    pose.translation() = Eigen::Vector3d(0, 0, 0.3 * i);
    world.trajectory.push_back(pose);
  }
  world.path_length_m = 0.3 * (frames - 1);
  return world;
}

}  // namespace planecell::io
