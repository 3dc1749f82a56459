/// `planecell feed SEQ_DIR` — publishes a KITTI-odometry-layout sequence's stereo frames and poses
/// over LCM at a given rate: a client for `planecell run`, or a dataset player for other stacks.
#include <spdlog/spdlog.h>

#include <chrono>
#include <iostream>
#include <memory>
#include <thread>

#include "core/error.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"
#include "services/commands/commands.hpp"
#include "services/pipeline/lcm_link.hpp"
#include "services/replay.hpp"

namespace planecell::services {

void add_feed_command(CLI::App& app, CommandContext& context) {
  auto* command = app.add_subcommand(
      "feed",
      "Publish a sequence's stereo frames (stereo_frame_t, PNG or raw) and poses (pose_t) over LCM "
      "at --rate frames per second; each frame's pose goes out just before its images. PNG files "
      "are sent as they are (no decoding: the receiver checks them).");
  struct Args {
    std::string sequence, lcm_url, frames, poses;
    double rate_hz = 10.0;
    bool raw = false;
  };
  auto args = std::make_shared<Args>();
  command->add_option("sequence", args->sequence, "Sequence folder (image_2/3 or image_0/1, calib.txt, poses)")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("--rate", args->rate_hz, "Frames per second (0 = as fast as possible)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command->add_option("--lcm", args->lcm_url, "LCM URL (default: lcm.url of the config)");
  command->add_option("--frames", args->frames, "Frame range A:B (B exclusive)");
  command->add_option("--poses", args->poses, "KITTI pose file to use instead of the sequence's own")
      ->check(CLI::ExistingFile);
  command->add_flag("--raw", args->raw, "Send raw pixels instead of PNG (bigger messages)");
  command->footer("Example:\n  planecell feed /tmp/street --rate 10 --frames 0:50");
  context.add(command, [args](const CommandContext& ctx) {
    AppConfig config = ctx.load_app_config();
    if (!args->lcm_url.empty()) config.lcm.url = args->lcm_url;
    std::optional<std::filesystem::path> poses;
    if (!args->poses.empty()) poses = args->poses;
    const auto sequence = io::open_kitti_odometry(args->sequence, poses);
    if (sequence.poses.empty())
      throw InputError("feed: sequence '" + args->sequence + "' has no poses (give --poses FILE)");
    std::size_t first = 0, last = sequence.size();
    if (!args->frames.empty()) {
      const auto range = parse_frame_range(args->frames);
      first = std::min(range.first, sequence.size());
      last = std::min(range.second, sequence.size());
    }
    auto lcm = open_lcm(config.lcm.url);
    const StopSignals signals;
    const auto encoding = args->raw ? io::ImageEncoding::kRaw : io::ImageEncoding::kPng;
    const auto period = std::chrono::duration<double>(args->rate_hz > 0.0 ? 1.0 / args->rate_hz : 0.0);
    auto next = std::chrono::steady_clock::now();
    std::size_t sent = 0;
    for (std::size_t index = first; index < last && !signals.requested(); ++index) {
      const auto utime = now_utime();
      const auto& left = sequence.left_images[index];
      const auto& right = sequence.right_images[index];
      planecell_lcm::stereo_frame_t message;
      if (encoding == io::ImageEncoding::kPng && io::is_png_file(left) && io::is_png_file(right)) {
        // PNG files go out as they are: the daemon decodes them exactly as load_kitti_frame would.
        message = io::to_lcm_png(index, sequence.camera, io::read_png_bytes(left), io::read_png_bytes(right), utime);
        io::check_frame_size(sequence, left, message.width, message.height);
      } else {
        StereoFrame frame = io::load_kitti_frame(sequence, index);
        frame.frame_id = index;
        message = io::to_lcm(frame, encoding, utime);
      }
      publish_message(*lcm, config.lcm.pose_channel, io::to_lcm(index, sequence.poses[index], utime));
      publish_message(*lcm, config.lcm.stereo_channel, message);
      ++sent;
      next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
      std::this_thread::sleep_until(next);
    }
    std::cout << "feed: " << sent << " frames published on " << config.lcm.stereo_channel << " + "
              << config.lcm.pose_channel << "\n";
    return signals.requested() ? kExitInterrupted : kExitOk;
  });
}

}  // namespace planecell::services
