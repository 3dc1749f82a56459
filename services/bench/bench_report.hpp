#pragma once
/// What `planecell bench` measured: accuracy curves per representation, memory versus frames,
/// stage latencies, and where the figures are. Written as report.json (to_json) and report.md
/// (bench_markdown).
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/config/app_config.hpp"
#include "core/stereo_camera.hpp"
#include "services/bench/frame_accuracy.hpp"
#include "services/latency_stats.hpp"
#include "services/replay.hpp"

namespace planecell::services::bench {

/// File names inside the output folder.
inline constexpr const char* kReportJson = "report.json";
inline constexpr const char* kReportMd = "report.md";
inline constexpr const char* kMapStore = "map.db";
inline constexpr const char* kAccuracyFigure = "accuracy.png";
inline constexpr const char* kMemoryFigure = "memory.png";
inline constexpr const char* kLatencyFigure = "latency.png";
inline constexpr const char* kTopHeightFigure = "map_top_height.png";
inline constexpr const char* kTopSurfaceFigure = "map_top_surfaces.png";

/// Bytes per point of the point-based map: 3 float coordinates + 3 colour bytes.
inline constexpr std::size_t kPointBytes = 3 * sizeof(float) + 3;

/// Sizes of every representation after `frames` frames.
struct MemorySample {
  std::size_t frames = 0;                 ///< frames mapped so far
  std::size_t planecell_ram_bytes = 0;    ///< GlobalMap::map_bytes
  std::size_t planecell_store_bytes = 0;  ///< map store on disk (database + WAL) at that point
  std::size_t planecell_cells = 0;
  std::size_t points = 0;             ///< points of the point map (every valid SGM pixel)
  std::size_t point_bytes = 0;        ///< points · kPointBytes
  std::size_t octomap_ram_bytes = 0;  ///< ColorOcTree::memoryUsage
  std::size_t octomap_bt_bytes = 0;   ///< .bt (binary occupancy) size
  std::size_t octomap_ot_bytes = 0;   ///< .ot (with colour) size
  std::size_t voxels = 0;             ///< occupied voxels at full resolution
};

/// The accuracy of one frame (frames with GT only).
struct FrameScore {
  std::uint64_t frame_id = 0;
  Curves curves;
};

struct BenchReport {
  std::string sequence;
  std::string out_dir;
  std::string command;                          ///< the command line that regenerates the report
  std::string created_utc;                      ///< ISO 8601
  std::size_t first_frame = 0, last_frame = 0;  ///< the frames benched, [first, last)
  int width = 0, height = 0;
  StereoCamera camera;
  AppConfig config;
  bool threaded = false;

  ReplayReport replay;  ///< the planecell pipeline's own report (stages, map, merge scoring)
  Curves accuracy;      ///< pooled over every frame with GT
  std::vector<FrameScore> frame_scores;
  std::size_t frames_without_gt = 0;
  std::vector<MemorySample> memory;  ///< in frame order; the last one after the last frame
  /// Per-frame costs measured by the bench itself, ms: "points" (back-projection of every valid
  /// SGM pixel), "voxel" (back-projection within range + OctoMap insertion), "scoring" and
  /// "memory sampling" (bench bookkeeping, no representation's cost).
  std::vector<std::pair<std::string, LatencySummary>> bench_latency;
  double wall_s = 0.0;
  std::size_t peak_rss_bytes = 0;  ///< getrusage ru_maxrss of the process at the end
  std::optional<std::uint64_t> overlay_frame;
  std::string overlay_figure;                   ///< file name, empty without an overlay
  bool top_views = false;                       ///< kTopHeightFigure / kTopSurfaceFigure written
  std::size_t map_cells = 0, map_surfaces = 0;  ///< of the stored map the top views show
  /// Markdown reports appended at the end (e.g. eval-stereo --report-md): file name, content.
  std::vector<std::pair<std::string, std::string>> appended;
};

/// Single-thread frames/s of a representation from its stages' mean latencies:
/// 1000 / Σ mean_ms over the stages it needs (points: load, sgm, points; voxel: load, sgm, voxel;
/// planecell: load, sgm, extract, transform, merge, store). NaN when a stage is missing.
double estimated_frames_per_s(const BenchReport& report, std::size_t representation);

/// Names of the stages a representation needs (as above).
std::vector<std::string> representation_stages(std::size_t representation);

/// Latency summary of a stage from the replay's or the bench's log; nullptr when absent.
const LatencySummary* find_stage(const BenchReport& report, const std::string& stage);
/// Mean latency (ms) of a stage from the replay's or the bench's log; NaN when absent.
double stage_mean_ms(const BenchReport& report, const std::string& stage);

/// report.json: every figure above, curves as {threshold_m: [...], within_pct: [...]}.
nlohmann::json to_json(const BenchReport& report);

}  // namespace planecell::services::bench
