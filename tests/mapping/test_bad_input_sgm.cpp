/// SGM resource limits: images above sgm.max_image_pixels, disparity ranges above
/// sgm.max_disparity_limit and cost volumes above sgm.max_cost_volume_mb are refused by
/// validate_sgm_input, before compute_disparity allocates anything.
#include <gtest/gtest.h>

#include <limits>
#include <opencv2/core.hpp>
#include <string>

#include "core/error.hpp"
#include "mapping/stereo/sgm.hpp"
#include "support/expect_error.hpp"

namespace planecell::stereo {
namespace {

template <class Error, class Fn>
std::string message_of(Fn&& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no exception of the expected type";
  return {};
}

TEST(SgmLimits, ImageAboveTheConfiguredPixelLimitIsAnInputError) {
  const cv::Mat image(40, 64, CV_8UC1, cv::Scalar(9));  // 2560 px
  SgmConfig c;
  c.max_disparity = 16;
  c.max_image_pixels = 2560;
  EXPECT_NO_THROW(validate_sgm_input(image, image, c));
  c.max_image_pixels = 2559;
  const auto message = message_of<InputError>([&] { validate_sgm_input(image, image, c); });
  EXPECT_CONTAINS(message, "image 64x40 exceeds sgm.max_image_pixels");
  EXPECT_THROW(compute_disparity(image, image, c), InputError);
}

TEST(SgmLimits, DisparityRangeAboveItsSanityBoundIsAConfigError) {
  const cv::Mat image(8, 4000, CV_8UC1, cv::Scalar(9));
  SgmConfig c;
  c.max_disparity = 1024;  // the default bound: accepted
  EXPECT_NO_THROW(validate_sgm_input(image, image, c));
  c.max_disparity = 1025;
  EXPECT_CONTAINS(message_of<ConfigError>([&] { validate_sgm_input(image, image, c); }),
                  "sgm.max_disparity = 1025 exceeds max_disparity_limit = 1024");
  c.max_disparity_limit = 0;
  EXPECT_CONTAINS(message_of<ConfigError>([&] { validate_sgm_input(image, image, c); }),
                  "max_disparity_limit must be > 0");
}

TEST(SgmLimits, CostVolumeAboveTheConfiguredSizeIsAConfigError) {
  // 1024 x 512 px x 256 disparities = 128 MiB exactly.
  const cv::Mat image(512, 1024, CV_8UC1, cv::Scalar(9));
  SgmConfig c;
  c.max_disparity = 256;
  c.max_cost_volume_mb = 128.0;
  EXPECT_NO_THROW(validate_sgm_input(image, image, c));
  c.max_cost_volume_mb = 127.0;
  EXPECT_CONTAINS(message_of<ConfigError>([&] { validate_sgm_input(image, image, c); }),
                  "needs a 128 MiB cost volume, above max_cost_volume_mb = 127");
  c.max_cost_volume_mb = std::numeric_limits<double>::quiet_NaN();
  EXPECT_CONTAINS(message_of<ConfigError>([&] { validate_sgm_input(image, image, c); }),
                  "max_cost_volume_mb must be > 0");
}

}  // namespace
}  // namespace planecell::stereo
