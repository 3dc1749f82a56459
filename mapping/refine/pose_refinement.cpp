#include "mapping/refine/pose_refinement.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <vector>

#include "core/error.hpp"
#include "mapping/map/geometry.hpp"

namespace planecell::refine {
namespace {

using Vector6 = Eigen::Matrix<double, 6, 1>;

constexpr double kDegToRad = std::numbers::pi / 180.0;

/// One point-to-plane residual: a cell vertex relative to the camera centre, q = X_w − c, and the
/// associated surface plane n_s·X + e_s = 0 (world).
struct PlaneSample {
  Eigen::Vector3d q;
  Eigen::Vector3d normal;
  double offset = 0.0;
  double weight = 0.0;
};

/// r(δ) = n_s·(R(ω) q + c + τ) + e_s, δ = (ω, τ) (angle-axis rotation vector, translation).
struct PointToPlaneCost {
  PointToPlaneCost(const PlaneSample& s, const Eigen::Vector3d& centre)
      : q(s.q), n(s.normal), e(s.offset + s.normal.dot(centre)) {}

  template <class T>
  bool operator()(const T* delta, T* residual) const {
    const T p[3] = {T(q.x()), T(q.y()), T(q.z())};
    T rotated[3];
    ceres::AngleAxisRotatePoint(delta, p, rotated);
    residual[0] = T(n.x()) * (rotated[0] + delta[3]) + T(n.y()) * (rotated[1] + delta[4]) +
                  T(n.z()) * (rotated[2] + delta[5]) + T(e);
    return true;
  }

  Eigen::Vector3d q, n;
  double e;  ///< e_s + n_s·c: the plane offset seen from the camera centre
};

/// Odometry prior r_i = (δ_i + δ₀_i) / σ_i (δ₀: correction of earlier rounds).
struct PriorCost {
  Vector6 sigma, offset;
  template <class T>
  bool operator()(const T* delta, T* residual) const {
    for (int i = 0; i < 6; ++i) residual[i] = (delta[i] + T(offset[i])) / T(sigma[i]);
    return true;
  }
};

ceres::LossFunction* make_loss(const RefineConfig& config, double weight) {
  ceres::LossFunction* robust = nullptr;
  // Ceres losses take s = r²; their scale a is in the units of r (m).
  if (config.loss == "huber") robust = new ceres::HuberLoss(config.loss_scale_m);
  else if (config.loss == "cauchy") robust = new ceres::CauchyLoss(config.loss_scale_m);
  return new ceres::ScaledLoss(robust, weight, ceres::TAKE_OWNERSHIP);
}

/// The association of one frame cell: its world-frame vertices (with the current pose) and the
/// chosen surface plane. Returns false when no surface passes the gates.
bool associate_cell(const std::vector<Eigen::Vector3d>& world, const Eigen::Vector3d& normal_w,
                    const map::GlobalMap& map, const RefineConfig& config, Plane3& surface_plane) {
  map::Aabb box;
  for (const auto& x : world) box.extend(x);
  const std::vector<std::uint32_t> near =
      map.cells_near(box.inflated(config.max_plane_distance_m + config.overlap_margin_m));
  if (near.empty()) return false;

  // Candidate surfaces with their nearby member cells.
  std::map<std::uint32_t, std::vector<const Planecell*>> by_surface;
  for (const std::uint32_t id : near) {
    const Planecell* cell = map.cell(id);
    if (cell == nullptr || cell->surface == kNoSurface || cell->vertices_m.size() < 3) continue;
    by_surface[cell->surface].push_back(cell);
  }

  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& x : world) centroid += x;
  centroid /= static_cast<double>(world.size());
  const double cos_max = std::cos(config.max_normal_angle_deg * kDegToRad);
  const auto samples = static_cast<double>(world.size() + 1);

