#include "services/bench/run_bench.hpp"

#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <sstream>

#include "core/error.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"
#include "io/map_store.hpp"
#include "io/sequence_ground_truth.hpp"
#include "mapping/voxel/voxel_map.hpp"
#include "services/bench/bench_figures.hpp"
#include "services/bench/bench_markdown.hpp"
#include "services/bench/frame_accuracy.hpp"
#include "services/bench/map_views.hpp"
#include "services/render/cell_overlay.hpp"
#include "services/report/markdown.hpp"

namespace planecell::services::bench {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::size_t file_bytes(const fs::path& path) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  return ec ? 0 : static_cast<std::size_t>(size);
}

std::size_t peak_rss_bytes() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<std::size_t>(usage.ru_maxrss) * 1024;  // Linux: kilobytes
}

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%d %H:%M:%S UTC", &tm);
  return text;
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError("bench --append '" + path.string() + "': cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  out.flush();
  if (!out) throw StorageError("bench: cannot write '" + path.string() + "'");
}

/// Removes a previous run's map store so that the replay starts from an empty map (a kept store
/// would make the replay resume and skip the frames).
void remove_store(const fs::path& store) {
  for (const char* suffix : {"", "-wal", "-shm"}) {
    std::error_code ec;
    fs::remove(store.string() + suffix, ec);
    if (ec)
      throw StorageError("bench: cannot remove the old map store '" + store.string() + suffix +
                         "': " + ec.message());
  }
}

/// Everything the per-frame observer accumulates.
class FrameObserver {
 public:
  FrameObserver(const BenchOptions& options, const AppConfig& config,
                const io::KittiOdometrySequence& sequence, std::size_t frames, BenchReport& report)
      : options_(options),
        config_(config),
        sequence_(sequence),
        report_(report),
        voxels_(config.voxel),
        stride_(std::max<std::size_t>(1, (frames + options.max_memory_samples - 1) /
                                             std::max<std::size_t>(options.max_memory_samples, 1))),
        frames_(frames),
        store_path_(options.out_dir / kMapStore) {}

  void operator()(const FrameWork& work) {
    if (!work.frame.pose)
      throw InputError("bench: frame " + std::to_string(work.frame_id) + " has no pose");
    const StereoCamera& camera = work.frame.camera;
    auto start = Clock::now();
    // Point map: every valid SGM pixel in 3D (the cloud itself is not kept, only counted).
    points_ += voxel::back_project(work.disparity, work.frame.left, camera, *work.frame.pose,
                                   std::numeric_limits<double>::infinity())
                   .points_m.size();
    log_.add("points", ms_since(start));
    start = Clock::now();
    voxels_.insert(voxel::back_project(work.disparity, work.frame.left, camera, *work.frame.pose,
                                       config_.voxel.max_range_m));
    log_.add("voxel", ms_since(start));

    start = Clock::now();
    const cv::Mat gt = io::load_disparity_ground_truth(sequence_, work.frame_id,
                                                       work.disparity.cols, work.disparity.rows);
    if (gt.empty()) {
      ++report_.frames_without_gt;
    } else {
      FrameScore score{work.frame_id, score_frame(work, gt, voxels_, config_.voxel.max_range_m)};
      report_.accuracy += score.curves;
      report_.frame_scores.push_back(std::move(score));
    }
    log_.add("scoring", ms_since(start));

    if (report_.overlay_frame && *report_.overlay_frame == work.frame_id) {
      char name[48];
      std::snprintf(name, sizeof(name), "overlay_%06llu.png",
                    static_cast<unsigned long long>(work.frame_id));
      io::write_image(options_.out_dir / name,
                      render::draw_cell_overlay(work.frame.left, work.cells));
      report_.overlay_figure = name;
    }

    ++done_;
    if (done_ % stride_ == 0 || done_ == frames_) {
      start = Clock::now();
      const auto stats = voxels_.stats();
      MemorySample m;
      m.frames = done_;
      // Measured by the merge stage on every stride-th frame (ReplayOptions::memory_sample_every);
      // the last sample's is the replay's final map_bytes (run_bench fills it in).
      m.planecell_ram_bytes = work.map_bytes.value_or(0);
      m.planecell_store_bytes = file_bytes(store_path_) + file_bytes(store_path_.string() + "-wal");
      m.planecell_cells = work.map_cells;
      m.points = points_;
      m.point_bytes = points_ * kPointBytes;
      m.octomap_ram_bytes = stats.memory_bytes;
      m.octomap_bt_bytes = stats.bt_bytes;
      m.octomap_ot_bytes = stats.ot_bytes;
      m.voxels = stats.occupied_voxels;
      report_.memory.push_back(m);
      log_.add("sampling", ms_since(start));
    }
  }

