/// `planecell synth` — renders the synthetic street as a KITTI-odometry-layout sequence with
/// ground truth (disparity, surface ids, scene.yaml).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "core/error.hpp"
#include "io/kitti_odometry.hpp"
#include "io/synthetic/pose_noise.hpp"
#include "io/synthetic/synthetic_world.hpp"
#include "services/commands/commands.hpp"

namespace planecell::services {
namespace {

struct SynthOptions {
  std::string out_dir;
  std::optional<int> frames, width, height;
  std::optional<std::uint64_t> seed;
  bool loop = false;
  std::optional<double> noise;
  std::string pose_noise;
};

}  // namespace

void add_synth_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<SynthOptions>();
  auto* command = app.add_subcommand(
      "synth",
      "Render a synthetic KITTI-like street (textured planes) seen from a driving stereo rig.\n"
      "Writes the KITTI odometry layout (image_2/, image_3/, calib.txt, poses/00.txt, times.txt)\n"
      "plus ground truth: disp_occ_0/ (KITTI 16-bit disparity), disp_noc_0/ (the same where the right\n"
      "camera sees the point too), surface_0/ (16-bit surface ids, 0 = sky) and scene.yaml (every surface's plane and polygon). Deterministic per --seed.\n"
      "Options override the `synth` section of --config.");
  command->add_option("-o,--out", options->out_dir, "Output folder (created if needed)")
      ->required();
  command->add_option("-n,--frames", options->frames, "Number of frames (10 Hz)");
  command->add_option("-s,--seed", options->seed, "World seed (same seed = identical output)");
  command->add_option("--width", options->width, "Image width in px (64..8192; intrinsics scale)");
  command->add_option("--height", options->height, "Image height in px (32..8192)");
  command->add_flag("--loop", options->loop,
                    "Drive around a closed block twice (the second lap re-observes the first)");
  command->add_option("--noise", options->noise, "Sensor noise sigma in grey levels (0 = none)");
  command->add_option("--pose-noise", options->pose_noise,
                      "TRANS_PER_M,ROT_DEG_PER_M[,TRANS_PER_STEP_M,ROT_DEG_PER_STEP]: also write\n"
                      "poses_noisy.txt (KITTI format, in the output folder) with seeded random-walk\n"
                      "odometry drift, e.g. 0.01,0.1 = 1 % and 0.1 deg per metre driven (the optional\n"
                      "floors err every frame, driven or not); replay it with\n"
                      "`replay --poses OUT/poses_noisy.txt`");
  context.add(command, [options](const CommandContext& ctx) {
    SynthConfig config = ctx.load_app_config().synth;
    if (options->frames) config.frames = *options->frames;
    if (options->seed) config.seed = *options->seed;
    if (options->width) config.width = *options->width;
    if (options->height) config.height = *options->height;
    if (options->noise) config.sensor_noise_sigma = *options->noise;
    if (options->loop) config.loop = true;
    const std::optional<io::PoseDrift> pose_drift =
        options->pose_noise.empty() ? std::nullopt
                                    : std::optional(io::parse_pose_drift(options->pose_noise));
    const std::filesystem::path out_dir(options->out_dir);
    if (std::filesystem::exists(out_dir) && !std::filesystem::is_directory(out_dir))
      throw StorageError("output folder '" + out_dir.string() + "' exists and is not a folder");

    const auto start = std::chrono::steady_clock::now();
    const io::SyntheticWorld world = io::make_street_world(config);
    spdlog::info("synth: {} surfaces, {} frames at {}x{}, path {:.1f} m{}", world.surfaces.size(),
                 world.trajectory.size(), config.width, config.height, world.path_length_m,
                 config.loop ? " (two laps of a closed block)" : "");
    int last_decile = 0;
    const auto stats = io::write_sequence(
        world, out_dir,
        [&](std::size_t done, std::size_t total) {
          const int decile = static_cast<int>(10 * done / total);
          if (decile > last_decile) {
            last_decile = decile;
            spdlog::info("synth: {}/{} frames ({}%)", done, total, 10 * decile);
          }
        },
        config.png_compression);
    if (pose_drift) {  // noisy odometry beside the ground truth (same seed as the world)
      io::write_kitti_poses(out_dir / "poses_noisy.txt",
                        io::add_odometry_drift(world.trajectory, *pose_drift, config.seed));
      spdlog::info("synth: noisy odometry ({} m/m, {} deg/m) in {}", pose_drift->translation_per_m,
                   pose_drift->rotation_deg_per_m, (out_dir / "poses_noisy.txt").string());
    }
    const double total_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double n = static_cast<double>(std::max<std::size_t>(stats.frames, 1));
    spdlog::info(
        "synth: done: {} frames {}x{}, path {:.1f} m, {} surfaces, {:.2f} s ({:.1f} fps); "
        "render {:.1f} ms/frame, write {:.1f} ms/frame; output {}",
        stats.frames, config.width, config.height, stats.path_length_m, stats.surfaces, total_s,
        stats.frames / std::max(total_s, 1e-9), stats.render_ms / n, stats.write_ms / n,
        out_dir.string());
    return kExitOk;
  });
}

}  // namespace planecell::services
