#include "io/synthetic/pose_noise.hpp"

#include <cmath>
#include <numbers>
#include <random>
#include <sstream>
#include <vector>

#include "core/error.hpp"

namespace planecell::io {
namespace {

Eigen::Vector3d gaussian3(std::mt19937_64& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const double x = normal(rng), y = normal(rng), z = normal(rng);
  return {x, y, z};
}

Eigen::Vector3d unit_direction(std::mt19937_64& rng) {
  for (;;) {
    const Eigen::Vector3d g = gaussian3(rng);
    if (g.norm() > 1e-6) return g.normalized();
  }
}

/// normalise(bias + 0.5·g), g standard normal (bias itself in the measure-zero case of a zero sum).
Eigen::Vector3d biased_direction(const Eigen::Vector3d& bias, std::mt19937_64& rng) {
  const Eigen::Vector3d d = bias + 0.5 * gaussian3(rng);
  return d.norm() > 1e-9 ? Eigen::Vector3d(d.normalized()) : bias;
}

}  // namespace

PoseDrift parse_pose_drift(const std::string& text) {
  const auto fail = [&]() -> PoseDrift {
    throw ConfigError("--pose-noise '" + text +
                      "': expected TRANS_PER_M,ROT_DEG_PER_M[,TRANS_PER_STEP_M,ROT_DEG_PER_STEP] (two or four "
                      "non-negative numbers, e.g. 0.01,0.1 or 0.01,0.1,0.002,0.02)");
  };
  std::vector<std::string> parts;
  for (std::size_t begin = 0;;) {
    const auto comma = text.find(',', begin);
    parts.push_back(text.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin));
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  if (parts.size() != 2 && parts.size() != 4) return fail();
  PoseDrift drift;
  const auto parse = [&](const std::string& part, double& value) {
    std::size_t used = 0;
    try {
      value = std::stod(part, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (part.empty() || used != part.size() || !std::isfinite(value) || value < 0.0) fail();
  };
  parse(parts[0], drift.translation_per_m);
  parse(parts[1], drift.rotation_deg_per_m);
  if (parts.size() == 4) {
    parse(parts[2], drift.translation_per_step_m);
    parse(parts[3], drift.rotation_deg_per_step);
  }
  return drift;
}

std::vector<Pose> add_odometry_drift(std::span<const Pose> ground_truth, const PoseDrift& drift,
                                     std::uint64_t seed) {
  if (!(drift.translation_per_m >= 0.0) || !(drift.rotation_deg_per_m >= 0.0) ||
      !(drift.translation_per_step_m >= 0.0) || !(drift.rotation_deg_per_step >= 0.0))
    throw ConfigError("pose drift: rates must be non-negative (got " +
                      std::to_string(drift.translation_per_m) + " m/m, " +
                      std::to_string(drift.rotation_deg_per_m) + " deg/m)");
  std::vector<Pose> noisy;
  if (ground_truth.empty()) return noisy;
  noisy.reserve(ground_truth.size());
  for (std::size_t i = 0; i < ground_truth.size(); ++i)
    validate_pose(ground_truth[i], "pose drift: ground-truth pose " + std::to_string(i));

  std::mt19937_64 rng(seed);
  const Eigen::Vector3d translation_bias = unit_direction(rng);
  const Eigen::Vector3d rotation_bias = unit_direction(rng);
  noisy.push_back(ground_truth[0]);
  for (std::size_t i = 1; i < ground_truth.size(); ++i) {
    const Pose step = ground_truth[i - 1].inverse() * ground_truth[i];
    const double length_m = step.translation().norm();
    const Eigen::Vector3d b = biased_direction(translation_bias, rng);
    const Eigen::Vector3d a = biased_direction(rotation_bias, rng);
    Pose error = Pose::Identity();
    error.linear() =
        Eigen::AngleAxisd((drift.rotation_deg_per_m * length_m + drift.rotation_deg_per_step) *
                              std::numbers::pi / 180.0,
                          a)
            .toRotationMatrix();
    error.translation() = (drift.translation_per_m * length_m + drift.translation_per_step_m) * b;
    Pose next = noisy.back() * step * error;
    // Re-orthonormalise against round-off accumulated over long sequences.
    next.linear() = Eigen::Quaterniond(next.linear()).normalized().toRotationMatrix();
    noisy.push_back(next);
  }
  return noisy;
}

}  // namespace planecell::io
