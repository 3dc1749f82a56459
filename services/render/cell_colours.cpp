#include "services/render/cell_colours.hpp"

#include <cmath>
#include <opencv2/imgproc.hpp>

namespace planecell::services::render {

cv::Vec3b surface_colour_bgr(std::uint32_t surface) {
  const double hue = std::fmod(static_cast<double>(surface) * 0.618033988749895, 1.0);
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(hue * 179.0, 200, 230)), bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  return bgr.at<cv::Vec3b>(0, 0);
}

}  // namespace planecell::services::render