  std::vector<std::pair<std::string, LatencySummary>> latency() const { return log_.summaries(); }
  /// Frames between two memory samples.
  std::size_t stride() const { return stride_; }

 private:
  const BenchOptions& options_;
  const AppConfig& config_;
  const io::KittiOdometrySequence& sequence_;
  BenchReport& report_;
  voxel::VoxelMap voxels_;
  LatencyLog log_;
  std::size_t stride_;
  std::size_t frames_;
  fs::path store_path_;
  std::size_t points_ = 0;
  std::size_t done_ = 0;
};

void write_figure(const fs::path& path, const cv::Mat& image) { io::write_image(path, image); }

}  // namespace

std::string bench_command_line(const BenchOptions& o) {
  using report::shell_quote;
  std::string line = "planecell";
  if (!o.config_path.empty()) line += " --config " + shell_quote(o.config_path);
  line += " bench " + shell_quote(o.sequence_dir.string()) + " --out " +
          shell_quote(o.out_dir.string());
  const bool open_end = o.last_frame == std::numeric_limits<std::size_t>::max();
  if (o.first_frame > 0 || !open_end)
    line += " --frames " + std::to_string(o.first_frame) + ":" +
            (open_end ? "" : std::to_string(o.last_frame));
  if (o.threads) line += " --threads";
  if (o.overlay_frame) line += " --overlay-frame " + std::to_string(*o.overlay_frame);
  for (const auto& md : o.append_markdown) line += " --append " + shell_quote(md.string());
  return line;
}

