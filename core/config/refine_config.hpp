#pragma once
/// Configuration of the SLAM-style pose refinement (mapping/refine): each frame's planecells are
/// aligned to the surfaces already in the global map before they are merged.

#include <string>

namespace planecell {

/// Pose refinement of noisy odometry against the global map (issue 9).
/// Association (refine/surface_association): a frame cell's vertex centroid, placed with the
/// predicted pose, is paired with the map surface whose member cell contains it in-plane and whose
/// plane is within the gates (normal angle, distance in σ); ambiguous cells are left out.
/// Solve (refine/correction_solver): Ceres on SO(3) × R³, robust loss on whitened centroid-to-
/// surface distances, a Gaussian prior around the odometry prediction. Directions of the 6×6
/// information matrix (rotation scaled by the points' RMS lever arm) whose eigenvalue is below
/// degeneracy_ratio × the largest are unobservable and keep the prediction.
struct RefineConfig {
  bool enabled = false;  ///< off: poses are used as given (as in the paper)
  double max_range_m = 30.0;  ///< cells whose vertex centroid is farther from the camera are not used
                              ///< (stereo depth error grows with Z², their planes are unreliable)
  double min_inlier_ratio = 0.5;        ///< cells with a worse plane fit are not used
  // --- association ----------------------------------------------------------------------------
  double max_normal_angle_deg = 8.0;    ///< max angle between cell and surface normals
  double max_plane_distance_m = 0.3;    ///< max |distance| of the cell centroid to the surface plane
  double gate_sigmas = 4.0;             ///< ... and at most this many σ (centroid σ, ≥ plane_sigma_m)
  double overlap_margin_m = 0.3;        ///< in-plane slack: the centroid, projected onto a member
                                        ///< cell's plane, lies inside its polygon or this close (m)
  double ambiguity_m = 0.1;             ///< another contained surface predicting a distance this much
                                        ///< different makes the cell ambiguous (left out)
  double max_surface_sigma_m = 0.05;    ///< surfaces whose plane is less certain than this at the
                                        ///< cell (offset and tilt from their stored cells) are not used
  int min_surface_cells = 1;            ///< surfaces with fewer stored cells are not associated
  int min_associations = 3;             ///< fewer associated cells: the pose is kept as given
  int association_rounds = 2;           ///< associate → solve rounds (later rounds use the refined pose)
  // --- noise model ----------------------------------------------------------------------------
  double plane_sigma_m = 0.02;          ///< σ₀: centroid-to-surface noise floor (m)
  double depth_sigma_scale = 1.0;       ///< s: the cell's σ_Z (Planecell::depth_sigma_m) is scaled by
                                        ///< this (it overestimates the true plane error)
  double disparity_sigma_px = 0.3;      ///< σ_d for cells without depth_sigma_m: σ_Z = Z²σ_d/(f_x·B)
  bool estimate_noise_scale = true;     ///< rescale every σ by the residuals' robust (MAD) scale
  double min_noise_scale = 0.25;        ///< ... clamped to [min, max]
  double max_noise_scale = 4.0;
  // --- odometry prior (0 = none) ---------------------------------------------------------------
  /// σ of the prediction (previous refined pose × odometry increment) per frame: a floor plus a
  /// rate per metre driven in that increment.
  double prior_sigma_m = 0.0;           ///< translation floor (m)
  double prior_sigma_deg = 0.0;         ///< rotation floor (deg)
  double prior_sigma_m_per_m = 0.0;     ///< translation per metre driven (m/m)
  double prior_sigma_deg_per_m = 0.0;   ///< rotation per metre driven (deg/m)
  // --- odometry drift estimate (0 = off) -------------------------------------------------------
  /// Odometry errs with a persistent bias (wheel scale, yaw bias): each step's error, in the
  /// step's camera frame and per metre driven, is estimated as b (rad/m ×3, m/m ×3) and removed
  /// from the next predictions: Δ' = Δ·exp(b·s) for an increment Δ of length s. After each refined
  /// frame, b ← clamp(b + drift_gain · ε / s), ε the correction in the predicted camera frame:
  /// an integral term that drives the mean correction to zero (only observable directions are
  /// corrected, so b learns only what the map measures). Steps shorter than min_drift_step_m do
  /// not update b (a standing rig has no per-metre rate).
  double drift_gain = 0.0;
  double min_drift_step_m = 0.2;
  double max_drift_per_m = 0.05;        ///< |τ_b| ≤ this (m/m) ...
  double max_drift_deg_per_m = 0.5;     ///< ... and |ω_b| ≤ this (deg/m)
  // --- solver ---------------------------------------------------------------------------------
  std::string loss = "huber";           ///< "huber", "cauchy" or "none" (robust loss on distances)
  double loss_scale = 2.0;              ///< robust loss scale in σ (residuals are whitened)
  int max_iterations = 20;              ///< Ceres iterations per round
  double degeneracy_ratio = 1e-4;       ///< relative eigenvalue below which a direction is unobservable
  // --- sanity ---------------------------------------------------------------------------------
  double max_correction_m = 1.0;        ///< larger translation corrections are rejected (pose kept)
  double max_correction_deg = 3.0;      ///< larger rotation corrections are rejected (pose kept)
};

template <class Visitor>
void visit_fields(RefineConfig& c, Visitor&& visit) {
  visit("enabled", c.enabled);
  visit("max_range_m", c.max_range_m);
  visit("min_inlier_ratio", c.min_inlier_ratio);
  visit("max_normal_angle_deg", c.max_normal_angle_deg);
  visit("max_plane_distance_m", c.max_plane_distance_m);
  visit("gate_sigmas", c.gate_sigmas);
  visit("overlap_margin_m", c.overlap_margin_m);
  visit("ambiguity_m", c.ambiguity_m);
  visit("max_surface_sigma_m", c.max_surface_sigma_m);
  visit("min_surface_cells", c.min_surface_cells);
  visit("min_associations", c.min_associations);
  visit("association_rounds", c.association_rounds);
  visit("plane_sigma_m", c.plane_sigma_m);
  visit("depth_sigma_scale", c.depth_sigma_scale);
  visit("disparity_sigma_px", c.disparity_sigma_px);
  visit("estimate_noise_scale", c.estimate_noise_scale);
  visit("min_noise_scale", c.min_noise_scale);
  visit("max_noise_scale", c.max_noise_scale);
  visit("prior_sigma_m", c.prior_sigma_m);
  visit("prior_sigma_deg", c.prior_sigma_deg);
  visit("prior_sigma_m_per_m", c.prior_sigma_m_per_m);
  visit("prior_sigma_deg_per_m", c.prior_sigma_deg_per_m);
  visit("drift_gain", c.drift_gain);
  visit("min_drift_step_m", c.min_drift_step_m);
  visit("max_drift_per_m", c.max_drift_per_m);
  visit("max_drift_deg_per_m", c.max_drift_deg_per_m);
  visit("loss", c.loss);
  visit("loss_scale", c.loss_scale);
  visit("max_iterations", c.max_iterations);
  visit("degeneracy_ratio", c.degeneracy_ratio);
  visit("max_correction_m", c.max_correction_m);
  visit("max_correction_deg", c.max_correction_deg);
}

}  // namespace planecell

