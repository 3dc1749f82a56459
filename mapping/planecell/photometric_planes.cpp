#include "mapping/planecell/photometric_planes.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace planecell::extraction {
namespace {

using Vec5 = Eigen::Matrix<double, 5, 1>;
using Mat5 = Eigen::Matrix<double, 5, 5>;

/// One textured sample of a cell: pixel (u, v) and its smoothed left intensity.
struct Sample {
  float u = 0.0f;
  float v = 0.0f;
  float left = 0.0f;
};

/// Huber's ρ(r) with threshold k.
double huber(double r, double k) {
  const double a = std::abs(r);
  return a <= k ? 0.5 * r * r : k * (a - 0.5 * k);
}

/// The photometric error of one cell's samples under the plane d = a·(u − ū) + b·(v − v̄) + c
/// and brightness offset β, with the normal equations of a Gauss–Newton step in x = (a, b, c, β).
struct CellProblem {
  std::span<const Sample> samples;
  const cv::Mat* right = nullptr;  ///< smoothed right image, CV_32F
  double u_mean = 0.0;
  double v_mean = 0.0;
  double huber_k = 8.0;

  /// Robust cost E and, when `normal` is given, H = Σ w J Jᵀ and g = Σ w J r (IRLS weights).
  double evaluate(const Vec5& x, Mat5* hessian, Vec5* gradient,
                  int* used) const {
    const int w = right->cols;
    double cost = 0.0;
    int n = 0;
    if (hessian) hessian->setZero(), gradient->setZero();
    for (const Sample& s : samples) {
      const double du = s.u - u_mean, dv = s.v - v_mean;
      const double d = x[0] * du + x[1] * dv + x[2];
      const double xr = s.u - d;
      if (!(xr >= 0.0) || xr >= w - 1) continue;
      const int x0 = static_cast<int>(xr);
      const double t = xr - x0;
      const float* row = right->ptr<float>(static_cast<int>(s.v));
      const double slope = row[x0 + 1] - row[x0];
      const double right_value = row[x0] + t * slope;
      const double r = s.left - x[4] * right_value - x[3];
      cost += huber(r, huber_k);
      ++n;
      if (!hessian) continue;
      const double weight = std::abs(r) <= huber_k ? 1.0 : huber_k / std::abs(r);
      Vec5 j;  // ∂r/∂x (∂d/∂a = u − ū, …)
      j << x[4] * slope * du, x[4] * slope * dv, x[4] * slope, -1.0, -right_value;
      hessian->noalias() += weight * j * j.transpose();
      *gradient += weight * r * j;
    }
    if (used) *used = n;
    return cost;
  }
};

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

  for (std::size_t k = 0; k < n_cells; ++k) {
    if (!has_plane[k]) continue;
    const std::span<const Sample> cell(samples.data() + first[k], samples.data() + first[k + 1]);
    if (static_cast<int>(cell.size()) < config.min_samples) {
      ++stats.kept;
      continue;
    }
    CellProblem problem{cell, &right, 0.0, 0.0, config.huber_grey};
    for (const Sample& s : cell) problem.u_mean += s.u, problem.v_mean += s.v;
    problem.u_mean /= static_cast<double>(cell.size());
    problem.v_mean /= static_cast<double>(cell.size());
    const DisparityPlane& fitted = planes[k];
    Vec5 x;
    x << fitted.a, fitted.b, fitted.at(problem.u_mean, problem.v_mean), 0.0, 1.0;
    // β for the fitted plane first (a few IRLS steps of the offset alone): the baseline cost.
    Mat5 h;
    Vec5 g;
    int used = 0;
    for (int i = 0; i < 3; ++i) {
      problem.evaluate(x, &h, &g, &used);
      if (h(3, 3) > 0.0) x[3] -= g[3] / h(3, 3);
    }
    const Vec5 start = x;
    const double cost0 = problem.evaluate(x, nullptr, nullptr, &used);
    const int used0 = used;
    double best_cost = cost0;
    Vec5 best = x;
    double lambda = 1e-3;  // Levenberg–Marquardt damping on diag(H)
    for (int it = 0; it < config.iterations; ++it) {
      problem.evaluate(x, &h, &g, &used);
      Mat5 damped = h;
      damped.diagonal() *= 1.0 + lambda;
      const Vec5 delta = damped.ldlt().solve(-g);
      if (!delta.allFinite()) break;
      const Vec5 trial = x + delta;
      int used_trial = 0;
      const double cost = problem.evaluate(trial, nullptr, nullptr, &used_trial);
      // Costs are comparable only over the same samples (a shift can push some out of the image).
      if (used_trial == used0 && cost < best_cost) {
        best_cost = cost, best = trial, x = trial;
        lambda = std::max(1e-6, lambda * 0.3);
      } else {
        lambda *= 10.0;
      }
    }
    // Largest disparity change over the samples (linear in u, v: attained at an extreme sample).
    double shift = 0.0;
    const Eigen::Vector3d change = (best - start).head<3>();
    if (!(best[4] > 0.5 && best[4] < 2.0)) shift = 1e9;  // a gain this far off is not a match
    for (const Sample& s : cell)
      shift = std::max(shift, std::abs(change[0] * (s.u - problem.u_mean) +
                                       change[1] * (s.v - problem.v_mean) + change[2]));
    if (!(best_cost < config.min_cost_ratio * cost0) || shift > config.max_shift_px) {
      ++stats.kept;
      continue;
    }
    DisparityPlane& plane = planes[k];
    plane.a = best[0];
    plane.b = best[1];
    plane.c = best[2] - best[0] * problem.u_mean - best[1] * problem.v_mean;
    ++stats.refined;
  }
  return stats;
}

}  // namespace planecell::extraction
