/// Writes a synthetic world as a KITTI-odometry-layout sequence with ground truth and scene.yaml.
#include <yaml-cpp/yaml.h>

#include <array>
#include <chrono>
#include <fstream>
#include <future>
#include <memory>
#include <string>

#include "core/error.hpp"
#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"
#include "io/synthetic/synthetic_world.hpp"

namespace planecell::io {
namespace {

using Clock = std::chrono::steady_clock;

double elapsed_ms(Clock::time_point since) {
  return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

void emit_vector(YAML::Emitter& out, const Eigen::Vector3d& v) {
  out << YAML::Flow << YAML::BeginSeq << v.x() << v.y() << v.z() << YAML::EndSeq;
}

Eigen::Vector3d read_vector3(const YAML::Node& node, const std::string& where) {
  if (!node || !node.IsSequence() || node.size() != 3)
    throw InputError(where + ": expected a list of 3 numbers");
  return {node[0].as<double>(), node[1].as<double>(), node[2].as<double>()};
}

/// P = K [I | t] with t = (−fx·B, 0, 0) for the right camera (KITTI convention).
std::array<double, 12> projection(const StereoCamera& cam, double tx) {
  return {cam.fx, 0.0, cam.cx, tx, 0.0, cam.fy, cam.cy, 0.0, 0.0, 0.0, 1.0, 0.0};
}

}  // namespace

void write_scene_yaml(const std::filesystem::path& path, const SyntheticWorld& world) {
  YAML::Emitter out;
  out.SetDoublePrecision(12);
  out << YAML::BeginMap;
  out << YAML::Key << "frame" << YAML::Value
      << "world = first left camera (x right, y down, z forward), metres";
  out << YAML::Key << "camera" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "fx" << YAML::Value << world.camera.fx << YAML::Key << "fy" << YAML::Value
      << world.camera.fy << YAML::Key << "cx" << YAML::Value << world.camera.cx << YAML::Key
      << "cy" << YAML::Value << world.camera.cy << YAML::Key << "baseline_m" << YAML::Value
      << world.camera.baseline_m << YAML::Key << "width" << YAML::Value << world.camera.width
      << YAML::Key << "height" << YAML::Value << world.camera.height << YAML::EndMap;
  out << YAML::Key << "frames" << YAML::Value << world.trajectory.size();
  out << YAML::Key << "frame_rate_hz" << YAML::Value << world.frame_rate_hz;
  out << YAML::Key << "seed" << YAML::Value << world.seed;
  out << YAML::Key << "loop" << YAML::Value << world.loop;
  out << YAML::Key << "path_length_m" << YAML::Value << world.path_length_m;
  out << YAML::Key << "surfaces" << YAML::Value << YAML::BeginSeq;
  for (const auto& s : world.surfaces) {
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << s.id;
    out << YAML::Key << "kind" << YAML::Value << to_string(s.kind);
    out << YAML::Key << "normal" << YAML::Value;
    emit_vector(out, s.plane.normal);
    out << YAML::Key << "offset" << YAML::Value << s.plane.offset;
    out << YAML::Key << "origin" << YAML::Value;
    emit_vector(out, s.origin);
    out << YAML::Key << "u_axis" << YAML::Value;
    emit_vector(out, s.u_axis);
    out << YAML::Key << "v_axis" << YAML::Value;
    emit_vector(out, s.v_axis);
    out << YAML::Key << "polygon" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const auto& p : s.polygon)
      out << YAML::Flow << YAML::BeginSeq << p.x() << p.y() << YAML::EndSeq;
    out << YAML::EndSeq;
    out << YAML::Key << "corners" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const auto& c : s.corners_world()) emit_vector(out, c);
    out << YAML::EndSeq;
    out << YAML::Key << "texture" << YAML::Value << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "colour_rgb" << YAML::Value;
    emit_vector(out, s.texture.colour_rgb);
    out << YAML::Key << "amplitude" << YAML::Value << s.texture.amplitude;
    out << YAML::Key << "base_wavelength_m" << YAML::Value << s.texture.base_wavelength_m;
    out << YAML::Key << "seed" << YAML::Value << s.texture.seed;
    out << YAML::EndMap;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  std::ofstream file(path);
  if (!file) throw StorageError("scene '" + path.string() + "': cannot open for writing");
  file << out.c_str() << '\n';
  file.flush();
  if (!file) throw StorageError("scene '" + path.string() + "': write failed (disk full?)");
}

std::vector<SyntheticSurface> read_scene_surfaces(const std::filesystem::path& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path.string());
  } catch (const YAML::BadFile&) {
    throw InputError("scene '" + path.string() + "': file not found or unreadable");
  } catch (const YAML::Exception& e) {
    throw InputError("scene '" + path.string() + "': not valid YAML (" + e.what() + ")");
  }
  const YAML::Node list = root["surfaces"];
  if (!list || !list.IsSequence())
    throw InputError("scene '" + path.string() + "': missing 'surfaces' list");
  std::vector<SyntheticSurface> surfaces;
  surfaces.reserve(list.size());
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string where = "scene '" + path.string() + "' surface #" + std::to_string(i);
    const YAML::Node node = list[i];
    try {
      std::vector<Eigen::Vector2d> polygon;
      for (const auto& p : node["polygon"]) {
        if (!p.IsSequence() || p.size() != 2) throw InputError(where + ": polygon corner needs 2 numbers");
        polygon.emplace_back(p[0].as<double>(), p[1].as<double>());
      }
      SurfaceTexture texture;
      const YAML::Node tex = node["texture"];
      if (!tex) throw InputError(where + ": missing texture");
      texture.colour_rgb = read_vector3(tex["colour_rgb"], where + " texture.colour_rgb");
      texture.amplitude = tex["amplitude"].as<double>();
      texture.base_wavelength_m = tex["base_wavelength_m"].as<double>();
      texture.seed = tex["seed"].as<std::uint32_t>();
      const int id = node["id"].as<int>();
      if (id < 1 || id > 65535) throw InputError(where + ": id must be in 1..65535");
      surfaces.push_back(make_surface(static_cast<std::uint16_t>(id),
                                      surface_kind_from_string(node["kind"].as<std::string>()),
                                      read_vector3(node["origin"], where + " origin"),
                                      read_vector3(node["u_axis"], where + " u_axis"),
                                      read_vector3(node["v_axis"], where + " v_axis"),
                                      std::move(polygon), texture));
    } catch (const YAML::Exception& e) {
      throw InputError(where + ": missing or malformed field (" + e.what() + ")");
    } catch (const InputError& e) {
      if (std::string(e.what()).rfind("scene '", 0) == 0) throw;
      throw InputError(where + ": " + e.what());
    }
  }
  return surfaces;
}

