#include "mapping/planecell/photometric_planes.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <ceres/tiny_solver.h>
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
/// d(p) = a·(u − ū) + b·(v − v̄) + c, over x = (a, b, c, β, α), robustified for
/// ceres::TinySolver: it minimises ½Σ r̃_p², and r̃ = sign(r)·√(2ρ(r)) with Huber's ρ (threshold
/// k) makes that Σ ρ(r_p): r̃ = r for |r| ≤ k, else sign(r)·√(2k|r| − k²), dr̃/dr = k/|r̃|.
/// Analytic Jacobian (I_R linear along the row between its pixels):
///   ∂r/∂(a, b, c) = α·∂I_R/∂u·(u − ū, v − v̄, 1),  ∂r/∂β = −1,  ∂r/∂α = −I_R.
/// A sample whose match falls outside the right image has residual 0 and no gradient; `used`
/// counts the others so that costs are compared over the same samples.
struct PhotometricResiduals {
  using Scalar = double;
  enum { NUM_RESIDUALS = Eigen::Dynamic, NUM_PARAMETERS = 5 };

  std::span<const Sample> samples;
  const cv::Mat* right = nullptr;  ///< smoothed right image, CV_32F
  double u_mean = 0.0;
  double v_mean = 0.0;
  double huber_k = 8.0;

  int NumResiduals() const { return static_cast<int>(samples.size()); }

  /// r̃ of a raw residual r, and dr̃/dr in `scale`.
  double robustified(double r, double& scale) const {
    if (std::abs(r) <= huber_k) {
      scale = 1.0;
      return r;
    }
    const double rooted = std::sqrt(2.0 * huber_k * std::abs(r) - huber_k * huber_k);
    scale = huber_k / rooted;
    return std::copysign(rooted, r);
  }

  /// The raw residual r of sample `s` at `x`, with ∂I_R/∂u and I_R at its match; false when the
  /// match falls outside the right image.
  bool raw_residual(const Sample& s, const double* x, double& r, double& slope, double& right_value) const {
    const double xr = s.u - (x[0] * (s.u - u_mean) + x[1] * (s.v - v_mean) + x[2]);
    if (!(xr >= 0.0) || xr >= right->cols - 1) return false;
    const int x0 = static_cast<int>(xr);
    const float* row = right->ptr<float>(static_cast<int>(s.v));
    slope = row[x0 + 1] - row[x0];
    right_value = row[x0] + (xr - x0) * slope;
    r = s.left - x[4] * right_value - x[3];
    return true;
  }

  bool operator()(const double* x, double* residuals, double* jacobian) const {
    const std::size_t n = samples.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Sample& s = samples[i];
      double r = 0.0, slope = 0.0, right_value = 0.0;
      if (!raw_residual(s, x, r, slope, right_value)) {
        residuals[i] = 0.0;
        if (jacobian)
          for (std::size_t p = 0; p < 5; ++p) jacobian[i + p * n] = 0.0;  // column-major, n × 5
        continue;
      }
      double scale = 1.0;  // dr̃/dr
      residuals[i] = robustified(r, scale);
      if (jacobian) {
        const double du = s.u - u_mean, dv = s.v - v_mean;
        jacobian[i] = scale * x[4] * slope * du;
        jacobian[i + n] = scale * x[4] * slope * dv;
        jacobian[i + 2 * n] = scale * x[4] * slope;
        jacobian[i + 3 * n] = -scale;
        jacobian[i + 4 * n] = -scale * right_value;
      }
    }
    return true;
  }

  /// Samples whose match lies inside the right image under `x`, and Σ r over them (raw).
  int used(const double* x, double* residual_sum = nullptr) const {
    int n = 0;
    double sum = 0.0, r = 0.0, slope = 0.0, right_value = 0.0;
    for (const Sample& s : samples)
      if (raw_residual(s, x, r, slope, right_value)) ++n, sum += r;
    if (residual_sum) *residual_sum = sum;
    return n;
  }

  /// Σ ρ(r_p) at `x` (= ½Σ r̃², as TinySolver sees it); `used_samples`, when given, receives
  /// used(x), counted in the same pass.
  double cost(const double* x, int* used_samples = nullptr) const {
    double sum = 0.0, r = 0.0, slope = 0.0, right_value = 0.0;
    int n = 0;
    for (const Sample& s : samples) {
      if (!raw_residual(s, x, r, slope, right_value)) continue;
      ++n;
      double scale = 1.0;
      const double rr = robustified(r, scale);
      sum += 0.5 * rr * rr;
    }
    if (used_samples) *used_samples = n;
    return sum;
  }
};

}  // namespace

