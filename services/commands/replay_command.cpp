/// `planecell replay` — a KITTI-odometry-layout sequence through SGM → extraction → transform →
/// merge (→ map store, → voxel baseline), single-threaded, with a progress bar and a JSON report.
#include <spdlog/spdlog.h>

#include <fstream>
#include <iostream>
#include <memory>

#include "core/error.hpp"
#include "services/commands/commands.hpp"
#include "services/pipeline/heap_tuning.hpp"
#include "services/pipeline/lcm_link.hpp"
#include "services/replay.hpp"

namespace planecell::services {

void add_replay_command(CLI::App& app, CommandContext& context) {
  auto* command = app.add_subcommand(
      "replay",
      "Replay a KITTI-odometry-layout sequence (real or `planecell synth`) through the whole "
      "pipeline: SGM disparity, planecell extraction, pose transform and CRF merging into the "
      "global map. With --map the map is stored (SQLite, one transaction per frame) and a second "
      "run with the same --map resumes after the last committed frame.");
  struct Args {
    std::string sequence, map, poses, frames, report, extraction_cache;
    bool voxel = false, ray_casting = false, no_progress = false, threads = false, publish = false,
         gt_disparity = false;
    double rate_hz = 0.0;
    std::size_t rss_every = 10;
    std::string lcm_url;
  };
  auto args = std::make_shared<Args>();
  command->add_option("sequence", args->sequence, "Sequence folder (image_2/3 or image_0/1, calib.txt, poses)")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("--map", args->map, "SQLite map store to write (resumes when it exists)");
  command->add_option("--poses", args->poses, "KITTI pose file to use instead of the sequence's own")
      ->check(CLI::ExistingFile);
  command->add_option("--frames", args->frames, "Frame range A:B (B exclusive), e.g. 0:100 or 50:");
  command->add_option("--report", args->report, "Write the JSON report here");
  command->add_flag("--voxel", args->voxel, "Also build the OctoMap voxel baseline (10 cm) from the same frames");
  command->add_flag("--ray-casting", args->ray_casting,
                    "Voxel baseline with free-space ray casting (insertPointCloud; slow)");
  command->add_flag("--no-progress", args->no_progress, "No progress bar");
  command->add_flag("--gt-disparity", args->gt_disparity,
                    "Diagnostic: use the sequence's ground-truth disparity (disp_occ_0/, as `synth` "
                    "writes) instead of SGM, to tell stereo errors from mapping errors (single-threaded)");
  command->add_option("--extraction-cache", args->extraction_cache,
                      "Folder of each frame's SGM + extraction products: read when they were made from "
                      "the same images and sgm/extraction settings, else computed and written there, so "
                      "a second replay re-runs only transform, merge and store (map tuning and "
                      "profiling; single-threaded, not with --voxel)");
  command->add_flag("--threads", args->threads,
                    "Run the stages as the threaded pipeline (one thread per stage, bounded queues; "
                    "section 'pipeline' of the config); builds the same map");
  command->add_option("--rate", args->rate_hz,
                      "Feed frames at this rate like a camera (Hz, e.g. 10); end-to-end latency then "
                      "counts from each frame's due time (0 = as fast as possible)")
      ->check(CLI::NonNegativeNumber);
  command->add_flag("--publish", args->publish,
                    "Publish every frame's map update over LCM (PLANECELL_MAP_UPDATE, as `run` does)");
  command->add_option("--lcm", args->lcm_url, "LCM URL for --publish (default: lcm.url of the config)");
  command->add_option("--rss-every", args->rss_every,
                      "Sample the process RSS every N frames into the report's rss_mb (0 = never)");
  command->footer(
      "Examples:\n"
      "  planecell replay /tmp/street --map /tmp/street.db --report /tmp/replay.json\n"
      "  planecell replay dataset/sequences/00 --frames 0:50 --voxel\n"
      "  planecell replay /tmp/street --threads --no-progress   # pipelined: frames/s, end-to-end latency\n"
      "  planecell replay /tmp/street --threads --rate 10        # latency at camera rate\n"
      "  planecell replay /tmp/street --gt-disparity             # the map from perfect stereo\n"
      "  planecell replay /tmp/street --extraction-cache /tmp/street.pcx --config map_trial.yaml\n"
      "                                     # second run on: merge only, same cells\n"
      "Report: frames, cells, surfaces, map bytes (RAM), store bytes, bytes per frame, voxel\n"
      "bytes/leaves and the map's size against them (with --voxel: map_vs_voxel, RAM and store\n"
      "times smaller than OctoMap's memoryUsage and .ot, store over .bt), per-stage latency\n"
      "p50/p95/p99/max (ms), per-stage CPU ms and page faults (stage_cost), RSS over frames\n"
      "(rss_mb) and peak RSS. On a synthetic sequence\n"
      "(GT surface ids, scene.yaml) also the merging against the GT surfaces\n"
      "(merge_vs_ground_truth) and each cell's plane error against its GT surface's plane next\n"
      "to the modelled depth noise (cell_planes_vs_ground_truth); with GT disparity and poses,\n"
      "the share of the GT points of every 10th frame (depth <= 20 m) within 10/20/50 cm of the\n"
      "final map's planecells (map_vs_ground_truth).");
  context.add(command, [args](const CommandContext& ctx) {
    AppConfig config = ctx.load_app_config();
    apply_heap_config(config.pipeline);  // per-frame buffers stay in the process (fewer faults)
    if (args->ray_casting) config.voxel.ray_casting = true;
    ReplayOptions options;
    options.sequence_dir = args->sequence;
    if (!args->map.empty()) options.map_path = args->map;
    if (!args->poses.empty()) options.poses_path = args->poses;
    if (!args->frames.empty())
      std::tie(options.first_frame, options.last_frame) = parse_frame_range(args->frames);
    options.voxel = args->voxel || args->ray_casting;
    options.progress = !args->no_progress;
    options.threads = args->threads;
    options.gt_disparity = args->gt_disparity;
    if (!args->extraction_cache.empty()) options.extraction_cache_dir = args->extraction_cache;
    options.rate_hz = args->rate_hz;
    options.memory_sample_every = args->rss_every;
    std::unique_ptr<lcm::LCM> lcm;
    if (args->publish) {
      if (!args->lcm_url.empty()) config.lcm.url = args->lcm_url;
      lcm = open_lcm(config.lcm.url);
      options.sinks.want_delta = true;
      options.sinks.publish = [&lcm, &config](const FrameWork& work) {
        const auto utime = now_utime();
        for (const auto& chunk : io::encode_map_update(work.delta, utime))
          publish_message(*lcm, config.lcm.map_update_channel, chunk);
      };
    }
    const ReplayReport report = run_replay(options, config);
    std::cout << summary_text(report);
    if (!args->report.empty()) {
      std::ofstream out(args->report);
      out << to_json(report).dump(2) << "\n";
      if (!out) throw StorageError("report '" + args->report + "': cannot be written");
      std::cout << "  report: " << args->report << "\n";
    }
    return kExitOk;
  });
}

}  // namespace planecell::services
