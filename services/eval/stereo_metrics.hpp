#pragma once
/// Disparity accuracy against ground truth (Middlebury bad-t, KITTI D1, MAE, density) and the
/// list of stereo methods that `planecell eval-stereo` compares side by side.
#include <array>
#include <functional>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/config/planecell_config.hpp"
#include "core/config/sgm_config.hpp"
#include "core/stereo_camera.hpp"
#include "io/stereo_datasets.hpp"
#include "services/eval/segmentation_metrics.hpp"

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
/// The paper's Table 1 row for planecells on OpenCV SGBM disparity (its KITTI stereo frames): % of
/// GT pixels within kPointRadiiM. Printed under the 3D tables as the figure to beat.
inline constexpr std::array<double, 4> kPaperTable1SgbmPct = {33.49, 50.23, 72.91, 80.84};

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

/// Calls `visit(u, v, distance_m)` for every GT pixel (row by row) with the 3D error of Table 1,
/// distance_m = ‖X(u, v, d) − X(u, v, d_gt)‖ = |Z(d) − Z(d_gt)|·‖((u − c_x)/f_x, (v − c_y)/f_y, 1)‖,
/// or NaN when the estimate has no point there (NaN or d ≤ 0). The one definition behind
/// evaluate_points and point_accuracy_curve. Same errors as evaluate_points.
void for_each_point_distance(const cv::Mat& estimate, const cv::Mat& gt, const StereoCamera& camera,
                             const std::function<void(int u, int v, double distance_m)>& visit);

/// Cumulative 3D accuracy curve (the paper's Fig. "Reconstruction accuracy"): at the thresholds
/// x_k = k·max_m/steps (k = 0..steps), the share of GT pixels whose reconstructed point lies within
/// x_k of its GT point (distance ≤ x_k). Pixels without a point, or farther than max_m, count
/// only in the total, so a curve ends at most at the representation's density. Counts add over
/// frames (pooled curves). The default grid (1 cm steps to 1 m) contains kPointRadiiM exactly.
class AccuracyCurve {
 public:
  /// Throws ConfigError when max_m ≤ 0 or steps < 1.
  explicit AccuracyCurve(double max_m = 1.0, int steps = 100);

  /// One GT pixel: its point's distance to the GT point (m), NaN (or ∞) when it has no point.
  void add(double distance_m);
  /// Adds another curve's counts. Throws ConfigError when the grids differ.
  AccuracyCurve& operator+=(const AccuracyCurve& other);

  int steps() const { return static_cast<int>(bins_.size()) - 1; }
  double max_m() const { return max_m_; }
  /// x_k = k·max_m/steps (m).
  double threshold_m(int k) const;
  long gt_pixels() const { return gt_pixels_; }
  /// GT pixels that have a point at all (any distance).
  long with_point() const { return with_point_; }
  /// GT pixels with distance ≤ x_k.
  long within(int k) const;
  /// 100·within(k)/gt_pixels; NaN when no GT pixel was added.
  double within_pct(int k) const;
  /// 100·with_point/gt_pixels (the density the curve is bounded by); NaN without GT pixels.
  double density_pct() const;

 private:
  double max_m_;
  std::vector<long> bins_;  ///< bins_[k]: distances in (x_{k−1}, x_k]; bins_[0]: distance 0
  long gt_pixels_ = 0;
  long with_point_ = 0;
};

/// The curve of one disparity map against GT (distances of for_each_point_distance).
AccuracyCurve point_accuracy_curve(const cv::Mat& estimate, const cv::Mat& gt,
                                   const StereoCamera& camera, double max_m = 1.0, int steps = 100);

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
  /// Planecells vs GT surfaces (synthetic pairs; see segmentation_metrics.hpp), when scored.
  std::optional<SegmentationScores> segmentation;
};

/// Runs every method on `sample` and scores it (in 3D too when the sample has a camera).
PairResult evaluate_pair(const io::StereoSample& sample, const std::vector<StereoMethod>& methods);

/// Pooled totals per method over all pairs (same order as `methods`).
std::vector<MethodResult> pooled_results(const std::vector<PairResult>& pairs,
                                         const std::vector<StereoMethod>& methods);

/// The side-by-side text table (per pair and overall), followed by the 3D accuracy table when
/// some pair has a camera and the planecell segmentation lines when some pair has them.
std::string format_table(const std::vector<PairResult>& pairs,
                         const std::vector<StereoMethod>& methods);

/// The same table as JSON ("segmentation" in each scored pair, "segmentation_overall" pooled).
std::string format_json(const std::string& dataset, const std::vector<PairResult>& pairs,
                        const std::vector<StereoMethod>& methods);

}  // namespace planecell::services::eval
