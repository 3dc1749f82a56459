#include "services/bench/bench_figures.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>

#include "services/bench/plot.hpp"
#include "services/report/markdown.hpp"

namespace planecell::services::bench {
namespace {

/// Log byte axis with ticks at 1, 10 and 100 × 1024^k (1 kB, 10 kB, 100 kB, 1 MB, ...), from the
/// tick below the smallest value to the tick above the largest.
Axis bytes_axis(double lo, double hi) {
  Axis axis;
  axis.log10 = true;
  axis.label = "bytes (log scale)";
  axis.format = [](double v) {  // the ticks are whole multiples of a unit: "10 KiB", "1 MiB"
    const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    int unit = 0;
    while (v >= 1024.0 && unit < 4) v /= 1024.0, ++unit;
    return report::number(v, 0) + " " + units[unit];
  };
  for (double unit = 1.0; unit <= 1024.0 * 1024 * 1024 * 1024; unit *= 1024.0)
    for (double m : {1.0, 10.0, 100.0}) axis.ticks.push_back(m * unit);
  axis.min = axis.ticks.front();
  for (double t : axis.ticks)
    if (t <= lo) axis.min = t;
  axis.max = axis.ticks.back();
  for (auto it = axis.ticks.rbegin(); it != axis.ticks.rend(); ++it)
    if (*it >= hi) axis.max = *it;
  if (!(axis.max > axis.min)) axis.max = axis.min * 10.0;
  return axis;
}

}  // namespace

cv::Mat accuracy_figure(const BenchReport& report) {
  LinePlot plot;
  plot.title =
      "Reconstruction accuracy (" + std::to_string(report.frame_scores.size()) + " frames with GT)";
  plot.x = linear_axis(0.0, report.accuracy[0].max_m(), "distance to the GT point x (m)");
  plot.y = linear_axis(0.0, 100.0, "GT pixels within x (%)");
  for (std::size_t k = 0; k < kRepresentations; ++k) {
    const auto& curve = report.accuracy[k];
    Series s;
    s.name = std::string(representation_name(k)) + " (density " +
             report::number(curve.density_pct(), 1) + " %)";
    s.colour = series_colour(k);
    for (int i = 0; i <= curve.steps(); ++i) {
      s.x.push_back(curve.threshold_m(i));
      s.y.push_back(curve.gt_pixels() > 0 ? curve.within_pct(i) : NAN);
    }
    plot.series.push_back(std::move(s));
  }
  return render_line_plot(plot);
}

cv::Mat memory_figure(const BenchReport& report) {
  LinePlot plot;
  plot.title = "Map size versus frames";
  plot.legend = LegendPlace::kOutsideRight;
  plot.size = cv::Size(1100, 600);
  struct Line {
    const char* name;
    std::size_t MemorySample::*field;
  };
  const Line lines[] = {{"planecell map in RAM", &MemorySample::planecell_ram_bytes},
                        {"planecell map store (SQLite)", &MemorySample::planecell_store_bytes},
                        {"point cloud (15 B/point)", &MemorySample::point_bytes},
                        {"OctoMap in RAM (memoryUsage)", &MemorySample::octomap_ram_bytes},
                        {"OctoMap .bt file", &MemorySample::octomap_bt_bytes}};
  double lo = INFINITY, hi = 0.0, frames = 1.0;
  for (const auto& m : report.memory) {
    frames = std::max(frames, static_cast<double>(m.frames));
    for (const auto& line : lines) {
      const double v = static_cast<double>(m.*line.field);
      if (v > 0) lo = std::min(lo, v), hi = std::max(hi, v);
    }
  }
  if (!(hi > 0)) lo = 1.0, hi = 10.0;
  plot.x = linear_axis(0.0, std::max(frames, 1.0), "frames mapped");
  plot.x.min_step = 1.0;  // whole frames
  plot.y = bytes_axis(lo, hi);
  for (std::size_t k = 0; k < std::size(lines); ++k) {
    Series s;
    s.name = lines[k].name;
    s.colour = series_colour(k);
    s.markers = report.memory.size() <= 60;
    for (const auto& m : report.memory) {
      s.x.push_back(static_cast<double>(m.frames));
      s.y.push_back(static_cast<double>(m.*lines[k].field));  // 0 is skipped on a log axis
    }
    plot.series.push_back(std::move(s));
  }
  return render_line_plot(plot);
}

cv::Mat latency_figure(const BenchReport& report) {
  BarPlot plot;
  plot.title = std::string("Per-stage latency") +
               (report.threaded ? " (threaded pipeline)" : " (one thread)");
  plot.series = {"p50", "p95", "p99"};
  double hi = 1.0;
  auto add = [&](const std::vector<std::pair<std::string, LatencySummary>>& log) {
    for (const auto& [name, s] : log) {
      if (name == "end_to_end") continue;  // a sum of the others plus queueing: not one stage
      plot.groups.push_back(name);
      plot.values.push_back({s.p50_ms, s.p95_ms, s.p99_ms});
      hi = std::max(hi, s.p99_ms);
    }
  };
  add(report.replay.stage_latency);
  add(report.bench_latency);
  plot.y = linear_axis(0.0, hi * 1.3, "latency (ms)");  // headroom for the legend
  plot.size = cv::Size(std::max(960, 110 * static_cast<int>(plot.groups.size()) + 160), 600);
  return render_bar_plot(plot);
}

}  // namespace planecell::services::bench
