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

struct PoseRefinement {
  Pose refined = Pose::Identity();  ///< T_world_cam after refinement (= input unless kRefined)
  Eigen::Matrix<double, 6, 1> correction = Eigen::Matrix<double, 6, 1>::Zero();  ///< (ω rad, τ m)
  std::size_t associations = 0;     ///< frame cells paired with a map surface (last round)
  std::size_t residuals = 0;        ///< point-to-plane residuals in the last solve
  int iterations = 0;               ///< Ceres iterations, all rounds
  double initial_cost = 0.0;        ///< Ceres cost ½Σρ of the first round at δ = 0
  double final_cost = 0.0;          ///< Ceres cost at the solution of the last round
  /// Eigenvalues (ascending) of the information matrix JᵀJ in the scaled coordinates
  /// (ω·L, τ), L = RMS distance of the residual points from the camera centre (m²·weight).
  Eigen::Matrix<double, 6, 1> information_eigenvalues = Eigen::Matrix<double, 6, 1>::Zero();
  int observable_directions = 0;    ///< eigenvalues ≥ degeneracy_ratio × the largest
  RefineStatus status = RefineStatus::kDisabled;
};

/// Throws ConfigError naming the field when a RefineConfig value is out of range.
void validate(const RefineConfig& config);

/// Refines T_world_cam_input of a frame whose planecells are `cells_cam` (camera frame, as from
/// extraction; planeless cells, cells without area or inlier_ratio, and cells whose vertex centroid
/// is beyond max_range_m from the camera are ignored) against `map`.
///
/// Association (per cell, with the current pose estimate): X_k = T X_k^cam for its vertices,
/// candidate surfaces are those of the map cells returned by cells_near(bounds inflated by
/// max_plane_distance_m + overlap_margin_m); a surface S = (n_s, e_s) passes when
///   angle(n_w, ±n_s) ≤ max_normal_angle_deg,  RMS_k (n_s·X_k + e_s) ≤ max_plane_distance_m,
///   overlap = share of samples {X_k, centroid} whose projection onto a nearby member cell's plane
///   lies within overlap_margin_m of that cell's polygon ≥ min_overlap;
/// the passing surface with the smallest RMS distance is chosen. ("Near its polygon" is tested
/// as: inside the member cell's vertex bounds grown by overlap_margin_m.)
///
/// Solve: minimise over δ = (ω, τ)   Σ_cells Σ_k w_k ρ( (n_s·X_k'(δ) + e_s)² )  with
///   X_k'(δ) = R(ω)(X_k − c) + c + τ,
///   w_k = (area_px · inlier_ratio / K) / (σ₀² + σ_r,k²)   (K vertices of the cell),
///   σ_r,k = |e_c| · Z_k · σ_d / (fx · B): a depth error σ_Z = Z²σ_d/(fx·B) moves the vertex along
///   its ray, which changes its distance to its plane n_c·X + e_c = 0 by |n_c·X_k|·σ_Z/Z = |e_c|·σ_Z/Z;
/// ρ Huber or Cauchy with scale loss_scale_m (Ceres, automatic derivatives, dense QR).
/// Rounds: association is redone with the refined pose association_rounds times.
///
/// Degeneracy: J (rows √w_c ∂r/∂δ at the solution, robust weights included) scaled to
/// (ω·L, τ); H = JᵀJ = V Λ Vᵀ. Directions with λ_i < degeneracy_ratio·λ_max are unobservable
/// (e.g. only the road visible: translation along the road and yaw); the scaled correction is
/// projected onto the observable eigenvectors, δ ← S⁻¹ V_o V_oᵀ S δ, so the input odometry is kept
/// along the rest. A correction beyond max_correction_m / max_correction_deg is rejected.
/// Throws ConfigError on an invalid config, InputError on an invalid input pose.
PoseRefinement refine_pose(std::span<const Planecell> cells_cam, const Pose& T_world_cam_input,
                           const map::GlobalMap& map, const StereoCamera& camera,
                           const RefineConfig& config);

}  // namespace planecell::refine
