/// `planecell extract LEFT RIGHT -o OUTDIR` — planecells of one stereo pair, with the dense plane
/// disparity, label image, overlay, PLY mesh and a JSON summary.
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <optional>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"
#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "io/kitti_odometry.hpp"
#include "io/planecell_codec.hpp"
#include "io/ply_export.hpp"
#include "mapping/planecell/extraction.hpp"
#include "mapping/stereo/sgm.hpp"
#include "services/commands/commands.hpp"
#include "services/render/cell_overlay.hpp"

namespace planecell::services {
namespace {

namespace fs = std::filesystem;

struct ExtractOptions {
  std::string left, right, disparity, out_dir, calib;
  std::optional<int> cells;
  std::optional<double> fx, baseline_m, cx, cy;
};

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  out.flush();
  if (!out) throw StorageError("cannot write '" + path.string() + "'");
}

int run_extract(const ExtractOptions& o, const CommandContext& ctx) {
  AppConfig config = ctx.load_app_config();
  if (o.cells) config.extraction.target_cells = *o.cells;
  const cv::Mat left = io::read_image(o.left, true);
  const cv::Mat right = io::read_image(o.right, true);
  if (left.size() != right.size())
    throw InputError("extract: '" + o.left + "' and '" + o.right + "' differ in size");

  StereoCamera camera;
  if (!o.calib.empty())
    camera = io::stereo_camera_from_kitti(io::read_kitti_calibration(o.calib), 2, left.cols,
                                          left.rows);
  if (o.fx) camera.fx = camera.fy = *o.fx;
  if (o.baseline_m) camera.baseline_m = *o.baseline_m;
  if (o.cx) camera.cx = *o.cx;
  if (o.cy) camera.cy = *o.cy;
  camera.width = left.cols;
  camera.height = left.rows;
  camera.validate("extract camera (--calib/--fx/--baseline)");

  const auto t0 = std::chrono::steady_clock::now();
  cv::Mat disparity;
  std::string source;
  if (!o.disparity.empty()) {
    disparity = io::read_disparity(o.disparity);
    if (disparity.size() != left.size())
      throw InputError("extract: disparity '" + o.disparity + "' is not the size of '" + o.left +
                       "'");
    source = "file";
  } else {
    disparity = stereo::compute_disparity(left, right, config.sgm);
    source = "sgm";
  }
  const double disparity_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  const auto frame = extraction::extract_planecells(left, right, disparity, camera, config.extraction);
  const auto compact = io::encode_planecells(frame.cells, camera, 0);

  const fs::path out(o.out_dir);
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) throw StorageError("extract: cannot create '" + out.string() + "': " + ec.message());
  io::write_pfm(out / "dense.pfm", frame.dense_disparity);
  if (frame.cells.size() > 65535)
    throw InputError("extract: " + std::to_string(frame.cells.size()) +
                     " cells do not fit a 16-bit label image (use fewer --cells)");
  cv::Mat labels16;
  frame.labels.convertTo(labels16, CV_16U);
  io::write_image(out / "labels.png", labels16);
  io::write_image(out / "overlay.png", render::draw_cell_overlay(left, frame));
  const std::size_t triangles = io::write_planecells_ply(out / "cells.ply", frame.cells, true);
  {
    std::ofstream bin(out / "cells.bin", std::ios::binary | std::ios::trunc);
    bin.write(reinterpret_cast<const char*>(compact.data()),
              static_cast<std::streamsize>(compact.size()));
    if (!bin) throw StorageError("extract: cannot write '" + (out / "cells.bin").string() + "'");
  }

  int dense_valid = 0;
  for (int v = 0; v < frame.dense_disparity.rows; ++v)
    for (int u = 0; u < frame.dense_disparity.cols; ++u)
      dense_valid += !std::isnan(frame.dense_disparity.at<float>(v, u));
  const auto& t = frame.timings;
  char json[1024];
  std::snprintf(json, sizeof(json),
                "{\n  \"cells\": %zu,\n  \"cells_asked\": %d,\n  \"plane_fraction\": %.4f,\n"
                "  \"planeless_fraction\": %.4f,\n  \"compact_bytes\": %zu,\n"
                "  \"triangles\": %zu,\n  \"dense_coverage\": %.4f,\n"
                "  \"disparity_source\": \"%s\",\n  \"image\": [%d, %d],\n"
                "  \"timings_ms\": {\"disparity\": %.2f, \"superpixels\": %.2f, \"planes\": %.2f, "
                "\"boundary_update\": %.2f, \"photometric\": %.2f, \"vertices\": %.2f, \"extraction_total\": %.2f}\n}\n",
                frame.cells.size(), config.extraction.target_cells, frame.plane_fraction,
                1.0 - frame.plane_fraction, compact.size(), triangles,
                static_cast<double>(dense_valid) / (left.cols * left.rows), source.c_str(),
                left.cols, left.rows, disparity_ms, t.superpixels_ms, t.planes_ms,
                t.boundary_update_ms, t.photometric_ms, t.vertices_ms, t.total_ms);
  write_text(out / "cells.json", json);
  spdlog::info("extract: {} cells ({:.1f} % with a plane), {} B compact, {:.1f} ms -> {}",
               frame.cells.size(), 100.0 * frame.plane_fraction, compact.size(), t.total_ms,
               out.string());
  return kExitOk;
}

}  // namespace

void add_extract_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<ExtractOptions>();
  auto* command = app.add_subcommand(
      "extract",
      "Extract the planecells of one rectified stereo pair (paper §4–5).\n"
      "Writes OUTDIR/dense.pfm (plane disparity), labels.png (16-bit cell ids), overlay.png,\n"
      "cells.ply (coloured polygons), cells.bin (compact encoding) and cells.json (summary).\n"
      "Without --disparity the SGM stage computes it. Example:\n"
      "  planecell extract left.png right.png --calib calib.txt -o /tmp/out --cells 800");
  command->add_option("LEFT", options->left, "Left (reference) image")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("RIGHT", options->right, "Right image")->required()->check(CLI::ExistingFile);
  command->add_option("--disparity", options->disparity,
                      "Use this disparity (.pfm, or KITTI 16-bit .png) instead of running SGM")
      ->check(CLI::ExistingFile);
  command->add_option("-o,--out", options->out_dir, "Output folder (created)")->required();
  command->add_option("--cells", options->cells, "Number of planecells asked (|S|)")
      ->check(CLI::Range(1, 65535));
  command->add_option("--calib", options->calib, "KITTI calib.txt (P2/P3 = left/right colour)")
      ->check(CLI::ExistingFile);
  command->add_option("--fx", options->fx, "Focal length (px); default KITTI 721.5377");
  command->add_option("--baseline", options->baseline_m, "Baseline (m); default KITTI 0.5372");
  command->add_option("--cx", options->cx, "Principal point x (px)");
  command->add_option("--cy", options->cy, "Principal point y (px)");
  context.add(command, [options](const CommandContext& ctx) { return run_extract(*options, ctx); });
}

}  // namespace planecell::services
