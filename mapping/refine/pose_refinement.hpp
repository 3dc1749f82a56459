#pragma once
/// SLAM-style pose refinement: a frame's camera-frame planecells are aligned to the surfaces
/// already in the global map, correcting a noisy (odometry) pose before the frame is merged.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "core/config/refine_config.hpp"
#include "core/planecell.hpp"
#include "core/pose.hpp"
#include "core/stereo_camera.hpp"
#include "mapping/map/global_map.hpp"

namespace planecell::refine {

enum class RefineStatus : std::uint8_t {
  kDisabled,           ///< refinement off: the input pose is returned
  kTooFewAssociations, ///< fewer than min_associations cells matched the map (e.g. first frame)
  kRefined,            ///< correction applied (possibly only along the observable directions)
  kRejected,           ///< solver failed or correction beyond max_correction_*: input kept
};
std::string to_string(RefineStatus status);

/// The correction model. With c the camera centre of the input pose T_in = [R_in | t_in] and
/// δ = (ω, τ) (ω: rotation vector in world axes, rad; τ: world translation, m), the refined pose is
///   T = [R(ω)·R_in | t_in + τ],   i.e.   X_w' = R(ω)(X_w − c) + c + τ   for X_w = T_in X_c,
/// a rotation about the camera centre followed by a translation, so ω and τ do not trade off
/// through the lever arm to the world origin.
Pose apply_correction(const Pose& T_world_cam_input, const Eigen::Matrix<double, 6, 1>& correction);
/// The correction (ω, τ) taking `from` to `to` under apply_correction: R(ω) = R_to R_fromᵀ,
/// τ = t_to − t_from (|ω| the rotation angle, rad; |τ| the camera displacement, m).
Eigen::Matrix<double, 6, 1> correction_between(const Pose& from, const Pose& to);

struct PoseRefinement {
  Pose refined = Pose::Identity();  ///< T_world_cam after refinement (= input unless kRefined)
  Eigen::Matrix<double, 6, 1> correction = Eigen::Matrix<double, 6, 1>::Zero();  ///< (ω rad, τ m)
  std::size_t associations = 0;     ///< frame cells paired with a map surface (last round)
  std::size_t residuals = 0;        ///< point-to-plane residuals in the last solve (one per association)
  int iterations = 0;               ///< Ceres iterations, all rounds
  double initial_cost = 0.0;        ///< Ceres cost ½Σρ of the first round at δ = 0
  double final_cost = 0.0;          ///< Ceres cost at the solution of the last round
  /// Eigenvalues (ascending) of the map's information matrix (whitened residuals) in the scaled
  /// coordinates (ω·L, τ), L = RMS distance of the residual points from the camera centre (1/m²).
  Eigen::Matrix<double, 6, 1> information_eigenvalues = Eigen::Matrix<double, 6, 1>::Zero();
  /// The map's information about (ω, τ) (world axes; 1/rad², 1/m²) at the solution of the last
  /// round: Σ_k ρ'(r_k²) J_kᵀ J_k of the whitened residuals (see solve_correction); its inverse is
  /// the covariance of the map-only estimate along the observable directions.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  int observable_directions = 0;    ///< eigenvalues ≥ degeneracy_ratio × the largest
  RefineStatus status = RefineStatus::kDisabled;
};

/// Throws ConfigError naming the field when a RefineConfig value is out of range.
void validate(const RefineConfig& config);

/// σ of the odometry prediction after driving `step_m` metres (world axes, rad ×3 then m ×3):
///   σ_τ = prior_sigma_m + prior_sigma_m_per_m · step_m,  σ_ω = prior_sigma_deg + prior_sigma_deg_per_m · step_m.
/// Zero (no prior) when either σ is 0.
Eigen::Matrix<double, 6, 1> prior_sigma(const RefineConfig& config, double step_m);

/// Refines T_world_cam_input of a frame whose planecells are `cells_cam` (camera frame, as from
/// extraction) against `map`; `step_m` is the distance driven since the previous refined frame
/// (it widens the odometry prior, see prior_sigma).
///
/// Rounds (association_rounds): associate the cells with the map surfaces at the current pose
/// (associate_cells: centroid-to-surface pairs with σ_k), solve the correction (solve_correction:
/// robust whitened point-to-plane residuals on SO(3) × R³ plus the prior around the input pose,
/// unobservable directions projected out), apply it. A total correction beyond
/// max_correction_m / max_correction_deg is rejected (input kept).
/// Throws ConfigError on an invalid config, InputError on an invalid input pose or camera.
PoseRefinement refine_pose(std::span<const Planecell> cells_cam, const Pose& T_world_cam_input,
                           const map::GlobalMap& map, const StereoCamera& camera,
                           const RefineConfig& config, double step_m = 0.0);

}  // namespace planecell::refine
