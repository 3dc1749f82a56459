#pragma once
/// Trajectory accuracy of an estimated pose list against ground truth: absolute trajectory error
/// (ATE) after a rigid alignment, and relative pose error (RPE) over a fixed frame delta.
#include <cstddef>
#include <span>

#include "core/pose.hpp"

namespace planecell::services::eval {

struct AteResult {
  std::size_t poses = 0;
  double rmse_m = 0.0;  ///< √(1/N Σ |A p_i − g_i|²) with A the best rigid alignment
  double mean_m = 0.0;
  double max_m = 0.0;
  Pose alignment = Pose::Identity();  ///< A: estimated frame → ground-truth frame
};

/// ATE: A = argmin over rigid transforms (no scale) Σ |A p_i − g_i|² of the estimated camera
/// positions p_i onto the ground-truth positions g_i (Umeyama, Eigen::umeyama), then the RMSE,
/// mean and max of the residual distances. With `align` false, A = I (both trajectories share the
/// first frame, as odometry started from the ground truth does). Throws InputError when the lists
/// differ in length or are empty (fewer than 3 poses: no alignment, A = I).
AteResult absolute_trajectory_error(std::span<const Pose> estimated, std::span<const Pose> ground_truth,
                                    bool align = true);

struct RpeResult {
  std::size_t pairs = 0;                ///< pairs (i, i + delta) with a ground-truth distance > 0
  double translation_rmse_m = 0.0;      ///< √(mean |t(E_ij)|²)
  double translation_percent = 0.0;     ///< 100 · Σ|t(E_ij)| / Σ d_ij
  double rotation_deg_per_m = 0.0;      ///< Σ angle(E_ij) (deg) / Σ d_ij
  double rotation_rmse_deg = 0.0;       ///< √(mean angle(E_ij)²): per pair, meaningful when the rig
                                        ///< barely moves (hovering, parked) and the rates blow up
};

/// RPE over frame pairs (i, j = i + frame_delta): E_ij = (G_i⁻¹ G_j)⁻¹ (P_i⁻¹ P_j), the error of the
/// estimated relative motion; d_ij = Σ_{k=i+1..j} |t(G_k) − t(G_{k−1})| the distance driven along
/// the ground truth. Pairs with d_ij = 0 are skipped. Throws InputError when the lists differ in
/// length or frame_delta is 0.
RpeResult relative_pose_error(std::span<const Pose> estimated, std::span<const Pose> ground_truth,
                              std::size_t frame_delta = 1);

}  // namespace planecell::services::eval
