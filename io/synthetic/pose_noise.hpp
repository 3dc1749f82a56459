#pragma once
/// Noisy odometry for the pose-refinement experiments: a seeded random-walk drift applied to a
/// ground-truth trajectory (`planecell synth --pose-noise TRANS_PER_M,ROT_DEG_PER_M`).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/pose.hpp"

namespace planecell::io {

/// Drift rates: per metre driven, the odometry step errs by translation_per_m metres (0.01 = 1 %)
/// and rotation_deg_per_m degrees; every step also errs by the floors translation_per_step_m and
/// rotation_deg_per_step (noise of a rig that hovers or stands, e.g. the EuRoC sample).
struct PoseDrift {
  double translation_per_m = 0.0;
  double rotation_deg_per_m = 0.0;
  double translation_per_step_m = 0.0;
  double rotation_deg_per_step = 0.0;
};

/// Parses "TRANS_PER_M,ROT_DEG_PER_M[,TRANS_PER_STEP_M,ROT_DEG_PER_STEP]" (e.g. "0.01,0.1" or
/// "0.01,0.1,0.002,0.02"). Throws ConfigError naming the text when it is not two or four finite
/// non-negative numbers separated by commas.
PoseDrift parse_pose_drift(const std::string& text);

/// Odometry with random-walk drift. With G_i the ground truth, s_i = |t(G_i) − t(G_{i−1})| the
/// step length and Δ_i = G_{i−1}⁻¹ G_i the true step, the noisy trajectory is
///   N_0 = G_0,   N_i = N_{i−1} · Δ_i · E_i,   E_i = [R(a_i, θ_i) | τ_i·b_i],
///   θ_i = rotation_deg_per_m·s_i + rotation_deg_per_step,   τ_i = translation_per_m·s_i + translation_per_step_m,
/// i.e. each step's error (in the camera frame of frame i) has translation norm exactly
/// translation_per_m·s_i + translation_per_step_m and rotation angle exactly rotation_deg_per_m·s_i +
/// rotation_deg_per_step, so the relative pose error of every step equals the rates (floors 0). The unit directions are b_i = normalise(b + 0.5·g_i),
/// a_i = normalise(a + 0.5·h_i) with b, a unit vectors drawn once per seed and g_i, h_i standard
/// normal (std::mt19937_64): a persistent bias, as real odometry has, so the error accumulates
/// roughly linearly with distance instead of as √n. Deterministic for a given seed (and standard
/// library). Throws InputError when a ground-truth pose is invalid, ConfigError on negative rates.
std::vector<Pose> add_odometry_drift(std::span<const Pose> ground_truth, const PoseDrift& drift,
                                     std::uint64_t seed);

}  // namespace planecell::io
