#pragma once
/// Disparity accuracy against ground truth (Middlebury bad-t, KITTI D1, MAE, density) and the
/// list of stereo methods that `planecell eval-stereo` compares side by side.
#include <array>
#include <functional>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "core/config/planecell_config.hpp"
#include "core/config/sgm_config.hpp"
#include "core/stereo_camera.hpp"
#include "io/stereo_datasets.hpp"

namespace planecell::services::eval {

/// Error counts of one disparity map over the pixels that have ground truth (GT not NaN, > 0).
/// A pixel is "bad-t" when |d − d_gt| > t px (Middlebury, GT pixel units) and a "D1 outlier"
/// when |d − d_gt| > 3 px and > 5 % of d_gt (KITTI). Counts add over images (pooled figures).
struct DisparityErrors {
  long gt_pixels = 0;  ///< pixels with ground truth
  long estimated = 0;  ///< … of which the method gave an estimate (not NaN)
  long bad1 = 0, bad2 = 0, bad4 = 0, d1 = 0;  ///< outliers among the estimated pixels
  double abs_error_sum_px = 0.0;              ///< Σ |d − d_gt| over the estimated pixels

  DisparityErrors& operator+=(const DisparityErrors& o);

  double density_pct() const;
  /// % of all GT pixels that are outliers or have no estimate (missing counts as an error).
  double all_pct(long outliers) const;
  /// % of the estimated pixels that are outliers.
  double estimated_pct(long outliers) const;
  /// Mean absolute error over the estimated pixels (px); NaN when nothing was estimated.
  double mae_px() const;
};

/// Compares `estimate` with `gt` (both CV_32F px, NaN = none; GT ≤ 0 is treated as unknown).
/// Throws InputError when the sizes or types differ.
DisparityErrors evaluate_disparity(const cv::Mat& estimate, const cv::Mat& gt);

/// Radii of the 3D accuracy (paper Table 1): 10, 20, 50 and 100 cm.
inline constexpr std::array<double, 4> kPointRadiiM = {0.1, 0.2, 0.5, 1.0};

/// 3D accuracy of one disparity map (paper Table 1): a GT pixel (u, v) counts as "within r" when
/// the point reconstructed from the estimate, X(u, v, d) = Z(d)·((u − c_x)/f_x, (v − c_y)/f_y, 1)
/// with Z(d) = f_x·B/d, lies within r of the GT point X(u, v, d_gt), i.e.
/// |Z(d) − Z(d_gt)|·‖((u − c_x)/f_x, (v − c_y)/f_y, 1)‖ ≤ r. Missing estimates (NaN or d ≤ 0)
/// count as outside every radius. Counts add over images (pooled figures).
struct PointErrors {
  long gt_pixels = 0;            ///< pixels with ground truth (0 = no camera, not scored)
  std::array<long, 4> within{};  ///< … of which within kPointRadiiM[k]

  PointErrors& operator+=(const PointErrors& o);
  /// % of the GT pixels within kPointRadiiM[k]; NaN when nothing was scored.
  double within_pct(std::size_t k) const;
};

/// Scores `estimate` against `gt` (CV_32F px, NaN = none, GT ≤ 0 unknown) in 3D with `camera`.
/// Throws InputError when the sizes or types differ, ConfigError on an invalid camera.
PointErrors evaluate_points(const cv::Mat& estimate, const cv::Mat& gt, const StereoCamera& camera);

/// A stereo method under evaluation: name → function(sample) → CV_32F disparity (NaN = none).
struct StereoMethod {
  std::string name;
  std::string parameters;  ///< printed with the results so the comparison states its settings
  std::function<cv::Mat(const io::StereoSample&)> run;
};

/// planecell SGM (with `sgm`, max_disparity from the sample), OpenCV StereoSGBM in MODE_SGBM
/// and MODE_SGBM_3WAY with one fixed, stated parameter set (blockSize 5, P1 = 8·3·5²,
/// P2 = 32·3·5², uniquenessRatio 10, speckle 100/2, disp12MaxDiff 1), same disparity range, and
/// "planecell": the dense plane disparity of extract_planecells (with `extraction`) run on the
/// planecell SGM output.
std::vector<StereoMethod> default_stereo_methods(const SgmConfig& sgm,
                                                 const ExtractionConfig& extraction = {});

/// OpenCV StereoSGBM with the parameters above (`mode` = cv::StereoSGBM::MODE_*), as float px
/// (NaN where OpenCV found no match or disparity 0). The one SGBM baseline of evals and benches.
cv::Mat opencv_sgbm_disparity(const cv::Mat& left, const cv::Mat& right, int max_disparity,
                              int mode);

/// Result of one method on one pair.
struct MethodResult {
  std::string method;
  double time_ms = 0.0;
  DisparityErrors all;  ///< over all GT pixels
  DisparityErrors noc;  ///< over non-occluded GT pixels (gt_pixels = 0 when not available)
  PointErrors points;   ///< 3D accuracy over all GT pixels (gt_pixels = 0 without a camera)
};

struct PairResult {
  std::string pair;
  int max_disparity = 0;
  std::vector<MethodResult> methods;
};

/// Runs every method on `sample` and scores it (in 3D too when the sample has a camera).
PairResult evaluate_pair(const io::StereoSample& sample, const std::vector<StereoMethod>& methods);

/// Pooled totals per method over all pairs (same order as `methods`).
std::vector<MethodResult> pooled_results(const std::vector<PairResult>& pairs,
                                         const std::vector<StereoMethod>& methods);

/// The side-by-side text table (per pair and overall), followed by the 3D accuracy table when
/// some pair has a camera.
std::string format_table(const std::vector<PairResult>& pairs,
                         const std::vector<StereoMethod>& methods);

/// The same table as JSON.
std::string format_json(const std::string& dataset, const std::vector<PairResult>& pairs,
                        const std::vector<StereoMethod>& methods);

}  // namespace planecell::services::eval
