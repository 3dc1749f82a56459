/// Plane function estimation (paper §4.4): RANSAC + least squares per segment.
#include "mapping/planecell/plane_fit.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "mapping/planecell/superpixel_state.hpp"

namespace planecell::extraction {
namespace {

/// Hypotheses are scored on at most this many samples; the final count uses all of them.
constexpr std::size_t kScoringSamples = 96;

/// Plane through three (u, v, d) samples; false when they are (nearly) collinear in the image.
bool plane_through(const Eigen::Vector3f& p, const Eigen::Vector3f& q, const Eigen::Vector3f& r,
                   DisparityPlane& out) {
  const double u1 = q.x() - p.x(), v1 = q.y() - p.y(), d1 = q.z() - p.z();
  const double u2 = r.x() - p.x(), v2 = r.y() - p.y(), d2 = r.z() - p.z();
  const double det = u1 * v2 - u2 * v1;  // twice the triangle's image area (px²)
  if (std::abs(det) < 1.0) return false;
  out.a = (d1 * v2 - d2 * v1) / det;
  out.b = (u1 * d2 - u2 * d1) / det;
  out.c = p.z() - out.a * p.x() - out.b * p.y();
  return true;
}

int count_inliers(std::span<const Eigen::Vector3f> samples, const DisparityPlane& plane,
                  double threshold) {
  int n = 0;
  for (const auto& s : samples) n += std::abs(plane.at(s.x(), s.y()) - s.z()) <= threshold;
  return n;
}

/// Least squares on the inliers of `plane`, in coordinates centred on their mean (conditioning).
bool refine(std::span<const Eigen::Vector3f> samples, double threshold, DisparityPlane& plane) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  int n = 0;
  for (const auto& s : samples)
    if (std::abs(plane.at(s.x(), s.y()) - s.z()) <= threshold) {
      mean += s.cast<double>();
      ++n;
    }
  if (n < 3) return false;
  mean /= n;
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (const auto& s : samples) {
    if (std::abs(plane.at(s.x(), s.y()) - s.z()) > threshold) continue;
    const Eigen::Vector3d row(s.x() - mean.x(), s.y() - mean.y(), 1.0);
    ata += row * row.transpose();
    atb += row * (s.z() - mean.z());
  }
  // Degenerate spread (all inliers on a line): keep the hypothesis.
  if (ata(0, 0) * ata(1, 1) - ata(0, 1) * ata(0, 1) < 1e-6 * n * n) return false;
  const Eigen::Vector3d x = ata.ldlt().solve(atb);
  if (!x.allFinite()) return false;
  plane.a = x(0);
  plane.b = x(1);
  plane.c = x(2) + mean.z() - x(0) * mean.x() - x(1) * mean.y();
  return true;
}

}  // namespace

PlaneFitResult fit_disparity_plane(std::span<const Eigen::Vector3f> samples,
                                   const ExtractionConfig& config, std::uint32_t seed) {
  PlaneFitResult result;
  result.valid = static_cast<int>(samples.size());
  if (result.valid < std::max(3, config.min_valid_pixels)) return result;
  const double threshold = config.inlier_threshold_px;

  // Scoring subset: an even stride through the samples (deterministic, spatially spread).
  std::vector<Eigen::Vector3f> subset;
  std::span<const Eigen::Vector3f> scoring = samples;
  if (samples.size() > kScoringSamples) {
    subset.reserve(kScoringSamples);
    const double stride = static_cast<double>(samples.size()) / kScoringSamples;
    for (std::size_t k = 0; k < kScoringSamples; ++k)
      subset.push_back(samples[static_cast<std::size_t>(k * stride)]);
    scoring = subset;
  }

  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, samples.size() - 1);
  const int target = static_cast<int>(std::ceil(config.target_inlier_ratio * scoring.size()));
  DisparityPlane best;
  int best_inliers = -1;
  for (int it = 0; it < config.ransac_iterations; ++it) {
    DisparityPlane hypothesis;
    if (!plane_through(samples[pick(rng)], samples[pick(rng)], samples[pick(rng)], hypothesis))
      continue;
    const int inliers = count_inliers(scoring, hypothesis, threshold);
    if (inliers > best_inliers) {
      best_inliers = inliers;
      best = hypothesis;
      if (inliers >= target) break;
    }
  }
  if (best_inliers < 3) return result;
  for (int pass = 0; pass < 2; ++pass)
    if (!refine(samples, threshold, best)) break;
  result.plane = best;
  result.inliers = count_inliers(samples, best, threshold);
  result.ok = result.inliers >= 3 && result.inlier_ratio() >= config.min_inlier_ratio;
  return result;
}

namespace detail {

void fit_segment_planes(SuperpixelState& s, const SegmentPixels& groups,
                        const ExtractionConfig& config, SegmentPlaneFits& fits) {
  fits.inliers.assign(s.num_segments, 0);
  fits.valid.assign(s.num_segments, 0);
  s.planes.resize(s.num_segments);
  s.has_plane.assign(s.num_segments, 0);
  std::vector<Eigen::Vector3f> samples;
  for (int seg = 0; seg < s.num_segments; ++seg) {
    samples.clear();
    for (int k = groups.offsets[seg]; k < groups.offsets[seg + 1]; ++k) {
      const int i = groups.pixels[k];
      const float d = s.disparity[i];
      if (!std::isnan(d))
        samples.emplace_back(static_cast<float>(i % s.width), static_cast<float>(i / s.width), d);
    }
    const int area = groups.offsets[seg + 1] - groups.offsets[seg];
    fits.valid[seg] = static_cast<int>(samples.size());
    if (samples.size() < config.min_valid_ratio * area) continue;
    const auto fit = fit_disparity_plane(
        samples, config, static_cast<std::uint32_t>(config.random_seed) * 7919u + seg);
    fits.inliers[seg] = fit.inliers;
    if (!fit.ok) continue;
    s.planes[seg] = fit.plane;
    s.has_plane[seg] = 1;
  }
}

}  // namespace detail
}  // namespace planecell::extraction