BenchReport run_bench(const BenchOptions& options, const AppConfig& config) {
  const auto start = Clock::now();
  if (options.out_dir.empty()) throw ConfigError("bench: --out DIR is required");
  if (options.max_memory_samples < 1) throw ConfigError("bench: max_memory_samples must be >= 1");
  const io::KittiOdometrySequence sequence = io::open_kitti_odometry(options.sequence_dir);
  const std::size_t first = std::min(options.first_frame, sequence.size());
  const std::size_t last = std::min(options.last_frame, sequence.size());
  if (last <= first)
    throw InputError("bench: no frame to bench: --frames selects [" +
                     std::to_string(options.first_frame) + ", " +
                     (options.last_frame == std::numeric_limits<std::size_t>::max()
                          ? std::string("end")
                          : std::to_string(options.last_frame)) +
                     ") but '" + options.sequence_dir.string() + "' has " +
                     std::to_string(sequence.size()) + " frames");
  if (!io::has_disparity_ground_truth(sequence))
    spdlog::warn("bench: '{}' has no GT disparity (disp_occ_0/): no accuracy, memory and time only",
                 options.sequence_dir.string());

  BenchReport report;
  report.sequence = options.sequence_dir.string();
  report.out_dir = options.out_dir.string();
  report.command = bench_command_line(options);
  report.created_utc = utc_now();
  report.first_frame = first;
  report.last_frame = last;
  report.camera = sequence.camera;
  report.width = sequence.camera.width;
  report.height = sequence.camera.height;
  report.config = config;
  report.threaded = options.threads;
  report.overlay_frame = options.overlay_frame.value_or(first);
  if (*report.overlay_frame < first || *report.overlay_frame >= last)
    throw ConfigError("bench: --overlay-frame " + std::to_string(*report.overlay_frame) +
                      " is outside the benched frames [" + std::to_string(first) + ", " +
                      std::to_string(last) + ")");
  for (const auto& path : options.append_markdown)
    report.appended.emplace_back(path.string(), read_text(path));

  std::error_code ec;
  fs::create_directories(options.out_dir, ec);
  if (ec)
    throw StorageError("bench: cannot create '" + options.out_dir.string() + "': " + ec.message());
  const fs::path store_path = options.out_dir / kMapStore;
  remove_store(store_path);

  FrameObserver observer(options, config, sequence, last - first, report);
  ReplayOptions replay;
  replay.sequence_dir = options.sequence_dir;
  replay.map_path = store_path;
  replay.first_frame = first;
  replay.last_frame = last;
  replay.progress = options.progress;
  replay.threads = options.threads;
  replay.observe = [&observer](const FrameWork& work) { observer(work); };
  replay.memory_sample_every = observer.stride();  // the merge stage measures the map's RAM then
  report.replay = run_replay(replay, config);
  if (!report.memory.empty()) {  // the map as the replay closed it (settled: map.settle_at_close)
    report.memory.back().planecell_ram_bytes = report.replay.map_bytes;
    report.memory.back().planecell_cells = report.replay.cells_in_map;
  }
  report.bench_latency = observer.latency();

  // Top views of the stored map, read back through the store like any consumer of the map.
  {
    const io::MapStore store(store_path);
    const map::GlobalMap global_map = io::load_map(store, config.map);
    std::vector<map::MapCell> cells;
    cells.reserve(global_map.cells().size());
    for (const auto& [id, cell] : global_map.cells()) cells.push_back(cell);
    std::sort(cells.begin(), cells.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
    report.map_cells = cells.size();
    report.map_surfaces = global_map.surfaces().size();
    const bool drawable = std::any_of(cells.begin(), cells.end(),
                                      [](const auto& c) { return !c.vertices_m.empty(); });
    if (drawable) {
      TopViewOptions view;
      view.up = Eigen::Vector3d(config.map.up_x, config.map.up_y, config.map.up_z);
      view.colour = TopViewColour::kHeight;
      view.title = "planecell map from above: height";
      write_figure(options.out_dir / kTopHeightFigure, render_top_view(cells, view));
      view.colour = TopViewColour::kSurface;
      view.title = "planecell map from above: " + std::to_string(report.map_surfaces) + " surfaces";
      write_figure(options.out_dir / kTopSurfaceFigure, render_top_view(cells, view));
      report.top_views = true;
    }
  }
  write_figure(options.out_dir / kAccuracyFigure, accuracy_figure(report));
  write_figure(options.out_dir / kMemoryFigure, memory_figure(report));
  write_figure(options.out_dir / kLatencyFigure, latency_figure(report));

  report.wall_s = ms_since(start) / 1000.0;
  report.peak_rss_bytes = peak_rss_bytes();
  write_text(options.out_dir / kReportJson, to_json(report).dump(2) + "\n");
  write_text(options.out_dir / kReportMd, format_markdown(report));
  return report;
}

std::string summary_text(const BenchReport& r) {
  std::ostringstream out;
  out << "bench: " << r.replay.frames << " frames of " << r.sequence << " in "
      << report::number(r.wall_s, 1) << " s (" << r.frame_scores.size() << " with GT)\n";
  if (!r.frame_scores.empty()) {
    out << "  accuracy (% of GT pixels within 10 / 20 / 50 / 100 cm, density):\n";
    for (std::size_t k = 0; k < kRepresentations; ++k) {
      const auto& c = r.accuracy[k];
      out << "    " << representation_name(k) << ":";
      for (double r_m : eval::kPointRadiiM)
        out << " "
            << report::number(
                   c.within_pct(static_cast<int>(std::lround(r_m / c.max_m() * c.steps()))), 1);
      out << "  (density " << report::number(c.density_pct(), 1) << " %)\n";
    }
  }
  if (!r.memory.empty()) {
    const auto& m = r.memory.back();
    const double n = static_cast<double>(std::max<std::size_t>(m.frames, 1));
    out << "  size after " << m.frames << " frames (per frame): planecell RAM "
        << report::bytes(static_cast<double>(m.planecell_ram_bytes)) << " ("
        << report::bytes(m.planecell_ram_bytes / n) << "), store "
        << report::bytes(static_cast<double>(r.replay.store_bytes)) << "; points "
        << report::bytes(static_cast<double>(m.point_bytes)) << " ("
        << report::bytes(m.point_bytes / n) << "); OctoMap RAM "
        << report::bytes(static_cast<double>(m.octomap_ram_bytes)) << " ("
        << report::bytes(m.octomap_ram_bytes / n) << "), .bt "
        << report::bytes(static_cast<double>(m.octomap_bt_bytes)) << "\n";
  }
  out << "  time: " << report::number(r.wall_s > 0 ? r.replay.frames / r.wall_s : 0.0, 2)
      << " frames/s for the whole bench; single-thread estimate planecell "
      << report::number(estimated_frames_per_s(r, kPlanecell), 2) << ", points "
      << report::number(estimated_frames_per_s(r, kPoints), 2) << ", voxel "
      << report::number(estimated_frames_per_s(r, kVoxel), 2) << " frames/s; peak RSS "
      << report::bytes(static_cast<double>(r.peak_rss_bytes)) << "\n";
  out << "  report: " << (fs::path(r.out_dir) / kReportMd).string() << " (figures and "
      << kReportJson << " beside it)\n";
  return out.str();
}

}  // namespace planecell::services::bench