SequenceStats write_sequence(const SyntheticWorld& world, const std::filesystem::path& out_dir,
                             const ProgressCallback& progress, int png_compression) {
  if (png_compression < 0 || png_compression > 9)
    throw ConfigError("write_sequence: png_compression must be in 0..9");
  for (const char* sub : {"image_2", "image_3", "disp_occ_0", "disp_noc_0", "surface_0", "poses"}) {
    std::error_code ec;
    std::filesystem::create_directories(out_dir / sub, ec);
    if (ec)
      throw StorageError("output folder '" + (out_dir / sub).string() +
                         "': cannot create: " + ec.message());
  }
  {  // Fail early (before rendering) when the folder is not writable.
    const auto probe = out_dir / ".planecell_write_probe";
    std::ofstream test(probe);
    if (!test) throw StorageError("output folder '" + out_dir.string() + "': not writable");
    test.close();
    std::filesystem::remove(probe);
  }
  SequenceStats stats;
  stats.surfaces = world.surfaces.size();
  stats.path_length_m = world.path_length_m;
  const std::size_t total = world.trajectory.size();
  // Frame i is encoded by two background tasks (left + disparity, right + surface ids) while
  // frame i + 1 renders: PNG encoding costs ~3x the rendering, so the two cores share it.
  // Task exceptions (StorageError) surface through get().
  std::future<double> pending[2];
  std::size_t pending_frame = 0;
  auto finish_pending = [&] {
    if (!pending[0].valid()) return;
    for (auto& task : pending) stats.write_ms += task.get();
    ++stats.frames;
    if (progress) progress(pending_frame + 1, total);
  };
  for (std::size_t i = 0; i < total; ++i) {
    const auto render_start = Clock::now();
    auto view = std::make_shared<const SyntheticView>(render_view(world, world.trajectory[i], i));
    stats.render_ms += elapsed_ms(render_start);
    finish_pending();
    const std::string name = kitti_frame_name(i);
    pending[0] = std::async(std::launch::async, [=] {
      const auto start = Clock::now();
      write_image(out_dir / "image_2" / name, view->left, png_compression);
      write_kitti_disparity(out_dir / "disp_occ_0" / name, view->disparity, png_compression);
      return elapsed_ms(start);
    });
    pending[1] = std::async(std::launch::async, [=] {
      const auto start = Clock::now();
      write_image(out_dir / "image_3" / name, view->right, png_compression);
      write_image(out_dir / "surface_0" / name, view->surface_id, png_compression);
      write_kitti_disparity(out_dir / "disp_noc_0" / name, non_occluded_disparity(*view),
                            png_compression);
      return elapsed_ms(start);
    });
    pending_frame = i;
  }
  finish_pending();
  KittiCalibration calib;
  const auto& cam = world.camera;
  calib.projection[0] = calib.projection[2] = projection(cam, 0.0);
  calib.projection[1] = calib.projection[3] = projection(cam, -cam.fx * cam.baseline_m);
  write_kitti_calibration(out_dir / "calib.txt", calib);
  write_kitti_poses(out_dir / "poses" / "00.txt", world.trajectory);
  std::vector<double> times(total);
  for (std::size_t i = 0; i < total; ++i) times[i] = static_cast<double>(i) / world.frame_rate_hz;
  write_kitti_times(out_dir / "times.txt", times);
  write_scene_yaml(out_dir / "scene.yaml", world);
  return stats;
}

}  // namespace planecell::io
