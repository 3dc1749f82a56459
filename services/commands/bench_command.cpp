/// `planecell bench SEQ --out DIR` — planecell against the point-based and the voxel map on the
/// same frames: accuracy, memory, time and views, as report.md / report.json / PNG figures.
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "services/bench/run_bench.hpp"
#include "services/commands/commands.hpp"
#include "services/replay.hpp"

namespace planecell::services {

void add_bench_command(CLI::App& app, CommandContext& context) {
  auto* command = app.add_subcommand(
      "bench",
      "Measure planecell against the paper's baselines, the point-based map (SGM disparity in 3D)\n"
      "and the OctoMap voxel map (10 cm), on the same frames of a sequence with ground truth:\n"
      "accuracy, memory, time and views, written as DIR/report.md (+ report.json, PNG figures).");
  struct Args {
    std::string sequence, out, frames;
    bool threads = false, no_progress = false;
    std::optional<std::size_t> overlay_frame;
    std::vector<std::string> append;
  };
  auto args = std::make_shared<Args>();
  command
      ->add_option("sequence", args->sequence,
                   "Sequence folder, KITTI odometry layout with poses; GT disparity in disp_occ_0/")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("-o,--out", args->out, "Output folder (created)")->required();
  command->add_option("--frames", args->frames, "Frame range A:B (B exclusive), e.g. 0:20 or 5:");
  command->add_flag(
      "--threads", args->threads,
      "Run the planecell stages as the threaded pipeline (the baselines and scoring run "
      "on its publish thread)");
  command->add_option(
      "--overlay-frame", args->overlay_frame,
      "Frame whose planecells are drawn over its image (default: the first benched)");
  command
      ->add_option("--append", args->append,
                   "Markdown report to append to report.md (repeatable), e.g. from "
                   "`planecell eval-stereo --report-md`")
      ->allow_extra_args(false)  // one file per --append
      ->check(CLI::ExistingFile);
  command->add_flag("--no-progress", args->no_progress, "No progress bar");
  command->footer(
      "Writes into DIR:\n"
      "  report.md        tables and figures, each followed by the command that regenerates it\n"
      "  report.json      the same numbers (per-frame accuracy, memory samples, stage latencies)\n"
      "  accuracy.png     share of GT pixels within x of their GT point, x = 0..1 m, per map\n"
      "  memory.png       bytes of each map versus frames (RAM, store, .bt)\n"
      "  latency.png      per-stage latency p50/p95/p99\n"
      "  map_top_*.png    the planecell map from above, by height and by surface label\n"
      "  overlay_N.png    one frame's planecells over its image\n"
      "  map.db           the planecell map store (replaced on every run)\n"
      "Examples:\n"
      "  planecell synth --out /tmp/street --frames 20\n"
      "  planecell bench /tmp/street --out /tmp/street/report        # then open report.md\n"
      "  planecell eval-stereo --dataset kitti --root data/kitti2015 --report-md k15.md\n"
      "  planecell bench /tmp/street --out /tmp/r --frames 0:10 --threads --append k15.md");
  context.add(command, [args](const CommandContext& ctx) {
    const AppConfig config = ctx.load_app_config();
    bench::BenchOptions options;
    options.sequence_dir = args->sequence;
    options.out_dir = args->out;
    if (!args->frames.empty())
      std::tie(options.first_frame, options.last_frame) = parse_frame_range(args->frames);
    options.threads = args->threads;
    options.progress = !args->no_progress;
    options.overlay_frame = args->overlay_frame;
    for (const auto& md : args->append) options.append_markdown.emplace_back(md);
    options.config_path = ctx.config_path;
    const bench::BenchReport report = bench::run_bench(options, config);
    std::cout << bench::summary_text(report);
    return kExitOk;
  });
}

}  // namespace planecell::services
