#include "services/bench/bench_report.hpp"

#include <cmath>
#include <limits>

namespace planecell::services::bench {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// null for NaN/∞ (JSON has no NaN).
nlohmann::json json_number(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

nlohmann::json latency_json(const std::vector<std::pair<std::string, LatencySummary>>& stages) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [name, s] : stages)
    out[name] = {{"count", s.count},   {"p50_ms", s.p50_ms}, {"p95_ms", s.p95_ms},
                 {"p99_ms", s.p99_ms}, {"max_ms", s.max_ms}, {"mean_ms", s.mean_ms}};
  return out;
}

/// within_{10,20,50,100}cm_pct and density of a curve.
nlohmann::json table1_json(const eval::AccuracyCurve& curve) {
  nlohmann::json out = {{"gt_pixels", curve.gt_pixels()},
                        {"with_point", curve.with_point()},
                        {"density_pct", json_number(curve.density_pct())}};
  for (double r : eval::kPointRadiiM) {
    const int k = static_cast<int>(std::lround(r / curve.max_m() * curve.steps()));
    out["within_" + std::to_string(std::lround(100 * r)) + "cm_pct"] =
        json_number(curve.within_pct(k));
  }
  return out;
}

nlohmann::json memory_json(const MemorySample& m) {
  return {{"frames", m.frames},
          {"planecell_ram_bytes", m.planecell_ram_bytes},
          {"planecell_store_bytes", m.planecell_store_bytes},
          {"planecell_cells", m.planecell_cells},
          {"points", m.points},
          {"point_bytes", m.point_bytes},
          {"octomap_ram_bytes", m.octomap_ram_bytes},
          {"octomap_bt_bytes", m.octomap_bt_bytes},
          {"octomap_ot_bytes", m.octomap_ot_bytes},
          {"voxels", m.voxels}};
}

}  // namespace

std::vector<std::string> representation_stages(std::size_t representation) {
  switch (representation) {
    case kPlanecell:
      return {"load", "sgm", "extract", "transform", "merge", "store"};
    case kPoints:
      return {"load", "sgm", "points"};
    case kVoxel:
      return {"load", "sgm", "voxel"};
    default:
      return {};
  }
}

const LatencySummary* find_stage(const BenchReport& report, const std::string& stage) {
  for (const auto* log : {&report.replay.stage_latency, &report.bench_latency})
    for (const auto& [name, s] : *log)
      if (name == stage && s.count > 0) return &s;
  return nullptr;
}

double stage_mean_ms(const BenchReport& report, const std::string& stage) {
  const LatencySummary* s = find_stage(report, stage);
  return s ? s->mean_ms : kNaN;
}

double estimated_frames_per_s(const BenchReport& report, std::size_t representation) {
  double total_ms = 0.0;
  for (const auto& stage : representation_stages(representation))
    total_ms += stage_mean_ms(report, stage);
  return std::isfinite(total_ms) && total_ms > 0.0 ? 1000.0 / total_ms : kNaN;
}

