#include "mapping/refine/pose_refinement.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "core/error.hpp"
#include "mapping/refine/correction_solver.hpp"
#include "mapping/refine/surface_association.hpp"
#include "mapping/refine/surface_planes.hpp"

namespace planecell::refine {

Eigen::Matrix<double, 6, 1> correction_between(const Pose& from, const Pose& to) {
  const Eigen::AngleAxisd rotation(to.linear() * from.linear().transpose());
  Vector6 out;
  out << rotation.angle() * rotation.axis(), to.translation() - from.translation();
  return out;
}

std::string to_string(RefineStatus status) {
  switch (status) {
    case RefineStatus::kDisabled: return "disabled";
    case RefineStatus::kTooFewAssociations: return "too_few_associations";
    case RefineStatus::kRefined: return "refined";
    case RefineStatus::kRejected: return "rejected";
  }
  return "unknown";
}

Pose apply_correction(const Pose& T_world_cam_input, const Vector6& correction) {
  const Eigen::Vector3d omega = correction.head<3>();
  const double angle = omega.norm();
  const Eigen::Matrix3d rotation =
      angle > 0.0 ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix()
                  : Eigen::Matrix3d::Identity();
  Pose out = Pose::Identity();
  out.linear() = rotation * T_world_cam_input.linear();
  out.translation() = T_world_cam_input.translation() + correction.tail<3>();
  return out;
}

void validate(const RefineConfig& c) {
  const auto fail = [](const std::string& field, const std::string& what) {
    throw ConfigError("refine." + field + ": " + what);
  };
  if (!(c.max_range_m > 0.0)) fail("max_range_m", "must be > 0");
  if (!(c.min_inlier_ratio >= 0.0 && c.min_inlier_ratio <= 1.0)) fail("min_inlier_ratio", "must be in [0, 1]");
  if (!(c.max_normal_angle_deg > 0.0 && c.max_normal_angle_deg < 90.0))
    fail("max_normal_angle_deg", "must be in (0, 90)");
  if (!(c.max_plane_distance_m > 0.0)) fail("max_plane_distance_m", "must be > 0");
  if (!(c.gate_sigmas > 0.0)) fail("gate_sigmas", "must be > 0");
  if (!(c.overlap_margin_m >= 0.0)) fail("overlap_margin_m", "must be >= 0");
  if (!(c.ambiguity_m > 0.0)) fail("ambiguity_m", "must be > 0");
  if (!(c.max_surface_sigma_m > 0.0)) fail("max_surface_sigma_m", "must be > 0");
  if (c.min_surface_cells < 1) fail("min_surface_cells", "must be >= 1");
  if (c.min_associations < 1) fail("min_associations", "must be >= 1");
  if (c.association_rounds < 1) fail("association_rounds", "must be >= 1");
  if (c.loss != "huber" && c.loss != "cauchy" && c.loss != "none")
    fail("loss", "'" + c.loss + "' is not one of huber, cauchy, none");
  if (!(c.plane_sigma_m > 0.0)) fail("plane_sigma_m", "must be > 0");
  if (!(c.depth_sigma_scale >= 0.0)) fail("depth_sigma_scale", "must be >= 0");
  if (!(c.min_noise_scale > 0.0 && c.min_noise_scale <= 1.0)) fail("min_noise_scale", "must be in (0, 1]");
  if (!(c.max_noise_scale >= 1.0)) fail("max_noise_scale", "must be >= 1");
  if (!(c.disparity_sigma_px >= 0.0)) fail("disparity_sigma_px", "must be >= 0");
  if (!(c.loss_scale > 0.0)) fail("loss_scale", "must be > 0");
  if (!(c.prior_sigma_m >= 0.0)) fail("prior_sigma_m", "must be >= 0 (0 = no prior)");
  if (!(c.prior_sigma_deg >= 0.0)) fail("prior_sigma_deg", "must be >= 0 (0 = no prior)");
  if (!(c.prior_sigma_m_per_m >= 0.0)) fail("prior_sigma_m_per_m", "must be >= 0");
  if (!(c.prior_sigma_deg_per_m >= 0.0)) fail("prior_sigma_deg_per_m", "must be >= 0");
  if (!(c.drift_gain >= 0.0 && c.drift_gain <= 1.0)) fail("drift_gain", "must be in [0, 1] (0 = off)");
  if (!(c.min_drift_step_m > 0.0)) fail("min_drift_step_m", "must be > 0");
  if (!(c.max_drift_per_m >= 0.0)) fail("max_drift_per_m", "must be >= 0");
  if (!(c.max_drift_deg_per_m >= 0.0)) fail("max_drift_deg_per_m", "must be >= 0");
  if (c.max_iterations < 1) fail("max_iterations", "must be >= 1");
  if (!(c.degeneracy_ratio > 0.0 && c.degeneracy_ratio < 1.0)) fail("degeneracy_ratio", "must be in (0, 1)");
  if (!(c.max_correction_m > 0.0)) fail("max_correction_m", "must be > 0");
  if (!(c.max_correction_deg > 0.0)) fail("max_correction_deg", "must be > 0");
}

Vector6 prior_sigma(const RefineConfig& config, double step_m) {
  const double step = std::isfinite(step_m) ? std::max(step_m, 0.0) : 0.0;
  const double sigma_t = config.prior_sigma_m + config.prior_sigma_m_per_m * step;
  const double sigma_r = (config.prior_sigma_deg + config.prior_sigma_deg_per_m * step) * kDegToRad;
  Vector6 out = Vector6::Zero();
  if (sigma_t > 0.0 && sigma_r > 0.0) out << Eigen::Vector3d::Constant(sigma_r), Eigen::Vector3d::Constant(sigma_t);
  return out;
}

PoseRefinement refine_pose(std::span<const Planecell> cells_cam, const Pose& T_world_cam_input,
                           const map::GlobalMap& map, const StereoCamera& camera,
                           const RefineConfig& config, double step_m) {
  validate(config);
  validate_pose(T_world_cam_input, "refine_pose: input pose");
  if (!(camera.fx > 0.0) || !(camera.baseline_m > 0.0))
    throw InputError("refine_pose: camera needs fx > 0 and baseline > 0");
  PoseRefinement out;
  out.refined = T_world_cam_input;
  if (!config.enabled) return out;

  // The surface planes around the frame, once: the map does not change while refining.
  const SurfacePlanes surfaces = surface_planes_near(
      map, association_region(cells_cam, T_world_cam_input, config, config.max_correction_m), config);
  CorrectionPrior prior;
  prior.sigma = prior_sigma(config, step_m);
  Pose current = T_world_cam_input;
  bool any = false;
  for (int round = 0; round < config.association_rounds; ++round) {
    const std::vector<SurfaceAssociation> associations =
        associate_cells(cells_cam, current, map, surfaces, camera, config);
    if (associations.size() < static_cast<std::size_t>(config.min_associations)) {
      if (!any) out.associations = associations.size();
      break;
    }
    prior.offset = correction_between(T_world_cam_input, current);
    const CorrectionSolution solution = solve_correction(associations, current, prior, config);
    if (round == 0) out.initial_cost = solution.initial_cost;
    out.iterations += solution.iterations;
    if (any && !solution.usable) break;  // keep the statistics of the last solved round
    out.associations = associations.size();
    out.residuals = associations.size();
    out.final_cost = solution.final_cost;
    out.information_eigenvalues = solution.eigenvalues;
    out.information = solution.information;
    out.observable_directions = solution.observable;
    if (!solution.usable) break;
    current = apply_correction(current, solution.delta);
    any = true;
  }
  if (!any) {
    out.status = out.associations < static_cast<std::size_t>(config.min_associations)
                     ? RefineStatus::kTooFewAssociations
                     : RefineStatus::kRejected;
    return out;
  }
  out.correction = correction_between(T_world_cam_input, current);
  if (out.correction.tail<3>().norm() > config.max_correction_m ||
      out.correction.head<3>().norm() > config.max_correction_deg * kDegToRad) {
    out.status = RefineStatus::kRejected;
    return out;
  }
  out.refined = current;
  out.status = RefineStatus::kRefined;
  return out;
}

}  // namespace planecell::refine
