#pragma once
/// The picture of one frame's planecells over its image (`planecell extract`, `planecell bench`).
#include <opencv2/core/mat.hpp>

#include "mapping/planecell/extraction.hpp"

namespace planecell::services::render {

/// Cells in their mean colour blended over the image (0.4·image + 0.6·mean), boundaries white,
/// vertices red, planeless cells darkened to 0.3·image (like the paper's figures). `image` is the
/// frame's left image (BGR CV_8UC3, or CV_8UC1), `frame` its extraction (labels index frame.cells).
/// Throws InputError when the label image is not the image's size.
cv::Mat draw_cell_overlay(const cv::Mat& image, const extraction::PlanecellFrame& frame);

}  // namespace planecell::services::render
