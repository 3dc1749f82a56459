/// `planecell disparity LEFT RIGHT -o OUT.{pfm,png}` — SGM disparity of one rectified pair.
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <opencv2/core.hpp>
#include <optional>

#include "core/error.hpp"
#include "io/disparity_io.hpp"
#include "io/image_io.hpp"
#include "io/paths.hpp"
#include "mapping/stereo/sgm.hpp"
#include "services/commands/commands.hpp"

namespace planecell::services {
namespace {

using io::lower_extension;

struct DisparityOptions {
  std::string left, right, output, preview;
  std::optional<int> max_disparity;
};

int run_disparity(const CommandContext& context, const DisparityOptions& options) {
  SgmConfig config = context.load_app_config().sgm;
  if (options.max_disparity) config.max_disparity = *options.max_disparity;
  const auto ext = lower_extension(options.output);
  if (ext != ".pfm" && ext != ".png")
    throw ConfigError("-o '" + options.output + "': output must end in .pfm or .png");
  const cv::Mat left = io::read_image(options.left);
  const cv::Mat right = io::read_image(options.right);
  if (left.size() != right.size())
    throw InputError("left '" + options.left + "' is " + std::to_string(left.cols) + "x" +
                     std::to_string(left.rows) + " but right '" + options.right + "' is " +
                     std::to_string(right.cols) + "x" + std::to_string(right.rows));
  const auto start = std::chrono::steady_clock::now();
  const cv::Mat disparity = stereo::compute_disparity(left, right, config);
  const double latency_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  io::write_disparity(options.output, disparity);
  if (!options.preview.empty())
    io::write_image(options.preview,
                    io::colourise_disparity(disparity, static_cast<float>(config.max_disparity)));
  const int valid = cv::countNonZero(disparity == disparity);  // NaN ≠ NaN
  spdlog::info("disparity {}x{}, {} disparities, {:.1f} % valid, {:.1f} ms → {}", left.cols,
               left.rows, config.max_disparity, 100.0 * valid / disparity.total(), latency_ms,
               options.output);
  return kExitOk;
}

}  // namespace

void add_disparity_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<DisparityOptions>();
  auto* command = app.add_subcommand(
      "disparity",
      "Disparity of a rectified stereo pair with planecell SGM (Census + gradient cost, 8 paths).\n"
      "Example: planecell disparity left.png right.png -o disp.pfm --preview disp_preview.png");
  command->add_option("LEFT", options->left, "Left (reference) image, grey or colour")->required();
  command->add_option("RIGHT", options->right, "Right image, same size")->required();
  command->add_option("-o,--output", options->output,
                      "Output disparity: .pfm (float) or .png (KITTI 16-bit, value = 256·d)")
      ->required();
  command->add_option("--max-disparity", options->max_disparity,
                      "Number of disparities searched (default: sgm.max_disparity of the config)");
  command->add_option("--preview", options->preview, "Also write a colour-mapped preview image");
  context.add(command, [options](const CommandContext& ctx) { return run_disparity(ctx, *options); });
}

}  // namespace planecell::services
