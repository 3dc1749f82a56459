#pragma once
/// Colours of map cells shared by every view of a map (PLY export, bench top views), so that one
/// surface has the same colour everywhere.
#include <cstdint>
#include <opencv2/core.hpp>

namespace planecell::services::render {

/// Colour of a CRF surface label (BGR): a fixed pseudo-random hue per id, hue = frac(id·0.618…)
/// (golden-ratio steps keep consecutive ids far apart), saturation 200, value 230 (OpenCV HSV).
cv::Vec3b surface_colour_bgr(std::uint32_t surface);

}  // namespace planecell::services::render
