#pragma once
/// Plane function estimation (paper §4.4): RANSAC on a segment's valid disparities, refined by
/// least squares on the inliers.
#include <Eigen/Core>
#include <cstdint>
#include <span>

#include "core/config/planecell_config.hpp"
#include "core/plane.hpp"

namespace planecell::extraction {

/// Outcome of fitting d = a·u + b·v + c to one segment.
struct PlaneFitResult {
  bool ok = false;         ///< false: too few valid disparities or too few inliers (planeless)
  DisparityPlane plane;    ///< least-squares plane on the inliers (when ok)
  int inliers = 0;         ///< |θ(p) − d(p)| ≤ inlier_threshold_px
  int valid = 0;           ///< samples given
  double inlier_ratio() const { return valid > 0 ? static_cast<double>(inliers) / valid : 0.0; }
};

/// RANSAC over (u, v, d) samples (px): minimal 3-point hypotheses d = A·u + B·v + C, stopping
/// once the inlier share reaches config.target_inlier_ratio (or after ransac_iterations), then
/// least squares min Σ (A·u + B·v + C − d)² over the inliers (normal equations, Eigen LDLT),
/// iterated twice. Fails when fewer than config.min_valid_pixels samples are given or the final
/// inlier share is below config.min_inlier_ratio. Deterministic for a given seed.
PlaneFitResult fit_disparity_plane(std::span<const Eigen::Vector3f> samples_uvd,
                                   const ExtractionConfig& config, std::uint32_t seed);

}  // namespace planecell::extraction
