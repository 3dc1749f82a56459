// GCC 12 reports a false -Warray-bounds inside Eigen::umeyama's AVX loads of a Vector3d (the
// diagnostic is attributed to avxintrin.h, so it must be silenced before the first include).
#pragma GCC diagnostic ignored "-Warray-bounds"
#include "services/eval/trajectory_metrics.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "core/error.hpp"

namespace planecell::services::eval {
namespace {

void check_lengths(std::span<const Pose> estimated, std::span<const Pose> ground_truth,
                   const char* what) {
  if (estimated.size() != ground_truth.size())
    throw InputError(std::string(what) + ": " + std::to_string(estimated.size()) +
                     " estimated poses but " + std::to_string(ground_truth.size()) +
                     " ground-truth poses");
}

}  // namespace

AteResult absolute_trajectory_error(std::span<const Pose> estimated, std::span<const Pose> ground_truth,
                                    bool align) {
  check_lengths(estimated, ground_truth, "ATE");
  if (estimated.empty()) throw InputError("ATE: no poses");
  const auto n = static_cast<Eigen::Index>(estimated.size());
  Eigen::Matrix3Xd p(3, n), g(3, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    p.col(i) = estimated[static_cast<std::size_t>(i)].translation();
    g.col(i) = ground_truth[static_cast<std::size_t>(i)].translation();
  }
  AteResult out;
  out.poses = estimated.size();
  if (align && n >= 3) out.alignment.matrix() = Eigen::umeyama(p, g, false);
  double sum_sq = 0.0, sum = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double d = (out.alignment * Eigen::Vector3d(p.col(i)) - g.col(i)).norm();
    sum_sq += d * d;
    sum += d;
    out.max_m = std::max(out.max_m, d);
  }
  out.rmse_m = std::sqrt(sum_sq / static_cast<double>(n));
  out.mean_m = sum / static_cast<double>(n);
  return out;
}

RpeResult relative_pose_error(std::span<const Pose> estimated, std::span<const Pose> ground_truth,
                              std::size_t frame_delta) {
  check_lengths(estimated, ground_truth, "RPE");
  if (frame_delta == 0) throw InputError("RPE: frame delta must be >= 1");
  RpeResult out;
  double sum_t = 0.0, sum_sq_t = 0.0, sum_deg = 0.0, sum_sq_deg = 0.0, sum_d = 0.0;
  for (std::size_t i = 0; i + frame_delta < estimated.size(); ++i) {
    const std::size_t j = i + frame_delta;
    double d = 0.0;
    for (std::size_t k = i + 1; k <= j; ++k)
      d += (ground_truth[k].translation() - ground_truth[k - 1].translation()).norm();
    if (!(d > 0.0)) continue;
    const Pose error = (ground_truth[i].inverse() * ground_truth[j]).inverse() *
                       (estimated[i].inverse() * estimated[j]);
    const double t = error.translation().norm();
    const double angle_deg = Eigen::AngleAxisd(error.linear()).angle() * 180.0 / std::numbers::pi;
    ++out.pairs;
    sum_t += t;
    sum_sq_t += t * t;
    sum_deg += angle_deg;
    sum_sq_deg += angle_deg * angle_deg;
    sum_d += d;
  }
  if (out.pairs > 0) {
    out.translation_rmse_m = std::sqrt(sum_sq_t / static_cast<double>(out.pairs));
    out.translation_percent = 100.0 * sum_t / sum_d;
    out.rotation_deg_per_m = sum_deg / sum_d;
    out.rotation_rmse_deg = std::sqrt(sum_sq_deg / static_cast<double>(out.pairs));
  }
  return out;
}

}  // namespace planecell::services::eval
