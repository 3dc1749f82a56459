#include "mapping/refine/correction_solver.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

namespace planecell::refine {
namespace {

/// r = (n·(R_c q + c + τ) + e) / σ = (n·(R_c q + τ) + e') / σ with e' = e + n·c.
struct CentroidToPlaneCost {
  CentroidToPlaneCost(const Eigen::Vector3d& q_, const Eigen::Vector3d& n_, double e_, double sigma)
      : q(q_), n(n_), e(e_), inv_sigma(1.0 / sigma) {}

  template <class T>
  bool operator()(const T* rotation, const T* translation, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> r(rotation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> tau(translation);
    const Eigen::Matrix<T, 3, 1> moved = r * q.cast<T>() + tau;
    residual[0] = (moved.dot(n.cast<T>()) + T(e)) * T(inv_sigma);
    return true;
  }

  Eigen::Vector3d q, n;
  double e;  ///< e_s + n_s·c: the surface plane seen from the camera centre
  double inv_sigma;
};

/// ((log R_c + ω₀)/σ_ω, (τ + τ₀)/σ_τ). log via ceres::QuaternionToAngleAxis (w, x, y, z order;
/// the Eigen quaternion block is stored x, y, z, w).
struct PriorCost {
  Vector6 inv_sigma, offset;
  template <class T>
  bool operator()(const T* rotation, const T* translation, T* residual) const {
    const T wxyz[4] = {rotation[3], rotation[0], rotation[1], rotation[2]};
    T omega[3];
    ceres::QuaternionToAngleAxis(wxyz, omega);
    for (int i = 0; i < 3; ++i) {
      residual[i] = (omega[i] + T(offset[i])) * T(inv_sigma[i]);
      residual[3 + i] = (translation[i] + T(offset[3 + i])) * T(inv_sigma[3 + i]);
    }
    return true;
  }
};

std::unique_ptr<ceres::LossFunction> make_loss(const RefineConfig& config) {
  if (config.loss == "huber") return std::make_unique<ceres::HuberLoss>(config.loss_scale);
  if (config.loss == "cauchy") return std::make_unique<ceres::CauchyLoss>(config.loss_scale);
  return nullptr;
}

/// One Ceres solve of the whitened problem with every σ_k multiplied by `sigma_scale`, starting
/// from (rotation, translation) and leaving the solution there.
ceres::Solver::Summary solve_once(std::span<const SurfaceAssociation> associations,
                                  std::span<const Eigen::Vector3d> lever, const Eigen::Vector3d& centre,
                                  const CorrectionPrior& prior, const RefineConfig& config,
                                  ceres::LossFunction* loss, double sigma_scale, double* rotation,
                                  double* translation) {
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (std::size_t k = 0; k < associations.size(); ++k) {
    const SurfaceAssociation& a = associations[k];
    const Plane3& s = a.surface_plane;
    auto* cost = new ceres::AutoDiffCostFunction<CentroidToPlaneCost, 1, 4, 3>(new CentroidToPlaneCost(
        lever[k], s.normal, s.offset + s.normal.dot(centre), sigma_scale * a.sigma_m));
    problem.AddResidualBlock(cost, loss, rotation, translation);
  }
  if (prior.enabled()) {
    auto* cost = new ceres::AutoDiffCostFunction<PriorCost, 6, 4, 3>(
        new PriorCost{prior.sigma.cwiseInverse(), prior.offset});
    problem.AddResidualBlock(cost, nullptr, rotation, translation);
  }
  problem.SetManifold(rotation, new ceres::EigenQuaternionManifold);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = config.max_iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return summary;
}

/// Whitened residuals r_k (σ_k unscaled) at the correction (rc, τ).
std::vector<double> whitened_residuals(std::span<const SurfaceAssociation> associations,
                                       std::span<const Eigen::Vector3d> lever, const Eigen::Vector3d& centre,
                                       const Eigen::Quaterniond& rc, const Eigen::Vector3d& tau) {
  std::vector<double> out;
  out.reserve(associations.size());
  for (std::size_t k = 0; k < associations.size(); ++k) {
    const SurfaceAssociation& a = associations[k];
    out.push_back((a.surface_plane.normal.dot(rc * lever[k] + centre + tau) + a.surface_plane.offset) / a.sigma_m);
  }
  return out;
}

}  // namespace

CorrectionSolution solve_correction(std::span<const SurfaceAssociation> associations,
                                    const Pose& T_world_cam, const CorrectionPrior& prior,
                                    const RefineConfig& config) {
  CorrectionSolution out;
  if (associations.empty()) return out;
  const Eigen::Vector3d centre = T_world_cam.translation();
  std::vector<Eigen::Vector3d> lever;  // q_k = T c_k − c
  lever.reserve(associations.size());
  for (const SurfaceAssociation& a : associations) lever.push_back(T_world_cam.linear() * a.centroid_cam);

  double rotation[4] = {0.0, 0.0, 0.0, 1.0};  // x, y, z, w
  double translation[3] = {0.0, 0.0, 0.0};
  const std::unique_ptr<ceres::LossFunction> loss = make_loss(config);
  ceres::Solver::Summary summary =
      solve_once(associations, lever, centre, prior, config, loss.get(), 1.0, rotation, translation);
  out.iterations = static_cast<int>(summary.iterations.size());
  out.initial_cost = summary.initial_cost;
  if (!summary.IsSolutionUsable()) return out;
  if (config.estimate_noise_scale && associations.size() >= 10) {
    // Robust scale of the whitened residuals at the solution: s = 1.4826 · median |r_k| (MAD,
    // = 1 for calibrated σ). The σ_k are rescaled by s (clamped) and the problem solved again.
    std::vector<double> r = whitened_residuals(
        associations, lever, centre,
        Eigen::Quaterniond(rotation[3], rotation[0], rotation[1], rotation[2]).normalized(),
        Eigen::Vector3d(translation[0], translation[1], translation[2]));
    for (double& x : r) x = std::abs(x);
    std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
    out.noise_scale = std::clamp(1.4826 * r[r.size() / 2], config.min_noise_scale, config.max_noise_scale);
    summary = solve_once(associations, lever, centre, prior, config, loss.get(), out.noise_scale, rotation,
                         translation);
    out.iterations += static_cast<int>(summary.iterations.size());
    if (!summary.IsSolutionUsable()) return out;
  }
  out.final_cost = summary.final_cost;

  const Eigen::Quaterniond rc = Eigen::Quaterniond(rotation[3], rotation[0], rotation[1], rotation[2]).normalized();
  const Eigen::AngleAxisd omega(rc);
  Vector6 solved;
  solved << omega.angle() * omega.axis(), Eigen::Vector3d(translation[0], translation[1], translation[2]);

  // Information of the map residuals at the solution: ∂r/∂ω = (R_c q) × n / σ, ∂r/∂τ = n / σ
  // (left perturbation R_c → exp(ω^) R_c), weighted by the robust loss' ρ'(r²).
  double sum_sq = 0.0;
  for (std::size_t k = 0; k < associations.size(); ++k) {
    const SurfaceAssociation& a = associations[k];
    const Eigen::Vector3d moved = rc * lever[k];
    const Eigen::Vector3d& n = a.surface_plane.normal;
    const double sigma = out.noise_scale * a.sigma_m;
    const double r = (n.dot(moved + centre + solved.tail<3>()) + a.surface_plane.offset) / sigma;
    double rho[3] = {r * r, 1.0, 0.0};
    if (loss) loss->Evaluate(r * r, rho);
    const Eigen::Vector3d lever_cross_n = moved.cross(n);
    Vector6 j;
    j.head<3>() = lever_cross_n / sigma;
    j.tail<3>() = n / sigma;
    out.information += rho[1] * j * j.transpose();
    sum_sq += lever[k].squaredNorm();
  }
  const double lever_m = std::max(std::sqrt(sum_sq / static_cast<double>(associations.size())), 1e-3);
  Vector6 scale;
  scale << 1.0 / lever_m, 1.0 / lever_m, 1.0 / lever_m, 1.0, 1.0, 1.0;
  const Matrix6 scaled = scale.asDiagonal() * out.information * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Matrix6> eigen(scaled);
  out.eigenvalues = eigen.eigenvalues();
  const double largest = out.eigenvalues[5];
  Matrix6 projector = Matrix6::Zero();
  for (int i = 0; i < 6; ++i) {
    if (!(largest > 0.0) || out.eigenvalues[i] < config.degeneracy_ratio * largest) continue;
    projector += eigen.eigenvectors().col(i) * eigen.eigenvectors().col(i).transpose();
    ++out.observable;
  }
  // Projection in the scaled coordinates s = (L ω, τ): δ ← S⁻¹ V_o V_oᵀ S δ.
  out.delta = (projector * solved.cwiseQuotient(scale)).cwiseProduct(scale);
  out.usable = out.observable > 0;
  return out;
}

}  // namespace planecell::refine
