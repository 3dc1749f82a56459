/// `planecell export` — a stored map as a coloured PLY of its planecell polygons, or as JSON
/// outlines of its surfaces.
#include <spdlog/spdlog.h>

#include <cmath>
#include <iostream>
#include <memory>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "io/map_store.hpp"
#include "io/outline_export.hpp"
#include "io/ply_export.hpp"
#include "services/commands/commands.hpp"
#include "services/render/cell_colours.hpp"

namespace planecell::services {
namespace {

/// Colour of a surface label as 0..255 RGB (render::surface_colour_bgr, shared with bench's views).
Eigen::Vector3f surface_colour(std::uint32_t surface) {
  const cv::Vec3b p = render::surface_colour_bgr(surface);
  return {static_cast<float>(p[2]), static_cast<float>(p[1]), static_cast<float>(p[0])};
}

}  // namespace

void add_export_command(CLI::App& app, CommandContext& context) {
  auto* command = app.add_subcommand("export",
                                     "Export a stored map (planecell replay --map) as a PLY of "
                                     "coloured polygons, or its surfaces' outlines as JSON "
                                     "(--outlines).");
  struct Args {
    std::string map, output, colour = "rgb";
    bool outlines = false;
    double tolerance_m = 0.1;
  };
  auto args = std::make_shared<Args>();
  command->add_option("map", args->map, "Map store (.db)")->required()->check(CLI::ExistingFile);
  command->add_option("-o,--output", args->output, "Output .ply (.json with --outlines)")->required();
  command->add_option("--color", args->colour,
                      "rgb: mean image colour; height: colour by height (world up); surface: one "
                      "colour per CRF surface label")
      ->check(CLI::IsMember({"rgb", "height", "surface"}))
      ->capture_default_str();
  command->add_flag(
      "--outlines", args->outlines,
      "Write the surfaces' outlines instead, as JSON: each surface's plane, colour and "
      "rings (the exact outer boundary and holes of its footprint, which holds everything "
      "fused into it, then simplified), a compact map for planners");
  command
      ->add_option("--tolerance", args->tolerance_m,
                   "With --outlines: Douglas-Peucker tolerance of the rings (m; 0 keeps every "
                   "footprint corner; the default, one 10 cm footprint bit, removes the bits' "
                   "staircase)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  command->footer(
      "Examples:\n  planecell export /tmp/street.db -o /tmp/street.ply --color surface\n"
      "  planecell export /tmp/street.db -o /tmp/street_outlines.json --outlines --tolerance 0.1");
  context.add(command, [args](const CommandContext& ctx) {
    const AppConfig config = ctx.load_app_config();
    const io::MapStore store(args->map);
    const map::GlobalMap global_map = io::load_map(store, config.map);
    if (args->outlines) {
      const io::OutlineExport written =
          io::write_outlines_json(args->output, global_map, args->tolerance_m);
      spdlog::info("export: {} surfaces as {} rings of {} vertices (tolerance {} m) -> {}",
                   written.surfaces, written.rings, written.vertices, args->tolerance_m,
                   args->output);
      return kExitOk;
    }
    std::vector<map::MapCell> cells;
    cells.reserve(global_map.cells().size());
    for (const auto& [id, cell] : global_map.cells()) cells.push_back(cell);
    std::sort(cells.begin(), cells.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
    if (args->colour == "surface") {
      for (auto& cell : cells) cell.mean_rgb = surface_colour(cell.surface);
    } else if (args->colour == "height") {
      const Eigen::Vector3f up = global_map.up().cast<float>();
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      std::vector<float> heights;
      for (const auto& cell : cells) {
        Eigen::Vector3f centre = Eigen::Vector3f::Zero();
        for (const auto& v : cell.vertices_m) centre += v;
        const float h = cell.vertices_m.empty() ? 0.0f : up.dot(centre) / cell.vertices_m.size();
        heights.push_back(h);
        lo = std::min(lo, h);
        hi = std::max(hi, h);
      }
      cv::Mat scaled(1, static_cast<int>(cells.size()), CV_8UC1), coloured;
      for (std::size_t i = 0; i < cells.size(); ++i)
        scaled.at<std::uint8_t>(0, static_cast<int>(i)) =
            cv::saturate_cast<std::uint8_t>(255.0f * (heights[i] - lo) / std::max(hi - lo, 1e-3f));
      if (!cells.empty()) cv::applyColorMap(scaled, coloured, cv::COLORMAP_TURBO);
      for (std::size_t i = 0; i < cells.size(); ++i) {
        const auto p = coloured.at<cv::Vec3b>(0, static_cast<int>(i));
        cells[i].mean_rgb = Eigen::Vector3f(p[2], p[1], p[0]);
      }
    }
    const std::size_t triangles = io::write_planecells_ply(args->output, cells);
    spdlog::info("export: {} cells, {} surfaces, {} triangles -> {}", cells.size(),
                 global_map.surfaces().size(), triangles, args->output);
    return kExitOk;
  });
}

}  // namespace planecell::services
