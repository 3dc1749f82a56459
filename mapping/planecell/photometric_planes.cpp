#include "mapping/planecell/photometric_planes.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <Eigen/Dense>
#include <ceres/ceres.h>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace planecell::extraction {
namespace {

/// One textured sample of a cell: pixel (u, v) and its smoothed left intensity.
struct Sample {
  float u = 0.0f;
  float v = 0.0f;
  float left = 0.0f;
};

/// The photometric residuals of one cell's samples, r_p = I_L(p) − α·I_R(u − d(p), v) − β, with
/// d(p) = a·(u − ū) + b·(v − v̄) + c, over the parameter block x = (a, b, c, β, α). Analytic
/// Jacobian (I_R linear along the row between its pixels):
///   ∂r/∂(a, b, c) = α·∂I_R/∂u·(u − ū, v − v̄, 1),  ∂r/∂β = −1,  ∂r/∂α = −I_R.
/// A sample whose match falls outside the right image has residual 0 and no gradient; `used`
/// counts the others so that costs are compared over the same samples.
class PhotometricCost final : public ceres::CostFunction {
 public:
  PhotometricCost(std::span<const Sample> samples, const cv::Mat& right, double u_mean, double v_mean)
      : samples_(samples), right_(right), u_mean_(u_mean), v_mean_(v_mean) {
    set_num_residuals(static_cast<int>(samples.size()));
    mutable_parameter_block_sizes()->push_back(5);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* x = parameters[0];
    double* jacobian = jacobians ? jacobians[0] : nullptr;
    const int w = right_.cols;
    for (std::size_t i = 0; i < samples_.size(); ++i) {
      const Sample& s = samples_[i];
      const double du = s.u - u_mean_, dv = s.v - v_mean_;
      const double xr = s.u - (x[0] * du + x[1] * dv + x[2]);
      double* j = jacobian ? jacobian + 5 * i : nullptr;
      if (!(xr >= 0.0) || xr >= w - 1) {
        residuals[i] = 0.0;
        if (j) std::fill(j, j + 5, 0.0);
        continue;
      }
      const int x0 = static_cast<int>(xr);
      const float* row = right_.ptr<float>(static_cast<int>(s.v));
      const double slope = row[x0 + 1] - row[x0];
      const double right_value = row[x0] + (xr - x0) * slope;
      residuals[i] = s.left - x[4] * right_value - x[3];
      if (j) {
        j[0] = x[4] * slope * du, j[1] = x[4] * slope * dv, j[2] = x[4] * slope;
        j[3] = -1.0, j[4] = -right_value;
      }
    }
    return true;
  }

  /// Samples whose match lies inside the right image under `x`.
  int used(const double* x) const {
    int n = 0;
    for (const Sample& s : samples_) {
      const double xr = s.u - (x[0] * (s.u - u_mean_) + x[1] * (s.v - v_mean_) + x[2]);
      n += xr >= 0.0 && xr < right_.cols - 1;
    }
    return n;
  }

 private:
  std::span<const Sample> samples_;
  const cv::Mat& right_;
  double u_mean_, v_mean_;
};

/// Σ ρ(r_p) of the cell at `x` (Huber ρ with threshold k; Ceres' cost is the same sum).
double robust_cost(const PhotometricCost& cost, const ceres::LossFunction& loss, double* x,
                   std::vector<double>& residuals) {
  residuals.resize(static_cast<std::size_t>(cost.num_residuals()));
  const double* parameters[] = {x};
  cost.Evaluate(parameters, residuals.data(), nullptr);
  double sum = 0.0;
  for (double r : residuals) {
    double rho[3];
    loss.Evaluate(r * r, rho);
    sum += 0.5 * rho[0];
  }
  return sum;
}

}  // namespace

