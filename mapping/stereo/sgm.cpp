/// The SGM disparity stage: validation, then census → (cost rows inside the aggregation passes)
/// → selection → speckles.
#include "mapping/stereo/sgm.hpp"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <memory>
#include <string>
#include <thread>

#include "core/error.hpp"
#include "mapping/stereo/sgm_detail.hpp"

namespace planecell::stereo {
namespace {

void require(bool ok, const std::string& what) {
  if (!ok) throw ConfigError("sgm." + what);
}

cv::Mat to_gray(const cv::Mat& image) {
  if (image.type() == CV_8UC1) return image;
  cv::Mat gray;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

}  // namespace

void validate_sgm_input(const cv::Mat& left, const cv::Mat& right, const SgmConfig& c) {
  if (left.empty()) throw InputError("SGM: left image is empty");
  if (right.empty()) throw InputError("SGM: right image is empty");
  if (left.size() != right.size())
    throw InputError("SGM: left and right images differ in size (" + std::to_string(left.cols) +
                     "x" + std::to_string(left.rows) + " vs " + std::to_string(right.cols) + "x" +
                     std::to_string(right.rows) + ")");
  for (const auto* image : {&left, &right})
    if (image->type() != CV_8UC1 && image->type() != CV_8UC3)
      throw InputError(std::string("SGM: ") + (image == &left ? "left" : "right") +
                       " image must be 8-bit grey or BGR (CV_8UC1/CV_8UC3)");
  require(c.max_disparity_limit > 0, "max_disparity_limit must be > 0");
  require(c.max_image_pixels > 0.0, "max_image_pixels must be > 0");
  require(c.max_cost_volume_mb > 0.0, "max_cost_volume_mb must be > 0");
  const double pixels = static_cast<double>(left.cols) * left.rows;
  if (pixels > c.max_image_pixels)
    throw InputError("SGM: image " + std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                     " exceeds sgm.max_image_pixels = " + std::to_string(c.max_image_pixels));
  require(c.max_disparity <= c.max_disparity_limit,
          "max_disparity = " + std::to_string(c.max_disparity) +
              " exceeds max_disparity_limit = " + std::to_string(c.max_disparity_limit));
  const double volume_mb = pixels * std::max(c.max_disparity, 0) / (1024.0 * 1024.0);
  require(volume_mb <= c.max_cost_volume_mb,
          "max_disparity = " + std::to_string(c.max_disparity) + " on a " +
              std::to_string(left.cols) + "x" + std::to_string(left.rows) + " image needs a " +
              std::to_string(static_cast<long long>(volume_mb)) +
              " MiB cost volume, above max_cost_volume_mb = " +
              std::to_string(static_cast<long long>(c.max_cost_volume_mb)));
  require(c.max_disparity > 0 && c.max_disparity < left.cols,
          "max_disparity = " + std::to_string(c.max_disparity) + " must be in [1, image width " +
              std::to_string(left.cols) + ")");
  require(c.threads >= 1, "threads must be >= 1");
  require(c.census_width % 2 == 1 && c.census_height % 2 == 1 && c.census_width > 0 &&
              c.census_height > 0 && c.census_width * c.census_height <= 65,
          "census window " + std::to_string(c.census_width) + "x" +
              std::to_string(c.census_height) + " must be odd x odd with at most 65 pixels");
  require(c.lambda_grad >= 0.0 && c.lambda_grad <= 8.0, "lambda_grad must be in [0, 8]");
  require(c.grad_cap >= 0 && c.grad_cap <= 255, "grad_cap must be in [0, 255]");
  require(c.out_of_image_cost >= 0.0 && c.out_of_image_cost <= 1.0,
          "out_of_image_cost must be in [0, 1] (a share of the largest matching cost)");
  require(c.paths == 4 || c.paths == 8, "paths must be 4 or 8");
  require(c.p1 >= 0 && c.p2 >= c.p1 && c.p2 <= 7900, "penalties need 0 <= p1 <= p2 <= 7900");
  require(c.p2_slope >= 0.0, "p2_slope must be >= 0");
  require(c.uniqueness_ratio >= 0 && c.uniqueness_ratio < 100,
          "uniqueness_ratio must be in [0, 100)");
  require(c.lr_max_diff_px >= 0, "lr_max_diff_px must be >= 0");
  require(c.speckle_window_size >= 0, "speckle_window_size must be >= 0");
  require(c.speckle_range_px >= 0.0, "speckle_range_px must be >= 0");
}

cv::Mat compute_disparity(const cv::Mat& left, const cv::Mat& right, const SgmConfig& config) {
  return detail::compute_disparity_with(left, right, config, detail::best_aggregation_kernel());
}

cv::Mat detail::compute_disparity_with(const cv::Mat& left, const cv::Mat& right,
                                       const SgmConfig& config, AggregationKernel kernel) {
  validate_sgm_input(left, right, config);
  const cv::Mat gray_l = to_gray(left), gray_r = to_gray(right);
  // Census and gradient of the two images, one image per thread when there are two.
  CensusImage census_l, census_r;
  cv::Mat gradient_l, gradient_r;
  auto describe_left = [&] {
    census_l = census_transform(gray_l, config.census_width, config.census_height, 1);
    gradient_l = epipolar_gradient(gray_l);
  };
  auto describe_right = [&] {
    census_r = census_transform(gray_r, config.census_width, config.census_height, 1);
    gradient_r = epipolar_gradient(gray_r);
  };
  if (config.threads >= 2) {
    std::thread worker(describe_right);
    describe_left();
    worker.join();
  } else {
    describe_left();
    describe_right();
  }
  // The parked-sum volume (W·H·D_p uint16) is kept per calling thread between calls, so that a
  // stream of frames does not fault it in every frame. The cost rows are computed inside the
  // aggregation passes (no cost volume).
  thread_local std::unique_ptr<Volume<std::uint16_t>> parked;
  const std::size_t cells = static_cast<std::size_t>(left.cols) * left.rows *
                            padded_disparities(config.max_disparity);
  if (!parked || parked->size < cells) {
    parked.reset();
    parked = std::make_unique<Volume<std::uint16_t>>(cells);
  }
  const CostInputs costs = cost_inputs(census_l, census_r, gradient_l, gradient_r, config);
  const CostRowFunction cost_row_function =
      kernel == AggregationKernel::avx512 && cost_row_avx512_supported() ? &cost_row_avx512
                                                                          : &cost_row;
  cv::Mat disparity =
      aggregate_and_select(costs, cost_row_function, gray_l, config, *parked, kernel);
  remove_speckles(disparity, config);
  return disparity;
}

}  // namespace planecell::stereo
