#pragma once
/// Configuration of the SLAM-style pose refinement (mapping/refine): each frame's planecells are
/// aligned to the surfaces already in the global map before they are merged.

#include <string>

namespace planecell {

/// Pose refinement of noisy odometry against the global map (issue 9).
/// Association: a frame cell (moved to the world with the predicted pose) is paired with the map
/// surface that passes every gate (normal angle, RMS vertex distance to the surface plane, in-plane
/// overlap with the surface's nearby member cells) and has the smallest RMS distance.
/// Solve: Ceres, robust loss on point-to-plane distances (m), weight area_px · inlier_ratio over the
/// vertex's variance (plane noise plus stereo depth noise).
/// Degeneracy: directions of the 6×6 information matrix (rotation scaled by the points' RMS lever
/// arm, so both blocks are in m²) whose eigenvalue is below degeneracy_ratio × the largest are
/// unobservable; the correction is projected onto the observable ones.
struct RefineConfig {
  bool enabled = false;  ///< off: poses are used as given (as in the paper)
  double max_range_m = 30.0;  ///< cells whose vertex centroid is farther from the camera are not used
                              ///< (stereo depth error grows with Z², their planes are unreliable)
  // --- association ----------------------------------------------------------------------------
  double max_normal_angle_deg = 8.0;    ///< max angle between cell and surface normals
  double max_plane_distance_m = 0.3;    ///< max RMS distance of the cell's vertices to the surface plane
  double min_overlap = 0.5;             ///< min share of the cell's samples (vertices + centroid)
                                        ///< lying, projected onto a nearby member cell's plane,
                                        ///< inside that cell's bounds grown by overlap_margin_m
  double overlap_margin_m = 0.3;        ///< in-plane slack of the overlap test (m)
  int min_associations = 3;             ///< fewer associated cells: the pose is kept as given
  int association_rounds = 2;           ///< associate → solve rounds (later rounds use the refined pose)
  // --- noise model ----------------------------------------------------------------------------
  double plane_sigma_m = 0.02;          ///< σ₀: point-to-plane noise of a near cell (m)
  double disparity_sigma_px = 0.3;      ///< σ_d: disparity noise; a vertex at depth Z on a plane at
                                        ///< distance |e| from the camera has σ_r = |e|·Z·σ_d/(fx·B)
  // --- odometry prior (0 = none) ---------------------------------------------------------------
  double prior_sigma_m = 0.0;           ///< σ of the predicted pose's translation per frame (m)
  double prior_sigma_deg = 0.0;         ///< σ of the predicted pose's rotation per frame (deg)
  // --- solver ---------------------------------------------------------------------------------
  std::string loss = "huber";           ///< "huber", "cauchy" or "none" (robust loss on distances)
  double loss_scale_m = 0.05;           ///< robust loss scale: distances beyond it are down-weighted
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
  visit("max_normal_angle_deg", c.max_normal_angle_deg);
  visit("max_plane_distance_m", c.max_plane_distance_m);
  visit("min_overlap", c.min_overlap);
  visit("overlap_margin_m", c.overlap_margin_m);
  visit("min_associations", c.min_associations);
  visit("association_rounds", c.association_rounds);
  visit("plane_sigma_m", c.plane_sigma_m);
  visit("disparity_sigma_px", c.disparity_sigma_px);
  visit("prior_sigma_m", c.prior_sigma_m);
  visit("prior_sigma_deg", c.prior_sigma_deg);
  visit("loss", c.loss);
  visit("loss_scale_m", c.loss_scale_m);
  visit("max_iterations", c.max_iterations);
  visit("degeneracy_ratio", c.degeneracy_ratio);
  visit("max_correction_m", c.max_correction_m);
  visit("max_correction_deg", c.max_correction_deg);
}

}  // namespace planecell
