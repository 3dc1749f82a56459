#include "services/bench/bench_markdown.hpp"

#include <cmath>
#include <sstream>

#include "services/eval/stereo_metrics.hpp"
#include "services/report/markdown.hpp"

namespace planecell::services::bench {
namespace {

using report::bytes;
using report::number;

/// Index of threshold r on a curve's grid (the default grid holds kPointRadiiM exactly).
int threshold_index(const eval::AccuracyCurve& curve, double r) {
  return static_cast<int>(std::lround(r / curve.max_m() * curve.steps()));
}

std::string pct(const eval::AccuracyCurve& curve, double r) {
  return number(curve.within_pct(threshold_index(curve, r)), 1);
}

const char* stage_meaning(const std::string& stage) {
  if (stage == "load") return "decode the stereo pair (PNG)";
  if (stage == "sgm") return "SGM disparity (shared by all three representations)";
  if (stage == "extract") return "planecell extraction: superpixels, planes, vertices";
  if (stage == "transform") return "planecells to the world frame";
  if (stage == "merge") return "CRF merge into the global map";
  if (stage == "store") return "commit the frame to the SQLite map store";
  if (stage == "refine") return "pose refinement against the map";
  if (stage == "publish")
    return "threaded: publish thread, includes the bench's points, voxel and scoring work";
  if (stage == "end_to_end") return "threaded: ingest to publish, queueing included";
  if (stage == "points") return "point map: back-project every valid SGM pixel to the world";
  if (stage == "voxel") return "voxel map: back-project within range + OctoMap insertion";
  if (stage == "scoring") return "bench only: accuracy of the three representations";
  if (stage == "sampling") return "bench only: memory sample (OctoMap .bt/.ot serialised)";
  return "";
}

std::vector<std::string> latency_row(const std::string& name, const LatencySummary& s) {
  return {name,
          stage_meaning(name),
          std::to_string(s.count),
          number(s.p50_ms, 1),
          number(s.p95_ms, 1),
          number(s.p99_ms, 1),
          number(s.max_ms, 1),
          number(s.mean_ms, 1)};
}

/// The paper's own figures (planecell.tex: introduction, §6 "Evaluation and Discussion", Table 1).
constexpr double kPaperExtractionS = 0.2;  ///< single core, about 700 planecells per frame
constexpr double kPaperMergeS = 0.1;       ///< CRF aggregation per frame

/// p50 of a stage, NaN when the stage did not run.
double stage_p50(const BenchReport& r, const std::string& stage) {
  const LatencySummary* s = find_stage(r, stage);
  return s ? s->p50_ms : std::nan("");
}

MemorySample final_memory(const BenchReport& r) {
  MemorySample m = r.memory.empty() ? MemorySample{} : r.memory.back();
  if (r.replay.store_bytes > 0) m.planecell_store_bytes = r.replay.store_bytes;  // WAL checkpointed
  return m;
}

}  // namespace

std::string format_markdown(const BenchReport& r) {
  std::ostringstream md;
  const std::string again = report::regenerate(r.command);
  const std::size_t frames = r.replay.frames;
  const MemorySample mem = final_memory(r);
  const double per_frame = static_cast<double>(std::max<std::size_t>(mem.frames, 1));

  md << "# planecell bench: " << r.sequence << "\n\n";
  md << frames << " frames (" << r.first_frame << ":" << r.last_frame << ") of `" << r.sequence
     << "`, " << r.width << "×" << r.height << " px, f_x " << number(r.camera.fx, 1)
     << " px, baseline " << number(r.camera.baseline_m, 3) << " m; "
     << (r.threaded ? "threaded pipeline" : "one thread") << "; created " << r.created_utc
     << ". Every number below comes from one run of\n\n    " << r.command
     << "\n\nwhich is repeated under each table and figure. The three representations "
        "are built from the same frames and the same SGM disparity: **planecell** (this project: "
        "planar cells merged into a global map), **points** (the SGM disparity back-projected to "
        "3D, "
        "colour per point) and **voxel** (OctoMap ColorOcTree, "
     << number(100.0 * r.config.voxel.resolution_m, 0) << " cm voxels, "
     << (r.config.voxel.ray_casting ? "free-space ray casting"
                                    : "per-voxel occupancy update, no ray casting")
     << ", points within " << number(r.config.voxel.max_range_m, 0) << " m).\n\n";

  // --- summary -------------------------------------------------------------------------------
  md << "## Summary\n\n";
  {
    std::vector<std::vector<std::string>> rows;
    const std::size_t ram[] = {mem.planecell_ram_bytes, mem.point_bytes, mem.octomap_ram_bytes};
    const std::string disk[] = {
        bytes(static_cast<double>(mem.planecell_store_bytes)) + " (SQLite store)",
        bytes(static_cast<double>(mem.point_bytes)) + " (15 B/point)",
        bytes(static_cast<double>(mem.octomap_bt_bytes)) + " (.bt)"};
    for (std::size_t k = 0; k < kRepresentations; ++k) {
      const auto& c = r.accuracy[k];
      rows.push_back({representation_name(k), pct(c, 0.1), pct(c, 0.2), pct(c, 0.5), pct(c, 1.0),
                      number(c.density_pct(), 1), bytes(static_cast<double>(ram[k])),
                      bytes(static_cast<double>(ram[k]) / per_frame), disk[k],
                      number(estimated_frames_per_s(r, k), 2)});
    }
    md << report::table({"representation", "≤ 10 cm %", "≤ 20 cm %", "≤ 50 cm %", "≤ 100 cm %",
                         "density %", "RAM after " + std::to_string(mem.frames) + " frames",
                         "RAM per frame", "on disk", "frames/s (1 thread, est.)"},
                        rows)
       << again;
    md << "\nAccuracy: share of all GT pixels within the distance (pooled over "
       << r.frame_scores.size()
       << " frames with GT); density: share of GT pixels that have a point at "
          "all. frames/s: 1000 / the sum of the mean stage latencies the representation needs "
          "(see Time)"
       << (r.threaded ? "; with --threads the stages shared the cores, so these latencies (and "
                        "this estimate) include waiting for a core"
                      : "")
       << ".\n\n";
  }

  // --- the paper -------------------------------------------------------------------------------
  md << "## Against the paper\n\n"
        "The paper's figures (its introduction, §6 and Table 1; Table 1 is on KITTI stereo pairs, "
        "not on this sequence) next to this run's:\n\n";
  {
    const double cells_per_frame =
        frames > 0 ? static_cast<double>(r.replay.cells_extracted) / static_cast<double>(frames) : 0.0;
    const auto& c = r.accuracy[kPlanecell];
    std::vector<std::vector<std::string>> rows = {
        {"planecell extraction per frame (one core)",
         number(1000.0 * kPaperExtractionS, 0) + " ms for ~700 cells",
         number(stage_p50(r, "extract"), 1) + " ms p50 for " + number(cells_per_frame, 0) + " cells"},
        {"CRF merging per frame", number(1000.0 * kPaperMergeS, 0) + " ms",
         number(stage_p50(r, "merge"), 1) + " ms p50"},
        {"map bytes per frame", "45 kB",
         bytes(static_cast<double>(mem.planecell_ram_bytes) / per_frame) + " in RAM, " +
             bytes(static_cast<double>(mem.planecell_store_bytes) / per_frame) + " in the store"}};
    if (!r.frame_scores.empty())
      rows.push_back({"planecell within 10 / 20 / 50 / 100 cm (Table 1, SGBM input)",
                      number(eval::kPaperTable1SgbmPct[0], 2) + " / " + number(eval::kPaperTable1SgbmPct[1], 2) +
                          " / " + number(eval::kPaperTable1SgbmPct[2], 2) + " / " +
                          number(eval::kPaperTable1SgbmPct[3], 2) + " %",
                      pct(c, 0.1) + " / " + pct(c, 0.2) + " / " + pct(c, 0.5) + " / " + pct(c, 1.0) +
                          " % (planecell SGM input)"});
    md << report::table({"figure", "paper", "this run"}, rows) << again;
    md << "\n" << (r.threaded ? "Stage times come from the threaded run (stages share the cores). "
                               : "Stage times are single-thread. ")
       << "`planecell eval-stereo --dataset kitti --root DIR --calib calib.txt` scores the same "
          "Table 1 figures on KITTI stereo pairs.\n\n";
  }

  // --- accuracy --------------------------------------------------------------------------------
  md << "## Reconstruction accuracy\n\n"
        "For every GT pixel (u, v) (GT disparity > 0), the reconstructed 3D point is compared with "
        "the GT point X(u, v, d_gt) = Z·((u − c_x)/f_x, (v − c_y)/f_y, 1), Z = f_x·B/d_gt, in the "
        "left camera frame of that frame. A pixel counts as within x when its point lies within x "
        "metres of the GT point; a pixel without a point counts as outside every x, so each curve "
        "ends at most at the representation's density. Per frame:\n\n"
        "- **planecell**: X(u, v, d) with d the frame's dense plane disparity "
        "(`PlanecellFrame::dense_disparity`, the planes of the cells rendered back into the "
        "image);\n"
        "- **points**: X(u, v, d) with d the raw SGM disparity;\n"
        "- **voxel**: the centre of the occupied voxel that the pixel's SGM point falls in (the "
        "map "
        "after this frame's insertion; a point farther than voxel.max_range_m is never inserted "
        "and "
        "counts as missing). Ray casting the octree along each pixel's ray (first occupied voxel) "
        "would be the alternative; it is not done here (up to 400 voxel steps per pixel at 40 "
        "m).\n\n";
  if (r.frame_scores.empty()) {
    md << "**No frame had GT disparity** (`disp_occ_0/` beside the sequence, as written by "
          "`planecell synth`), so there is no accuracy for this sequence.\n\n";
  } else {
    md << report::image("reconstruction accuracy", kAccuracyFigure) << again << "\n";
    std::vector<std::vector<std::string>> rows;
    for (std::size_t k = 0; k < kRepresentations; ++k) {
      const auto& c = r.accuracy[k];
      rows.push_back({representation_name(k), pct(c, 0.1), pct(c, 0.2), pct(c, 0.5), pct(c, 1.0),
                      number(c.density_pct(), 1), std::to_string(c.gt_pixels())});
    }
    md << "Table 1 layout (% of GT pixels within the distance):\n\n"
       << report::table(
              {"method", "< 10 cm", "< 20 cm", "< 50 cm", "< 100 cm", "density %", "GT pixels"},
              rows)
       << again;
    if (r.frames_without_gt > 0)
      md << "\n" << r.frames_without_gt << " frame(s) had no GT disparity and are not scored.\n";
    if (r.frame_scores.size() <= 60) {
      rows.clear();
      for (const auto& f : r.frame_scores) {
        std::vector<std::string> row = {std::to_string(f.frame_id)};
        for (std::size_t k = 0; k < kRepresentations; ++k) {
          row.push_back(pct(f.curves[k], 0.1));
          row.push_back(pct(f.curves[k], 1.0));
        }
        rows.push_back(row);
      }
      md << "\nPer frame (% within 10 cm / 100 cm):\n\n"
         << report::table({"frame", "planecell ≤ 10 cm", "planecell ≤ 100 cm", "points ≤ 10 cm",
                           "points ≤ 100 cm", "voxel ≤ 10 cm", "voxel ≤ 100 cm"},
                          rows)
         << again;
    } else {
      md << "\nPer-frame figures: `accuracy.per_frame` in " << kReportJson << ".\n";
    }
  }

  // --- memory ----------------------------------------------------------------------------------
  md << "\n## Memory\n\n"
        "Bytes of each representation as frames are added (sampled every few frames; the last "
        "sample is after the last frame). planecell: the global map in RAM "
        "(`GlobalMap::map_bytes`: heap bytes of cells, surfaces and index; at the end the map "
        "settled, `map.settle_at_close`: the last frames' cells consolidated and their surfaces "
        "dormant, as a session's close leaves it) and the SQLite map "
        "store on disk (database + WAL); points: every valid SGM pixel of every frame kept as 3 "
        "floats + 3 colour bytes (counted, not kept by the bench); voxel: OctoMap `memoryUsage()` "
        "and the size of its `.bt` (occupancy only) and `.ot` (with colour) serialisations.\n\n"
     << report::image("map size versus frames", kMemoryFigure) << again << "\n";
  {
    const double base = static_cast<double>(std::max<std::size_t>(mem.planecell_ram_bytes, 1));
    auto row = [&](const std::string& name, std::size_t value, const std::string& count) {
      return std::vector<std::string>{name, bytes(static_cast<double>(value)),
                                      bytes(static_cast<double>(value) / per_frame),
                                      number(static_cast<double>(value) / base, 2), count};
    };
    std::vector<std::vector<std::string>> rows = {
        row(r.replay.settled ? "planecell map in RAM (settled)" : "planecell map in RAM",
            mem.planecell_ram_bytes, std::to_string(mem.planecell_cells) + " cells"),
        row("planecell map store (disk)", mem.planecell_store_bytes,
            std::to_string(r.map_cells) + " cells, " + std::to_string(r.map_surfaces) +
                " surfaces"),
        row("point cloud", mem.point_bytes, std::to_string(mem.points) + " points"),
        row("OctoMap in RAM (memoryUsage)", mem.octomap_ram_bytes,
            std::to_string(mem.voxels) + " voxels"),
        row("OctoMap .bt", mem.octomap_bt_bytes, ""),
        row("OctoMap .ot", mem.octomap_ot_bytes, "")};
    if (r.replay.settled)  // the live map after the last frame, beside the settled one
      rows.insert(rows.begin() + 1, row("planecell map in RAM after the last frame (live)",
                                        r.replay.map_bytes_live, "before settling"));
    md << "After " << mem.frames << " frames:\n\n"
       << report::table({"representation", "bytes", "per frame", "× planecell RAM", "elements"},
                        rows)
       << again;
  }

  // --- time ------------------------------------------------------------------------------------
  md << "\n## Time\n\n"
     << (r.threaded ? "The planecell stages ran as the threaded pipeline (one thread per stage); "
                      "the baselines and the scoring ran on its publish thread, so they share the "
                      "cores and their cost is part of the publish stage and of frames/s.\n\n"
                    : "Everything ran on one thread, one stage after the other, so the stage "
                      "latencies are the stages' own.\n\n")
     << report::image("per-stage latency", kLatencyFigure) << again << "\n";
  {
    std::vector<std::vector<std::string>> rows;
    for (const auto& [name, s] : r.replay.stage_latency) rows.push_back(latency_row(name, s));
    for (const auto& [name, s] : r.bench_latency) rows.push_back(latency_row(name, s));
    md << "Latency per frame (ms):\n\n"
       << report::table({"stage", "what", "frames", "p50", "p95", "p99", "max", "mean"}, rows)
       << again;
    md << "\nThroughput: " << number(r.wall_s > 0 ? frames / r.wall_s : 0.0, 2)
       << " frames/s for the "
       << "whole bench (" << number(r.wall_s, 1)
       << " s wall, all three representations and the scoring); "
       << "the planecell pipeline alone ran at " << number(r.replay.frames_per_s, 2)
       << " frames/s by its own wall clock"
       << (r.threaded ? " (with the bench work on its publish thread)" : " (bench work included)")
       << ". Estimated single-thread frames/s from the mean stage latencies: planecell "
       << number(estimated_frames_per_s(r, kPlanecell), 2) << ", points "
       << number(estimated_frames_per_s(r, kPoints), 2) << ", voxel "
       << number(estimated_frames_per_s(r, kVoxel), 2) << ". Peak resident memory of the process "
       << "(getrusage ru_maxrss): " << bytes(static_cast<double>(r.peak_rss_bytes)) << ".\n"
       << again;
  }

  // --- views -----------------------------------------------------------------------------------
  md << "\n## Views\n\n";
  if (r.top_views) {
    md << "The stored planecell map (" << r.map_cells << " cells, " << r.map_surfaces
       << " surfaces) seen from above (orthographic, along −up), coloured by height (up·X, m; 0 = "
          "the world origin, the first camera for synthetic and KITTI sequences) and by CRF "
          "surface "
          "label (cells of one surface share a colour; the paper's last figure). Cells are drawn "
          "lowest first; the view spans the 1st–99th percentile of the cells' vertices, so a few "
          "long, far cells may run off its edge:\n\n"
       << report::image("planecell map from above, coloured by height", kTopHeightFigure) << "\n"
       << report::image("planecell map from above, coloured by surface label", kTopSurfaceFigure)
       << again;
  } else {
    md << "The map has no cell to draw from above.\n";
  }
  if (!r.overlay_figure.empty())
    md << "\nPlanecells of frame " << *r.overlay_frame << " over its image (mean colour per cell, "
       << "white boundaries, red vertices, planeless cells dark):\n\n"
       << report::image("planecells of one frame", r.overlay_figure) << again;

  // --- merging ---------------------------------------------------------------------------------
  if (r.replay.merge_metrics) {
    const auto& m = *r.replay.merge_metrics;
    md << "\n## Merging against GT surfaces\n\n"
       << "Targets (issue 5): ≥ 90 % of GT area in one label, < 2 % of cells across GT planes (surfaces "
          "on one world plane count as one). \"Beyond 2 σ_Z\": cells merged into a label whose dominant "
          "GT plane lies further than twice the cell's own modelled depth noise from the cell's GT plane "
          "(the cross-merges its depth could have told apart).\n\n"
       << report::table(
              {"GT area in its dominant label %", "GT area in one label %",
               "cells merged across GT surfaces %", "across GT planes %",
               "across GT planes beyond 2 σ_Z %", "GT surfaces", "labels", "cells"},
              {{number(100 * m.area_in_dominant_label, 1), number(100 * m.area_one_label, 1),
                number(100 * m.cross_merged_cells, 1), number(100 * m.cross_merged_cells_between_planes, 1),
                m.plane_error_cells > 0 ? number(100 * m.cross_merged_cells_resolvable, 2) : std::string("—"),
                std::to_string(m.gt_surfaces), std::to_string(m.labels), std::to_string(m.cells)}})
       << again;
    if (!m.by_kind.empty()) {
      std::vector<std::vector<std::string>> rows;
      const auto share_row = [](const std::string& name, const eval::MergeMetrics::KindShare& k) {
        return std::vector<std::string>{name, std::to_string(k.gt_surfaces), number(100 * k.area, 1),
                                        number(100 * k.one_label, 1), number(100 * k.lost, 1)};
      };
      for (const auto& k : m.by_kind) rows.push_back(share_row(k.kind, k));
      if (const auto& w = m.weak_texture; w.gt_surfaces > 0)
        rows.push_back(share_row("*" + w.kind + " (any kind, included above)*", w));
      md << "\nBy kind of GT surface (% of all GT area; the kinds' last column adds up to what the one-label "
            "figure misses):\n\n"
         << report::table({"kind", "GT surfaces", "GT area %", "in one label %", "not in one label %"}, rows)
         << again;
    }
  }

  // --- settings --------------------------------------------------------------------------------
  const auto& c = r.config;
  md << "\n## Settings\n\n"
     << "SGM: " << c.sgm.paths << " paths, P1 " << c.sgm.p1 << ", P2 " << c.sgm.p2
     << ", max disparity " << c.sgm.max_disparity << "; extraction: " << c.extraction.target_cells
     << " cells asked; map: range " << number(c.map.max_range_m, 0)
     << " m; voxel: " << number(c.voxel.resolution_m, 2) << " m, range "
     << number(c.voxel.max_range_m, 0) << " m. `planecell config` prints the whole configuration; "
     << "the JSON twin of this report is " << kReportJson << ", the map store " << kMapStore
     << ".\n";

  for (const auto& [name, text] : r.appended)
    md << "\n---\n\n_Appended from `" << name << "`:_\n\n" << report::demote_headings(text);
  return md.str();
}

}  // namespace planecell::services::bench
