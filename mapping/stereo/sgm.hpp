#pragma once
/// SGM disparity stage (paper §4.1): Census + gradient matching cost, semi-global aggregation.
#include <opencv2/core/mat.hpp>

#include "core/config/sgm_config.hpp"

namespace planecell::stereo {

/// Disparity of the left image: CV_32F px, NaN = invalid (occluded, unmatched, removed speckle).
/// `left`/`right`: rectified, same size, CV_8UC1 or CV_8UC3 (converted to gray).
/// Throws InputError on empty or mismatched images, ConfigError on a bad config
/// (max_disparity <= 0 or >= width, ...).
cv::Mat compute_disparity(const cv::Mat& left, const cv::Mat& right, const SgmConfig& config);

/// The checks compute_disparity starts with (InputError / ConfigError naming the bad value).
void validate_sgm_input(const cv::Mat& left, const cv::Mat& right, const SgmConfig& config);

/// Straightforward scalar SGM with full W×H×D volumes per path (int32, no SIMD, one thread):
/// the reference the fast path is tested against. Same maths, same results.
cv::Mat compute_disparity_reference(const cv::Mat& left, const cv::Mat& right,
                                    const SgmConfig& config);

}  // namespace planecell::stereo