  double best_rms = std::numeric_limits<double>::infinity();
  std::vector<map::Aabb> member_bounds;
  for (const auto& [surface_id, members] : by_surface) {
    const map::Surface* surface = map.surface(surface_id);
    if (surface == nullptr) continue;
    if (std::abs(surface->plane.normal.dot(normal_w)) < cos_max) continue;
    double sum_sq = 0.0;
    for (const auto& x : world) {
      const double d = surface->plane.signed_distance(x);
      sum_sq += d * d;
    }
    const double rms = std::sqrt(sum_sq / static_cast<double>(world.size()));
    if (rms > config.max_plane_distance_m || rms >= best_rms) continue;

    // Overlap: samples whose projection onto a member cell's plane lies in its grown bounds.
    member_bounds.clear();
    for (const Planecell* m : members)
      member_bounds.push_back(map::bounds_of(m->vertices_m).inflated(config.overlap_margin_m));
    const auto inside = [&](const Eigen::Vector3d& x) {
      for (std::size_t i = 0; i < members.size(); ++i) {
        const Plane3& plane = members[i]->plane;
        const Eigen::Vector3d p = x - plane.signed_distance(x) * plane.normal;
        const map::Aabb& b = member_bounds[i];
        if ((p.array() >= b.min.array()).all() && (p.array() <= b.max.array()).all()) return true;
      }
      return false;
    };
    int hits = inside(centroid) ? 1 : 0;
    for (const auto& x : world) hits += inside(x) ? 1 : 0;
    if (hits / samples < config.min_overlap) continue;
    best_rms = rms;
    surface_plane = surface->plane;
  }
  return std::isfinite(best_rms);
}

struct RoundResult {
  Vector6 delta = Vector6::Zero();
  std::size_t associations = 0;
  std::size_t residuals = 0;
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  Vector6 eigenvalues = Vector6::Zero();
  int observable = 0;
  bool solved = false;
};

/// One associate → solve → project round around `pose`.
RoundResult refine_round(std::span<const Planecell> cells_cam, const Pose& pose,
                         const map::GlobalMap& map, const StereoCamera& camera,
                         const RefineConfig& config, const Vector6& prior_offset) {
  RoundResult result;
  const Eigen::Vector3d centre = pose.translation();
  std::vector<PlaneSample> samples;
  std::vector<Eigen::Vector3d> world;
  for (const Planecell& cell : cells_cam) {
    if (!cell.has_plane || cell.vertices_m.size() < 3) continue;
    const double quality = std::clamp(static_cast<double>(cell.inlier_ratio), 0.0, 1.0);
    if (!(quality > 0.0) || cell.area_px == 0) continue;
    if (map::vertex_centroid(cell.vertices_m).norm() > config.max_range_m) continue;
    world.clear();
    for (const auto& v : cell.vertices_m) world.push_back(pose * v.cast<double>());
    Plane3 plane;
    if (!associate_cell(world, pose.linear() * cell.plane.normal, map, config, plane)) continue;
    ++result.associations;
    // w_k = (area_px · q / K) / (σ₀² + σ_r²),  σ_r = |e_c| · Z_k · σ_d / (fx · B).
    const double cell_weight = cell.area_px * quality / static_cast<double>(world.size());
    const double ray_factor = std::abs(cell.plane.offset) * config.disparity_sigma_px /
                              (camera.fx * camera.baseline_m);
    for (std::size_t k = 0; k < world.size(); ++k) {
      const double sigma_r = ray_factor * std::abs(static_cast<double>(cell.vertices_m[k].z()));
      const double weight = cell_weight / (config.plane_sigma_m * config.plane_sigma_m + sigma_r * sigma_r);
      samples.push_back({world[k] - centre, plane.normal, plane.offset, weight});
    }
  }
  if (result.associations < static_cast<std::size_t>(config.min_associations)) return result;

  // Absolute scale: the weights are normalised so that Σ_k w_k σ₀² = number of associated cells
  // (each cell one plane observation with noise σ₀), which makes them commensurate with the prior.
  double weight_sum = 0.0;
  for (const PlaneSample& s : samples) weight_sum += s.weight;
  const double normalise = static_cast<double>(result.associations) /
                           (weight_sum * config.plane_sigma_m * config.plane_sigma_m);
  for (PlaneSample& s : samples) s.weight *= normalise;

  double delta[6] = {0, 0, 0, 0, 0, 0};
  ceres::Problem problem;
  std::vector<ceres::ResidualBlockId> measurement_blocks;
  if (config.prior_sigma_m > 0.0 && config.prior_sigma_deg > 0.0) {
    // Odometry prior: r = δ_i / σ_i, around δ₀ (the correction already applied in earlier rounds).
    Vector6 sigma;
    sigma << Vector6::Constant(config.prior_sigma_deg * kDegToRad).head<3>(),
        Vector6::Constant(config.prior_sigma_m).tail<3>();
    auto* prior = new ceres::AutoDiffCostFunction<PriorCost, 6, 6>(new PriorCost{sigma, prior_offset});
    problem.AddResidualBlock(prior, nullptr, delta);
  }
  for (const PlaneSample& s : samples) {
    auto* cost = new ceres::AutoDiffCostFunction<PointToPlaneCost, 1, 6>(new PointToPlaneCost(s, centre));
    measurement_blocks.push_back(problem.AddResidualBlock(cost, make_loss(config, s.weight), delta));
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = config.max_iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  result.residuals = samples.size();
  result.iterations = static_cast<int>(summary.iterations.size());
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  if (!summary.IsSolutionUsable()) return result;

  // Information matrix of the map residuals at the solution (robust weights included), in scaled coordinates
  // s = (L ω, τ): H_s = D JᵀJ D, D = diag(1/L, 1/L, 1/L, 1, 1, 1).
  ceres::Problem::EvaluateOptions evaluate;
  evaluate.apply_loss_function = true;
  evaluate.residual_blocks = measurement_blocks;  // the map's information only, not the prior
  ceres::CRSMatrix jacobian;
  problem.Evaluate(evaluate, nullptr, nullptr, nullptr, &jacobian);
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  for (int row = 0; row < jacobian.num_rows; ++row) {
    Vector6 j = Vector6::Zero();
    for (int k = jacobian.rows[row]; k < jacobian.rows[row + 1]; ++k)
      j[jacobian.cols[k]] = jacobian.values[k];
    information += j * j.transpose();
  }
  double sum_sq = 0.0;
  for (const PlaneSample& s : samples) sum_sq += s.q.squaredNorm();
  const double lever_m = std::max(std::sqrt(sum_sq / static_cast<double>(samples.size())), 1e-3);
  Vector6 scale;
  scale << 1.0 / lever_m, 1.0 / lever_m, 1.0 / lever_m, 1.0, 1.0, 1.0;
  const Eigen::Matrix<double, 6, 6> scaled = scale.asDiagonal() * information * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(scaled);
  result.eigenvalues = eigen.eigenvalues();
  const double largest = result.eigenvalues[5];
  Eigen::Matrix<double, 6, 6> projector = Eigen::Matrix<double, 6, 6>::Zero();
  for (int i = 0; i < 6; ++i) {
    if (!(largest > 0.0) || result.eigenvalues[i] < config.degeneracy_ratio * largest) continue;
    projector += eigen.eigenvectors().col(i) * eigen.eigenvectors().col(i).transpose();
    ++result.observable;
  }
  const Vector6 solved = Eigen::Map<const Vector6>(delta);
  const Vector6 scaled_delta = solved.cwiseQuotient(scale);
  result.delta = (projector * scaled_delta).cwiseProduct(scale);
  result.solved = result.observable > 0;
  return result;
}

}  // namespace

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
  if (!(c.max_normal_angle_deg > 0.0 && c.max_normal_angle_deg < 90.0))
    fail("max_normal_angle_deg", "must be in (0, 90)");
  if (!(c.max_plane_distance_m > 0.0)) fail("max_plane_distance_m", "must be > 0");
  if (!(c.min_overlap >= 0.0 && c.min_overlap <= 1.0)) fail("min_overlap", "must be in [0, 1]");
  if (!(c.overlap_margin_m >= 0.0)) fail("overlap_margin_m", "must be >= 0");
  if (c.min_associations < 1) fail("min_associations", "must be >= 1");
  if (c.association_rounds < 1) fail("association_rounds", "must be >= 1");
  if (c.loss != "huber" && c.loss != "cauchy" && c.loss != "none")
    fail("loss", "'" + c.loss + "' is not one of huber, cauchy, none");
  if (!(c.plane_sigma_m > 0.0)) fail("plane_sigma_m", "must be > 0");
  if (!(c.disparity_sigma_px >= 0.0)) fail("disparity_sigma_px", "must be >= 0");
  if (!(c.loss_scale_m > 0.0)) fail("loss_scale_m", "must be > 0");
  if (!(c.prior_sigma_m >= 0.0)) fail("prior_sigma_m", "must be >= 0 (0 = no prior)");
  if (!(c.prior_sigma_deg >= 0.0)) fail("prior_sigma_deg", "must be >= 0 (0 = no prior)");
  if (c.max_iterations < 1) fail("max_iterations", "must be >= 1");
  if (!(c.degeneracy_ratio > 0.0 && c.degeneracy_ratio < 1.0)) fail("degeneracy_ratio", "must be in (0, 1)");
  if (!(c.max_correction_m > 0.0)) fail("max_correction_m", "must be > 0");
  if (!(c.max_correction_deg > 0.0)) fail("max_correction_deg", "must be > 0");
}

