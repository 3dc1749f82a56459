/// `planecell import-euroc` — a EuRoC MAV sequence (ASL layout) rectified into the KITTI odometry
/// layout, so that every sequence command (replay, feed, bench, info) reads it.
#include <spdlog/spdlog.h>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "core/error.hpp"
#include "io/euroc.hpp"
#include "io/euroc_to_kitti.hpp"
#include "io/kitti_odometry.hpp"
#include "io/synthetic/pose_noise.hpp"
#include "services/commands/commands.hpp"

namespace planecell::services {
namespace {

struct ImportEurocOptions {
  std::string euroc_dir, out_dir, groundtruth, pose_noise;
  std::uint64_t seed = 1;
};

}  // namespace

void add_import_euroc_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<ImportEurocOptions>();
  auto* command = app.add_subcommand(
      "import-euroc",
      "Rectify a EuRoC MAV sequence (mav0/cam0, cam1, ground truth) and write it in the KITTI\n"
      "odometry layout (image_0/, image_1/, calib.txt, times.txt, poses/00.txt), so that replay,\n"
      "feed and bench read it. Only stereo pairs with a ground-truth pose within 20 ms are written;\n"
      "poses are expressed in the first written frame's rectified camera (x right, y down, z\n"
      "forward), as KITTI's are. Use config/euroc.yaml for the stage settings.");
  command->add_option("sequence", options->euroc_dir, "EuRoC folder (mav0, or the folder holding it)")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("-o,--out", options->out_dir, "Output folder (created if needed)")->required();
  command->add_option("--gt", options->groundtruth,
                      "Ground-truth file (TUM txt or EuRoC csv) instead of the sequence's own")
      ->check(CLI::ExistingFile);
  command->add_option("--pose-noise", options->pose_noise,
                      "TRANS_PER_M,ROT_DEG_PER_M[,TRANS_PER_STEP_M,ROT_DEG_PER_STEP]: also write\n"
                      "poses_noisy.txt with seeded odometry drift (as `synth --pose-noise`); a hovering\n"
                      "MAV drives few metres, so give the per-frame floors, e.g. 0.01,0.1,0.002,0.03");
  command->add_option("--seed", options->seed, "Seed of the pose noise")->capture_default_str();
  command->footer(
      "Example:\n"
      "  planecell import-euroc ~/euroc/V1_01_easy -o /tmp/v101 --pose-noise 0.01,0.1,0.002,0.03\n"
      "  planecell --config config/euroc.yaml replay /tmp/v101 --poses /tmp/v101/poses_noisy.txt");
  context.add(command, [options](const CommandContext&) {
    const std::optional<io::PoseDrift> drift =
        options->pose_noise.empty() ? std::nullopt : std::optional(io::parse_pose_drift(options->pose_noise));
    const std::filesystem::path out_dir(options->out_dir);
    if (std::filesystem::exists(out_dir) && !std::filesystem::is_directory(out_dir))
      throw StorageError("output folder '" + out_dir.string() + "' exists and is not a folder");
    const io::EurocSequence sequence = io::open_euroc(
        options->euroc_dir, options->groundtruth.empty()
                                ? std::nullopt
                                : std::optional<std::filesystem::path>(options->groundtruth));
    const io::EurocExport written = io::write_euroc_as_kitti(sequence, out_dir);
    spdlog::info("import-euroc: {} frames {}x{} (fx {:.1f} px, baseline {:.3f} m) to {}; {} without a pose skipped",
                 written.frames, written.camera.width, written.camera.height, written.camera.fx,
                 written.camera.baseline_m, out_dir.string(), written.skipped_frames);
    if (drift) {
      io::write_kitti_poses(out_dir / "poses_noisy.txt",
                            io::add_odometry_drift(written.poses, *drift, options->seed));
      spdlog::info("import-euroc: noisy odometry ({} m/m, {} deg/m) in {}", drift->translation_per_m,
                   drift->rotation_deg_per_m, (out_dir / "poses_noisy.txt").string());
    }
    return kExitOk;
  });
}

}  // namespace planecell::services
