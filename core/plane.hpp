#pragma once
/// Disparity planes and their exact 3D planes.
#include <Eigen/Core>

#include "core/stereo_camera.hpp"

namespace planecell {

/// A plane in disparity space: d(u, v) = a·u + b·v + c (px).
struct DisparityPlane {
  double a = 0.0;
  double b = 0.0;
  double c = 0.0;
  double at(double u_px, double v_px) const { return a * u_px + b * v_px + c; }
};

/// A 3D plane n·X + offset = 0 with unit normal n.
struct Plane3 {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double offset = 0.0;
  /// Signed distance of a point to the plane (m).
  double signed_distance(const Eigen::Vector3d& point) const { return normal.dot(point) + offset; }
};

/// Exact 3D plane (left camera frame) of a disparity plane under the pinhole stereo model.
/// Substituting u = fx X/Z + cx, v = fy Y/Z + cy, d = fx B/Z into d = a u + b v + c gives
///   a·fx·X + b·fy·Y + (a·cx + b·cy + c)·Z − fx·B = 0,
/// normalised to a unit normal. Every pixel of the disparity plane back-projects onto it.
Plane3 plane_from_disparity(const DisparityPlane& plane, const StereoCamera& camera);

/// Inverse of plane_from_disparity: the disparity plane of a 3D plane n·X + e = 0 (camera frame).
/// Requires e ≠ 0 (a plane through the optical centre is seen edge-on and has no disparity plane):
///   a = −B·n_x/e,  b = −fx·B·n_y/(fy·e),  c = −fx·B·n_z/e − a·cx − b·cy.
/// Throws InputError when |e| is (numerically) zero.
DisparityPlane disparity_from_plane(const Plane3& plane, const StereoCamera& camera);

/// 1-σ angle (rad) of the 3D normal of a least-squares disparity plane, from the covariance
/// cov_ab of its slopes (a, b): for a fit on n pixels with residual variance s² and centred image
/// scatter C = Σ (p − p̄)(p − p̄)ᵀ, cov_ab = s²·C⁻¹, and c moves with them so that the disparity
/// at the pixels' centroid p̄ stays (its own error, s²/n, shifts the plane but hardly turns it).
/// Along each principal axis e_k of cov_ab (variance λ_k) the slopes move by √λ_k·e_k; the angle
/// α_k between plane_from_disparity of the moved and the fitted plane adds in quadrature:
///   σ_θ = √(α_1² + α_2²).
/// A wide, near cell turns little; a small or far one (little disparity across it) turns a lot.
double normal_sigma_rad(const DisparityPlane& plane, const Eigen::Matrix2d& cov_ab,
                        const Eigen::Vector2d& centroid_px, const StereoCamera& camera);

/// Fits n·X + e = 0 to points by least squares (smallest eigenvector of the scatter matrix).
Plane3 fit_plane(const Eigen::Ref<const Eigen::Matrix3Xd>& points);

}  // namespace planecell
