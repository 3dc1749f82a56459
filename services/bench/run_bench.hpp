#pragma once
/// `planecell bench`: planecell against the paper's baselines (point-based map, OctoMap voxel map)
/// on the same frames of a sequence with ground truth — accuracy, memory, time and views —
/// written as report.json, report.md and PNG figures.
#include <cstddef>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "core/config/app_config.hpp"
#include "services/bench/bench_report.hpp"

namespace planecell::services::bench {

struct BenchOptions {
  std::filesystem::path sequence_dir;  ///< KITTI odometry layout with poses (GT: disp_occ_0/)
  std::filesystem::path out_dir;       ///< created; its map.db is replaced by a fresh map
  std::size_t first_frame = 0;         ///< frames [first, last) are benched
  std::size_t last_frame = std::numeric_limits<std::size_t>::max();
  bool threads = false;  ///< the threaded pipeline instead of one thread
  bool progress = true;
  std::optional<std::size_t> overlay_frame;  ///< frame drawn with its cells; default: the first
  std::size_t max_memory_samples = 40;       ///< memory is sampled every ⌈frames / this⌉ frames
  std::vector<std::filesystem::path> append_markdown;  ///< reports appended to report.md
  std::string config_path;  ///< the --config file, only to print the regenerating command
};

/// The command line that regenerates a bench run (printed under every table of the report):
/// "planecell [--config F] bench SEQ --out DIR [--frames A:B] [--threads] [--overlay-frame N]
/// [--append F.md]...".
std::string bench_command_line(const BenchOptions& options);

/// Runs the sequence's frames through the planecell pipeline (services/replay, map store in
/// out_dir/map.db) and, in a per-frame observer on the same frames: the point map (every valid
/// SGM pixel back-projected), the voxel map (OctoMap, config.voxel), the accuracy of all three
/// against the GT disparity, memory samples and the overlay frame. Then draws the figures and
/// the top views of the stored map and writes report.json and report.md.
/// Throws InputError on a bad sequence or an empty frame range, ConfigError on bad options,
/// StorageError when an output cannot be written.
BenchReport run_bench(const BenchOptions& options, const AppConfig& config);

/// A few lines for the terminal: the Table 1 figures, sizes, throughput and where the report is.
std::string summary_text(const BenchReport& report);

}  // namespace planecell::services::bench
