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
  /// Covariance of the slopes (a, b) from the final inliers, s²·C⁻¹ with s² = Σ r²/(n − 3) their
  /// residual variance and C = Σ (p − p̄)(p − p̄)ᵀ their centred image scatter, and their image
  /// centroid p̄ (px); both zero with ≤ 3 inliers, no residual or inliers on a line.
  Eigen::Matrix2d slope_covariance = Eigen::Matrix2d::Zero();
  Eigen::Vector2d inlier_centroid_px = Eigen::Vector2d::Zero();
  double inlier_ratio() const { return valid > 0 ? static_cast<double>(inliers) / valid : 0.0; }
};

/// Samples are processed in lanes of this many floats (one AVX register).
inline constexpr int kSampleLane = 8;

/// Disparity of a padding sample: never within any inlier threshold of a plane.
inline constexpr float kPaddingDisparity = 1e30f;

/// `count` samples (u, v, d) as structure of arrays, each array padded to a multiple of
/// kSampleLane with samples of disparity kPaddingDisparity (the hot path of fit_segment_planes).
struct SampleLanes {
  const float* u = nullptr;
  const float* v = nullptr;
  const float* d = nullptr;
  int count = 0;
  int padded_count() const { return (count + kSampleLane - 1) / kSampleLane * kSampleLane; }
};

/// RANSAC over (u, v, d) samples (px): minimal 3-point hypotheses d = A·u + B·v + C (indices
/// drawn uniformly with std::mt19937(seed)), each scored on an even subset of at most 96
/// samples, stopping once the inlier share reaches config.target_inlier_ratio (or after
/// ransac_iterations); then least squares min Σ (A·u + B·v + C − d)² over the inliers
/// (closed-form 2×2 normal equations in coordinates centred on the inliers' mean), iterated
/// twice. Fails when fewer than config.min_valid_pixels samples are given or the final inlier
/// share is below config.min_inlier_ratio. Coordinates are taken relative to the first sample;
/// hypotheses are scored in float lanes, the least squares and the final inlier count run in
/// double. Deterministic for a given seed.
PlaneFitResult fit_disparity_plane(const SampleLanes& samples, const ExtractionConfig& config,
                                   std::uint32_t seed);

/// The same on an array of (u, v, d) samples.
PlaneFitResult fit_disparity_plane(std::span<const Eigen::Vector3f> samples_uvd,
                                   const ExtractionConfig& config, std::uint32_t seed);

}  // namespace planecell::extraction