nlohmann::json to_json(const BenchReport& r) {
  const std::size_t frames = r.replay.frames;
  nlohmann::json accuracy = {
      {"definition",
       {{"score",
         "share of GT pixels (GT disparity > 0) whose reconstructed 3D point lies within x "
         "of the GT point X(u, v, d_gt), left camera frame; a pixel without a point counts "
         "as outside every x"},
        {"planecell",
         "X(u, v, d) of the frame's dense plane disparity (PlanecellFrame::dense_disparity)"},
        {"points", "X(u, v, d) of the raw SGM disparity"},
        {"voxel",
         "centre of the occupied OctoMap voxel containing the pixel's SGM point (after this "
         "frame's insertion; points beyond voxel.max_range_m are not inserted)"}}},
      {"frames_scored", r.frame_scores.size()},
      {"frames_without_gt", r.frames_without_gt}};
  for (std::size_t k = 0; k < kRepresentations; ++k) {
    const auto& curve = r.accuracy[k];
    nlohmann::json entry = table1_json(curve);
    std::vector<double> x, y;
    for (int i = 0; i <= curve.steps(); ++i) {
      x.push_back(curve.threshold_m(i));
      y.push_back(curve.gt_pixels() > 0 ? curve.within_pct(i) : 0.0);
    }
    entry["curve"] = {{"threshold_m", x}, {"within_pct", y}};
    accuracy["representations"][representation_name(k)] = entry;
  }
  nlohmann::json per_frame = nlohmann::json::array();
  for (const auto& f : r.frame_scores) {
    nlohmann::json row = {{"frame", f.frame_id}};
    for (std::size_t k = 0; k < kRepresentations; ++k)
      row[representation_name(k)] = table1_json(f.curves[k]);
    per_frame.push_back(row);
  }
  accuracy["per_frame"] = per_frame;

  nlohmann::json memory = {{"point_bytes_per_point", kPointBytes},
                           {"voxel_resolution_m", r.config.voxel.resolution_m}};
  nlohmann::json samples = nlohmann::json::array();
  for (const auto& m : r.memory) samples.push_back(memory_json(m));
  memory["samples"] = samples;
  if (!r.memory.empty()) {
    MemorySample last = r.memory.back();
    last.planecell_store_bytes = r.replay.store_bytes;  // after closing: WAL checkpointed
    memory["final"] = memory_json(last);
    const double n = static_cast<double>(std::max<std::size_t>(last.frames, 1));
    memory["bytes_per_frame"] = {{"planecell_ram", last.planecell_ram_bytes / n},
                                 {"planecell_store", last.planecell_store_bytes / n},
                                 {"points", last.point_bytes / n},
                                 {"octomap_ram", last.octomap_ram_bytes / n},
                                 {"octomap_bt", last.octomap_bt_bytes / n}};
  }

  nlohmann::json estimated = nlohmann::json::object();
  for (std::size_t k = 0; k < kRepresentations; ++k)
    estimated[representation_name(k)] = json_number(estimated_frames_per_s(r, k));
  nlohmann::json time = {{"stages", latency_json(r.replay.stage_latency)},
                         {"bench_stages", latency_json(r.bench_latency)},
                         {"threaded", r.threaded},
                         {"wall_s", r.wall_s},
                         {"frames_per_s", r.wall_s > 0 ? frames / r.wall_s : 0.0},
                         {"pipeline_frames_per_s", r.replay.frames_per_s},
                         {"estimated_single_thread_frames_per_s", estimated},
                         {"peak_rss_bytes", r.peak_rss_bytes}};

  nlohmann::json figures = {
      {"accuracy", kAccuracyFigure}, {"memory", kMemoryFigure}, {"latency", kLatencyFigure}};
  if (r.top_views) {
    figures["map_top_height"] = kTopHeightFigure;
    figures["map_top_surfaces"] = kTopSurfaceFigure;
  }
  if (!r.overlay_figure.empty()) figures["overlay"] = r.overlay_figure;

  nlohmann::json out = {
      {"sequence", r.sequence},
      {"out_dir", r.out_dir},
      {"command", r.command},
      {"created_utc", r.created_utc},
      {"frames", {{"first", r.first_frame}, {"last_exclusive", r.last_frame}, {"count", frames}}},
      {"image", {r.width, r.height}},
      {"camera",
       {{"fx", r.camera.fx},
        {"fy", r.camera.fy},
        {"cx", r.camera.cx},
        {"cy", r.camera.cy},
        {"baseline_m", r.camera.baseline_m}}},
      {"accuracy", accuracy},
      {"memory", memory},
      {"time", time},
      {"figures", figures},
      {"map", {{"cells", r.map_cells}, {"surfaces", r.map_surfaces}, {"store", kMapStore}}},
      {"replay", services::to_json(r.replay)}};
  if (r.overlay_frame) out["overlay_frame"] = *r.overlay_frame;
  nlohmann::json appended = nlohmann::json::array();
  for (const auto& [name, text] : r.appended) appended.push_back(name);
  out["appended_reports"] = appended;
  return out;
}

}  // namespace planecell::services::bench