PoseRefinement refine_pose(std::span<const Planecell> cells_cam, const Pose& T_world_cam_input,
                           const map::GlobalMap& map, const StereoCamera& camera,
                           const RefineConfig& config) {
  validate(config);
  validate_pose(T_world_cam_input, "refine_pose: input pose");
  if (!(camera.fx > 0.0) || !(camera.baseline_m > 0.0))
    throw InputError("refine_pose: camera needs fx > 0 and baseline > 0");
  PoseRefinement out;
  out.refined = T_world_cam_input;
  if (!config.enabled) return out;

  Pose current = T_world_cam_input;
  bool any = false;
  for (int round = 0; round < config.association_rounds; ++round) {
    const Eigen::AngleAxisd so_far(current.linear() * T_world_cam_input.linear().transpose());
    Vector6 offset;
    offset << so_far.angle() * so_far.axis(), current.translation() - T_world_cam_input.translation();
    const RoundResult r = refine_round(cells_cam, current, map, camera, config, offset);
    if (round == 0) out.initial_cost = r.initial_cost;
    out.iterations += r.iterations;
    if (any && !r.solved) break;  // keep the statistics of the last solved round
    out.associations = r.associations;
    out.residuals = r.residuals;
    out.final_cost = r.final_cost;
    out.information_eigenvalues = r.eigenvalues;
    out.observable_directions = r.observable;
    if (!r.solved) break;
    current = apply_correction(current, r.delta);
    any = true;
  }
  if (!any) {
    out.status = out.associations < static_cast<std::size_t>(config.min_associations)
                     ? RefineStatus::kTooFewAssociations
                     : RefineStatus::kRejected;
    return out;
  }
  // Total correction relative to the input: R = R(ω) R_in, t = t_in + τ.
  const Eigen::AngleAxisd total(current.linear() * T_world_cam_input.linear().transpose());
  out.correction.head<3>() = total.angle() * total.axis();
  out.correction.tail<3>() = current.translation() - T_world_cam_input.translation();
  if (out.correction.tail<3>().norm() > config.max_correction_m ||
      total.angle() > config.max_correction_deg * kDegToRad) {
    out.status = RefineStatus::kRejected;
    return out;
  }
  out.refined = current;
  out.status = RefineStatus::kRefined;
  return out;
}

}  // namespace planecell::refine
