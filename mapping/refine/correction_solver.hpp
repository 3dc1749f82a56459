#pragma once
/// The least-squares step of pose refinement: the rigid correction that puts a frame's associated
/// cell centroids onto their map surfaces, with a prior keeping it near the odometry prediction.
#include <Eigen/Core>
#include <span>

#include "core/config/refine_config.hpp"
#include "core/pose.hpp"
#include "mapping/refine/surface_association.hpp"

namespace planecell::refine {

using Vector6 = Eigen::Matrix<double, 6, 1>;
using Matrix6 = Eigen::Matrix<double, 6, 6>;

/// Gaussian prior on the correction δ = (ω, τ): residual (δ_total − 0)/σ per axis, where
/// δ_total = δ + offset is the correction relative to the prediction (offset: what earlier
/// association rounds already applied). sigma ≤ 0 on every axis = no prior.
struct CorrectionPrior {
  Vector6 sigma = Vector6::Zero();   ///< (rad ×3, m ×3), world axes
  Vector6 offset = Vector6::Zero();  ///< (rad ×3, m ×3)
  bool enabled() const { return (sigma.array() > 0.0).all(); }
};

struct CorrectionSolution {
  Vector6 delta = Vector6::Zero();  ///< (ω rad, τ m) to apply with apply_correction
  /// Σ_k ρ'(r_k²) J_kᵀ J_k of the map residuals at the solution, (ω, τ) coordinates, whitened
  /// (units 1/rad², 1/m²): J_k = [ (R q_k) × n_s , n_s ] / σ_k.
  Matrix6 information = Matrix6::Zero();
  /// Eigenvalues (ascending) of the information in the scaled coordinates (ω·L, τ), L the RMS
  /// distance of the observed points from the camera centre.
  Vector6 eigenvalues = Vector6::Zero();
  int observable = 0;               ///< eigenvalues ≥ degeneracy_ratio × the largest
  double noise_scale = 1.0;         ///< s applied to every σ_k (estimate_noise_scale), else 1
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  bool usable = false;              ///< Ceres converged to a usable solution with ≥ 1 observable direction
};

/// Minimises over the rotation R_c (unit quaternion on ceres::EigenQuaternionManifold) and the
/// translation τ (Euclidean) — together SE(3) as SO(3) × R³, a rotation about the camera centre c
/// followed by a translation (see apply_correction) —
///   Σ_k ρ( r_k² ) + |prior residual|²,   r_k = (n_k·(R_c q_k + c + τ) + e_k) / σ_k,
/// q_k = T c_k − c the associated centroid relative to the camera centre with the linearisation
/// pose T, ρ the robust loss (huber / cauchy / none) with scale loss_scale (in σ units, residuals
/// are whitened). Prior residual: ((log R_c + ω₀)/σ_ω, (τ + τ₀)/σ_τ), log the rotation vector.
/// Noise scale (estimate_noise_scale, ≥ 10 associations): after a first solve, s = 1.4826 ·
/// median_k |r_k| (the MAD scale of the whitened residuals, 1 when the σ_k are right), clamped to
/// [min_noise_scale, max_noise_scale]; every σ_k is multiplied by s and the problem solved again
/// from there. The σ model's shape (depth noise along the ray, plane uncertainty) is kept, its
/// level is measured on the frame, so the balance with the odometry prior follows the data.
/// Degeneracy: the solution is projected onto the eigenvectors of the scaled information whose
/// eigenvalue is ≥ degeneracy_ratio × the largest; along the others the prediction is kept.
CorrectionSolution solve_correction(std::span<const SurfaceAssociation> associations,
                                    const Pose& T_world_cam, const CorrectionPrior& prior,
                                    const RefineConfig& config);

}  // namespace planecell::refine
