#include "services/render/cell_overlay.hpp"

#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace planecell::services::render {

cv::Mat draw_cell_overlay(const cv::Mat& image, const extraction::PlanecellFrame& frame) {
  const cv::Mat& labels = frame.labels;
  if (labels.size() != image.size() || labels.type() != CV_32S)
    throw InputError("cell overlay: the label image (" + std::to_string(labels.cols) + "x" +
                     std::to_string(labels.rows) + ") must be CV_32S and the size of the image (" +
                     std::to_string(image.cols) + "x" + std::to_string(image.rows) + ")");
  cv::Mat overlay;
  if (image.channels() == 1)
    cv::cvtColor(image, overlay, cv::COLOR_GRAY2BGR);
  else
    overlay = image.clone();
  for (int v = 0; v < labels.rows; ++v) {
    const auto* row = labels.ptr<std::int32_t>(v);
    auto* out = overlay.ptr<cv::Vec3b>(v);
    for (int u = 0; u < labels.cols; ++u) {
      const Planecell& cell = frame.cells.at(static_cast<std::size_t>(row[u]));
      const cv::Vec3b mean(cv::saturate_cast<uchar>(cell.mean_rgb.z()),
                           cv::saturate_cast<uchar>(cell.mean_rgb.y()),
                           cv::saturate_cast<uchar>(cell.mean_rgb.x()));
      for (int c = 0; c < 3; ++c)
        out[u][c] = cv::saturate_cast<uchar>(cell.has_plane ? 0.4 * out[u][c] + 0.6 * mean[c]
                                                            : 0.3 * out[u][c]);
      const bool edge = (u + 1 < labels.cols && row[u + 1] != row[u]) ||
                        (v + 1 < labels.rows && labels.at<std::int32_t>(v + 1, u) != row[u]);
      if (edge) out[u] = cv::Vec3b(255, 255, 255);
    }
  }
  for (const Planecell& cell : frame.cells)
    for (const auto& p : cell.vertices_px)
      cv::circle(overlay, cv::Point(cvRound(p.x()), cvRound(p.y())), 1, cv::Scalar(0, 0, 255),
                 cv::FILLED);
  return overlay;
}

}  // namespace planecell::services::render