PhotometricPlaneStats refine_planes_photometric(const cv::Mat& left_grey, const cv::Mat& right_grey,
                                                std::span<const std::int32_t> labels,
                                                std::span<DisparityPlane> planes,
                                                std::span<const std::uint8_t> has_plane,
                                                const PhotometricPlaneConfig& config) {
  PhotometricPlaneStats stats;
  if (config.iterations <= 0) return stats;
  if (left_grey.type() != CV_8UC1 || right_grey.type() != CV_8UC1 || left_grey.size() != right_grey.size())
    throw InputError("photometric plane refinement: left and right must be grey (CV_8UC1) images of one size");
  if (labels.size() != left_grey.total())
    throw InputError("photometric plane refinement: the label image does not match the images (" +
                     std::to_string(labels.size()) + " labels, " + std::to_string(left_grey.total()) + " pixels)");
  if (planes.size() != has_plane.size())
    throw InputError("photometric plane refinement: planes and has_plane differ in length");
  const int width = left_grey.cols, height = left_grey.rows;
  const int step = std::max(1, config.sample_step);
  cv::Mat left, right;
  left_grey.convertTo(left, CV_32F);
  right_grey.convertTo(right, CV_32F);
  cv::GaussianBlur(left, left, cv::Size(3, 3), 0.0);
  cv::GaussianBlur(right, right, cv::Size(3, 3), 0.0);

  // Textured samples per cell, grouped by cell (counting pass, then fill).
  const std::size_t n_cells = planes.size();
  std::vector<std::int32_t> first(n_cells + 1, 0);
  auto textured = [&](int u, int v) {
    if (u < 1 || u >= width - 1) return false;
    const float* row = left.ptr<float>(v);
    return std::abs(0.5f * (row[u + 1] - row[u - 1])) >= config.min_gradient;
  };
  for (int v = 0; v < height; v += step)
    for (int u = 0; u < width; u += step) {
      const std::int32_t l = labels[static_cast<std::size_t>(v) * width + u];
      if (l >= 0 && static_cast<std::size_t>(l) < n_cells && has_plane[l] && textured(u, v)) ++first[l + 1];
    }
  for (std::size_t k = 0; k < n_cells; ++k) first[k + 1] += first[k];
  std::vector<Sample> samples(static_cast<std::size_t>(first[n_cells]));
  std::vector<std::int32_t> fill(first.begin(), first.end() - 1);
  for (int v = 0; v < height; v += step) {
    const float* row = left.ptr<float>(v);
    for (int u = 0; u < width; u += step) {
      const std::int32_t l = labels[static_cast<std::size_t>(v) * width + u];
      if (l >= 0 && static_cast<std::size_t>(l) < n_cells && has_plane[l] && textured(u, v))
        samples[fill[l]++] = {static_cast<float>(u), static_cast<float>(v), row[u]};
    }
  }

  // One small problem per cell (5 parameters, many residuals): Levenberg–Marquardt on the dense
  // normal equations (5×5), Huber loss.
  ceres::HuberLoss loss(config.huber_grey);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.max_num_iterations = config.iterations;
  options.logging_type = ceres::SILENT;
  options.num_threads = 1;
  std::vector<double> residuals;
  for (std::size_t k = 0; k < n_cells; ++k) {
    if (!has_plane[k]) continue;
    const std::span<const Sample> cell(samples.data() + first[k], samples.data() + first[k + 1]);
    if (static_cast<int>(cell.size()) < config.min_samples) {
      ++stats.kept;
      continue;
    }
    double u_mean = 0.0, v_mean = 0.0;
    for (const Sample& sample : cell) u_mean += sample.u, v_mean += sample.v;
    u_mean /= static_cast<double>(cell.size());
    v_mean /= static_cast<double>(cell.size());
    const DisparityPlane& fitted = planes[k];
    // x = (a, b, c at the samples' centre, β, α); β starts at the mean residual of the fit.
    std::array<double, 5> x{fitted.a, fitted.b, fitted.at(u_mean, v_mean), 0.0, 1.0};
    auto* cost = new PhotometricCost(cell, right, u_mean, v_mean);
    const int used0 = cost->used(x.data());
    if (used0 < config.min_samples) {
      delete cost;
      ++stats.kept;
      continue;
    }
    residuals.resize(cell.size());
    cost->Evaluate(std::array<const double*, 1>{x.data()}.data(), residuals.data(), nullptr);
    double offset = 0.0;
    for (int i = 0; i < cost->num_residuals(); ++i) offset += residuals[static_cast<std::size_t>(i)];
    x[3] = offset / used0;
    const std::array<double, 5> start = x;
    const double cost0 = robust_cost(*cost, loss, x.data(), residuals);
    ceres::Problem problem(problem_options);
    problem.AddResidualBlock(cost, &loss, x.data());
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    const int used1 = cost->used(x.data());
    const double cost1 = robust_cost(*cost, loss, x.data(), residuals);
    const std::array<double, 5>& best = x;  // Ceres keeps the best point it reached
    const double best_cost = used1 == used0 ? cost1 : cost0;  // other samples: not comparable
    // Largest disparity change over the samples (linear in u, v: attained at an extreme sample).
    double shift = 0.0;
    const Eigen::Vector3d change(best[0] - start[0], best[1] - start[1], best[2] - start[2]);
    if (!(best[4] > 0.5 && best[4] < 2.0)) shift = 1e9;  // a gain this far off is not a match
    for (const Sample& sample : cell)
      shift = std::max(shift, std::abs(change[0] * (sample.u - u_mean) + change[1] * (sample.v - v_mean) + change[2]));
    if (!(best_cost < config.min_cost_ratio * cost0) || shift > config.max_shift_px) {
      ++stats.kept;
      continue;
    }
    DisparityPlane& plane = planes[k];
    plane.a = best[0];
    plane.b = best[1];
    plane.c = best[2] - best[0] * u_mean - best[1] * v_mean;
    ++stats.refined;
  }
  return stats;
}

}  // namespace planecell::extraction