PhotometricPlaneStats refine_planes_photometric(const cv::Mat& left_grey, const cv::Mat& right_grey,
                                                std::span<const std::int32_t> labels,
                                                std::span<DisparityPlane> planes,
                                                std::span<const std::uint8_t> has_plane,
                                                const ExtractionConfig& config) {
  PhotometricPlaneStats stats;
  if (left_grey.type() != CV_8UC1 || right_grey.type() != CV_8UC1 || left_grey.size() != right_grey.size())
    throw InputError("photometric plane refinement: left and right must be grey (CV_8UC1) images of one size");
  if (labels.size() != left_grey.total())
    throw InputError("photometric plane refinement: the label image does not match the images (" +
                     std::to_string(labels.size()) + " labels, " + std::to_string(left_grey.total()) + " pixels)");
  if (planes.size() != has_plane.size())
    throw InputError("photometric plane refinement: planes and has_plane differ in length");
  if (config.photometric_iterations <= 0) return stats;
  const int width = left_grey.cols, height = left_grey.rows;
  const int step = std::max(1, config.photometric_sample_step);
  cv::Mat left, right;
  left_grey.convertTo(left, CV_32F);
  right_grey.convertTo(right, CV_32F);
  cv::GaussianBlur(left, left, cv::Size(3, 3), 0.0);
  cv::GaussianBlur(right, right, cv::Size(3, 3), 0.0);

  // Textured samples per cell, grouped by cell: one pass over the sampling grid, then a counting
  // sort by cell.
  const std::size_t n_cells = planes.size();
  std::vector<Sample> unsorted;
  std::vector<std::int32_t> cell_of;
  const std::size_t grid = static_cast<std::size_t>((height + step - 1) / step) * ((width + step - 1) / step);
  unsorted.reserve(grid);
  cell_of.reserve(grid);
  std::vector<std::int32_t> first(n_cells + 1, 0);
  for (int v = 0; v < height; v += step) {
    const float* row = left.ptr<float>(v);
    for (int u = step; u < width - 1; u += step) {  // u = 0 has no central gradient
      const std::int32_t l = labels[static_cast<std::size_t>(v) * width + u];
      if (l < 0 || static_cast<std::size_t>(l) >= n_cells || !has_plane[l]) continue;
      if (!(std::abs(0.5f * (row[u + 1] - row[u - 1])) >= config.photometric_min_gradient)) continue;
      unsorted.push_back({static_cast<float>(u), static_cast<float>(v), row[u]});
      cell_of.push_back(l);
      ++first[l + 1];
    }
  }
  for (std::size_t k = 0; k < n_cells; ++k) first[k + 1] += first[k];
  std::vector<Sample> samples(unsorted.size());
  std::vector<std::int32_t> fill(first.begin(), first.end() - 1);
  for (std::size_t i = 0; i < unsorted.size(); ++i) samples[fill[cell_of[i]]++] = unsorted[i];

  // One small problem per cell (5 parameters, many residuals): ceres::TinySolver's
  // Levenberg–Marquardt on the 5×5 normal equations, without a ceres::Problem's set-up per cell.
  using Solver = ceres::TinySolver<PhotometricResiduals>;
  Solver solver;
  solver.options.max_num_iterations = config.photometric_iterations;
  for (std::size_t k = 0; k < n_cells; ++k) {
    if (!has_plane[k]) continue;
    const std::span<const Sample> cell(samples.data() + first[k], samples.data() + first[k + 1]);
    if (static_cast<int>(cell.size()) < kMinPhotometricSamples) {
      ++stats.kept;
      continue;
    }
    double u_mean = 0.0, v_mean = 0.0;
    for (const Sample& sample : cell) u_mean += sample.u, v_mean += sample.v;
    u_mean /= static_cast<double>(cell.size());
    v_mean /= static_cast<double>(cell.size());
    const DisparityPlane& fitted = planes[k];
    const PhotometricResiduals problem{cell, &right, u_mean, v_mean, config.photometric_huber_grey};
    // x = (a, b, c at the samples' centre, β, α); β starts at the fit's mean residual.
    Solver::Parameters x;
    x << fitted.a, fitted.b, fitted.at(u_mean, v_mean), 0.0, 1.0;
    double offset = 0.0;
    const int used0 = problem.used(x.data(), &offset);
    if (used0 < kMinPhotometricSamples) {
      ++stats.kept;
      continue;
    }
    x[3] = offset / used0;
    const Solver::Parameters start = x;
    const double cost0 = problem.cost(x.data());
    solver.Solve(problem, &x);
    int used1 = 0;
    const double cost1 = problem.cost(x.data(), &used1);
    const double best_cost = used1 == used0 ? cost1 : cost0;  // other samples: not comparable
    // Largest disparity change over the samples (linear in u, v: attained at an extreme sample).
    double shift = 0.0;
    const Eigen::Vector3d change(x[0] - start[0], x[1] - start[1], x[2] - start[2]);
    if (!(x[4] > 0.5 && x[4] < 2.0)) shift = 1e9;  // a gain this far off is not a match
    for (const Sample& sample : cell)
      shift = std::max(shift, std::abs(change[0] * (sample.u - u_mean) + change[1] * (sample.v - v_mean) + change[2]));
    if (!(best_cost < config.photometric_min_cost_ratio * cost0) || shift > config.photometric_max_shift_px) {
      ++stats.kept;
      continue;
    }
    DisparityPlane& plane = planes[k];
    plane.a = x[0];
    plane.b = x[1];
    plane.c = x[2] - x[0] * u_mean - x[1] * v_mean;
    ++stats.refined;
  }
  return stats;
}

}  // namespace planecell::extraction
