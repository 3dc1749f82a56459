/// `planecell eval-stereo --dataset D --root DIR` — planecell SGM vs OpenCV StereoSGBM on every
/// pair with ground truth under DIR (bad-1/2/4, D1, MAE, density, time), plus the dense planecell
/// disparity and, on pairs with a camera, the 3D accuracy within 10/20/50/100 cm (paper Table 1);
/// on synthetic pairs also the planecells' boundary recall and cells on one GT surface.
#include <spdlog/spdlog.h>

#include <fstream>
#include <iostream>
#include <optional>

#include "core/error.hpp"
#include "io/kitti_odometry.hpp"
#include "io/stereo_datasets.hpp"
#include "services/commands/commands.hpp"
#include "services/eval/segmentation_metrics.hpp"
#include "services/eval/stereo_markdown.hpp"
#include "services/eval/stereo_metrics.hpp"
#include "services/report/markdown.hpp"

namespace planecell::services {
namespace {

struct EvalStereoOptions {
  std::string dataset, root, json, report_md, calib;
  int max_pairs = 0;
};

/// The command line that reproduces this evaluation (printed under every markdown table).
std::string command_line(const CommandContext& context, const EvalStereoOptions& o) {
  std::string line = "planecell";
  if (!context.config_path.empty()) line += " --config " + report::shell_quote(context.config_path);
  line += " eval-stereo --dataset " + report::shell_quote(o.dataset) + " --root " + report::shell_quote(o.root);
  if (o.max_pairs > 0) line += " --max-pairs " + std::to_string(o.max_pairs);
  if (!o.calib.empty()) line += " --calib " + report::shell_quote(o.calib);
  return line;
}

int run_eval_stereo(const CommandContext& context, const EvalStereoOptions& options) {
  if (options.max_pairs < 0) throw ConfigError("--max-pairs must be >= 0 (0 = all)");
  const auto dataset = io::parse_stereo_dataset(options.dataset);
  auto refs = io::find_stereo_samples(dataset, options.root);
  if (refs.empty())
    throw InputError("eval-stereo: no " + options.dataset + " pair with ground truth under '" +
                     options.root + "'");
  if (options.max_pairs > 0 && refs.size() > static_cast<std::size_t>(options.max_pairs))
    refs.resize(static_cast<std::size_t>(options.max_pairs));
  const auto config = context.load_app_config();
  const auto methods = eval::default_stereo_methods(config.sgm, config.extraction);
  std::optional<io::KittiCalibration> calib;
  if (!options.calib.empty()) calib = io::read_kitti_calibration(options.calib);
  std::vector<eval::PairResult> results;
  for (const auto& ref : refs) {
    spdlog::info("eval-stereo: {}", ref.name);
    io::StereoSample sample = io::load_stereo_sample(ref);
    if (!sample.camera && calib) {
      // The dataset gave no calibration: the rig of --calib (colour pair P2/P3) stands in.
      sample.camera = io::stereo_camera_from_kitti(*calib, 2, sample.left.cols, sample.left.rows);
      spdlog::info("eval-stereo: {}: camera from --calib (fx {:.1f} px, baseline {:.3f} m)", ref.name,
                   sample.camera->fx, sample.camera->baseline_m);
    }
    results.push_back(eval::evaluate_pair(sample, methods));
    // Synthetic pairs carry GT surface ids: score how the planecells follow the surfaces.
    if (dataset == io::StereoDataset::kSynthetic) {
      const cv::Mat surfaces = eval::synthetic_surface_ids(ref);
      if (!surfaces.empty())
        results.back().segmentation =
            eval::planecell_segmentation(sample, surfaces, config.sgm, config.extraction);
    }
  }
  std::cout << eval::format_table(results, methods);
  if (!options.json.empty()) {
    std::ofstream out(options.json);
    out << eval::format_json(options.dataset, results, methods);
    if (!out) throw StorageError("--json '" + options.json + "': cannot write");
  }
  if (!options.report_md.empty()) {
    std::ofstream out(options.report_md);
    out << eval::format_markdown(options.dataset, command_line(context, options), results, methods);
    if (!out) throw StorageError("--report-md '" + options.report_md + "': cannot write");
    spdlog::info("eval-stereo: markdown report -> {}", options.report_md);
  }
  return kExitOk;
}

}  // namespace

void add_eval_stereo_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<EvalStereoOptions>();
  auto* command = app.add_subcommand(
      "eval-stereo",
      "Accuracy and time of planecell SGM, the dense planecell disparity and OpenCV StereoSGBM on\n"
      "every pair with ground truth (3D accuracy within 10/20/50/100 cm when a camera is known).\n"
      "Example: planecell eval-stereo --dataset middlebury --root data/middlebury --json m.json\n"
      "         planecell eval-stereo --dataset kitti --root data/kitti2015 --report-md k15.md");
  command->add_option("--dataset", options->dataset,
                      "middlebury, kitti, sceneflow (Scene Flow layout: disparity/[REST/]left/*.pfm beside\n"
                      "frames_cleanpass|frames_finalpass/[REST/]left|right/*.png, optional occlusion/) or synthetic")
      ->required();
  command->add_option("--root", options->root, "Folder searched recursively for pairs")->required();
  command->add_option("--json", options->json, "Also write the table as JSON");
  command->add_option("--report-md", options->report_md,
                      "Also write the tables as a markdown report (the style of `planecell bench`; "
                      "bench --append FILE adds it to a bench report)");
  command->add_option("--max-pairs", options->max_pairs, "Evaluate at most N pairs (0 = all)");
  command->add_option("--calib", options->calib,
                      "KITTI calibration (calib.txt, or calib_cam_to_cam.txt of KITTI raw) for pairs\n"
                      "whose dataset gives none, e.g. the KITTI 2012/2015 stereo samples: their\n"
                      "3D accuracy is then computed with that rig (colour pair P2/P3)")
      ->check(CLI::ExistingFile);
  context.add(command,
              [options](const CommandContext& ctx) { return run_eval_stereo(ctx, *options); });
}

}  // namespace planecell::services
