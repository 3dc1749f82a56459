#include "services/eval/stereo_metrics.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <sstream>

#include "core/error.hpp"
#include "mapping/planecell/extraction.hpp"
#include "mapping/stereo/sgm.hpp"

namespace planecell::services::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kSgbmBlock = 5;

double pct(long part, long whole) {
  return whole == 0 ? kNaN : 100.0 * static_cast<double>(part) / static_cast<double>(whole);
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream s;
  s << std::setprecision(6) << v;
  return s.str();
}

std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

void append_errors_json(std::ostringstream& j, const char* key, const DisparityErrors& e) {
  j << json_string(key) << ": {\"gt_pixels\": " << e.gt_pixels << ", \"estimated\": " << e.estimated
    << ", \"density_pct\": " << json_number(e.density_pct())
    << ", \"bad1_pct\": " << json_number(e.all_pct(e.bad1))
    << ", \"bad2_pct\": " << json_number(e.all_pct(e.bad2))
    << ", \"bad4_pct\": " << json_number(e.all_pct(e.bad4))
    << ", \"d1_pct\": " << json_number(e.all_pct(e.d1))
    << ", \"bad1_est_pct\": " << json_number(e.estimated_pct(e.bad1))
    << ", \"bad2_est_pct\": " << json_number(e.estimated_pct(e.bad2))
    << ", \"bad4_est_pct\": " << json_number(e.estimated_pct(e.bad4))
    << ", \"d1_est_pct\": " << json_number(e.estimated_pct(e.d1))
    << ", \"mae_est_px\": " << json_number(e.mae_px()) << "}";
}

void append_method_json(std::ostringstream& j, const MethodResult& m) {
  j << "{\"method\": " << json_string(m.method) << ", \"time_ms\": " << json_number(m.time_ms)
    << ", ";
  append_errors_json(j, "all", m.all);
  if (m.noc.gt_pixels > 0) {
    j << ", ";
    append_errors_json(j, "noc", m.noc);
  }
  if (m.points.gt_pixels > 0) {
    j << ", \"points\": {\"gt_pixels\": " << m.points.gt_pixels;
    for (std::size_t k = 0; k < kPointRadiiM.size(); ++k)
      j << ", \"within_" << std::lround(100.0 * kPointRadiiM[k])
        << "cm_pct\": " << json_number(m.points.within_pct(k));
    j << "}";
  }
  j << "}";
}

std::string fixed(double v, int precision = 2) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(precision) << v;
  return s.str();
}

/// Width of the pair column: the longest pair name plus a space, at least 24.
int pair_column_width(const std::vector<PairResult>& pairs) {
  std::size_t longest = 23;
  for (const auto& pair : pairs) longest = std::max(longest, pair.pair.size());
  return static_cast<int>(longest) + 1;
}

void append_row(std::ostringstream& t, int width, const std::string& pair, const MethodResult& m) {
  const auto& a = m.all;
  t << std::left << std::setw(width) << pair << std::setw(18) << m.method << std::right
    << std::setw(7) << fixed(a.all_pct(a.bad1)) << std::setw(7) << fixed(a.all_pct(a.bad2))
    << std::setw(7) << fixed(a.all_pct(a.bad4)) << std::setw(7) << fixed(a.all_pct(a.d1))
    << std::setw(8) << fixed(a.density_pct(), 1) << " |" << std::setw(7)
    << fixed(a.estimated_pct(a.bad2)) << std::setw(7) << fixed(a.estimated_pct(a.d1))
    << std::setw(6) << fixed(a.mae_px()) << " |";
  const auto& n = m.noc;
  t << std::setw(7) << (n.gt_pixels > 0 ? fixed(n.all_pct(n.bad2)) : "-") << std::setw(7)
    << (n.gt_pixels > 0 ? fixed(n.all_pct(n.d1)) : "-") << " |" << std::setw(8)
    << fixed(m.time_ms, 1) << "\n";
}

void append_points_row(std::ostringstream& t, int width, const std::string& pair,
                       const MethodResult& m) {
  if (m.points.gt_pixels == 0) return;
  t << std::left << std::setw(width) << pair << std::setw(18) << m.method << std::right;
  for (std::size_t k = 0; k < kPointRadiiM.size(); ++k)
    t << std::setw(9) << fixed(m.points.within_pct(k));
  t << "\n";
}

}  // namespace

PointErrors& PointErrors::operator+=(const PointErrors& o) {
  gt_pixels += o.gt_pixels;
  for (std::size_t k = 0; k < within.size(); ++k) within[k] += o.within[k];
  return *this;
}

double PointErrors::within_pct(std::size_t k) const { return pct(within.at(k), gt_pixels); }

void for_each_point_distance(const cv::Mat& estimate, const cv::Mat& gt, const StereoCamera& camera,
                             const std::function<void(int u, int v, double distance_m)>& visit) {
  if (estimate.type() != CV_32F || gt.type() != CV_32F)
    throw InputError("evaluate_points: estimate and ground truth must be CV_32F disparity");
  if (estimate.size() != gt.size())
    throw InputError("evaluate_points: estimate is " + std::to_string(estimate.cols) + "x" +
                     std::to_string(estimate.rows) + " but ground truth is " +
                     std::to_string(gt.cols) + "x" + std::to_string(gt.rows));
  camera.validate("evaluate_points camera");
  const double fb = camera.fx * camera.baseline_m;  // Z(d) = f_x·B / d
  for (int y = 0; y < gt.rows; ++y) {
    const float* g = gt.ptr<float>(y);
    const float* d = estimate.ptr<float>(y);
    const double ry = (y - camera.cy) / camera.fy;
    for (int x = 0; x < gt.cols; ++x) {
      if (!(g[x] > 0.0f)) continue;
      if (!(d[x] > 0.0f)) {  // NaN or ≤ 0: no point
        visit(x, y, kNaN);
        continue;
      }
      const double rx = (x - camera.cx) / camera.fx;
      // ‖X(d) − X(d_gt)‖ = |Z(d) − Z(d_gt)|·‖(r_x, r_y, 1)‖ (both points lie on the pixel's ray).
      visit(x, y, std::abs(fb / d[x] - fb / g[x]) * std::sqrt(rx * rx + ry * ry + 1.0));
    }
  }
}

PointErrors evaluate_points(const cv::Mat& estimate, const cv::Mat& gt,
                            const StereoCamera& camera) {
  PointErrors e;
  for_each_point_distance(estimate, gt, camera, [&](int, int, double distance_m) {
    ++e.gt_pixels;
    for (std::size_t k = 0; k < kPointRadiiM.size(); ++k)
      e.within[k] += distance_m <= kPointRadiiM[k];  // false for NaN
  });
  return e;
}

AccuracyCurve::AccuracyCurve(double max_m, int steps) : max_m_(max_m) {
  if (!(max_m > 0.0) || steps < 1)
    throw ConfigError("accuracy curve: need max_m > 0 and steps >= 1, got max_m " +
                      std::to_string(max_m) + ", steps " + std::to_string(steps));
  bins_.assign(static_cast<std::size_t>(steps) + 1, 0);
}

double AccuracyCurve::threshold_m(int k) const {
  return max_m_ * static_cast<double>(k) / static_cast<double>(steps());
}

void AccuracyCurve::add(double distance_m) {
  ++gt_pixels_;
  if (!std::isfinite(distance_m)) return;
  ++with_point_;
  if (distance_m > max_m_) return;
  // The smallest k with distance ≤ x_k: the rounded guess, corrected against the exact thresholds
  // (so that within(k) agrees with a direct "distance ≤ x_k" test, e.g. evaluate_points').
  int k = std::clamp(static_cast<int>(std::ceil(distance_m / max_m_ * steps())), 0, steps());
  while (k > 0 && distance_m <= threshold_m(k - 1)) --k;
  while (k < steps() && distance_m > threshold_m(k)) ++k;
  ++bins_[static_cast<std::size_t>(k)];
}

AccuracyCurve& AccuracyCurve::operator+=(const AccuracyCurve& other) {
  if (other.bins_.size() != bins_.size() || other.max_m_ != max_m_)
    throw ConfigError("accuracy curve: cannot add curves on different grids");
  for (std::size_t k = 0; k < bins_.size(); ++k) bins_[k] += other.bins_[k];
  gt_pixels_ += other.gt_pixels_;
  with_point_ += other.with_point_;
  return *this;
}

long AccuracyCurve::within(int k) const {
  const int last = std::clamp(k, -1, steps());
  long count = 0;
  for (int i = 0; i <= last; ++i) count += bins_[static_cast<std::size_t>(i)];
  return count;
}

double AccuracyCurve::within_pct(int k) const { return pct(within(k), gt_pixels_); }
double AccuracyCurve::density_pct() const { return pct(with_point_, gt_pixels_); }

AccuracyCurve point_accuracy_curve(const cv::Mat& estimate, const cv::Mat& gt,
                                   const StereoCamera& camera, double max_m, int steps) {
  AccuracyCurve curve(max_m, steps);
  for_each_point_distance(estimate, gt, camera,
                          [&](int, int, double distance_m) { curve.add(distance_m); });
  return curve;
}

DisparityErrors& DisparityErrors::operator+=(const DisparityErrors& o) {
  gt_pixels += o.gt_pixels;
  estimated += o.estimated;
  bad1 += o.bad1;
  bad2 += o.bad2;
  bad4 += o.bad4;
  d1 += o.d1;
  abs_error_sum_px += o.abs_error_sum_px;
  return *this;
}

double DisparityErrors::density_pct() const { return pct(estimated, gt_pixels); }
double DisparityErrors::all_pct(long outliers) const {
  return pct(outliers + (gt_pixels - estimated), gt_pixels);
}
double DisparityErrors::estimated_pct(long outliers) const { return pct(outliers, estimated); }
double DisparityErrors::mae_px() const {
  return estimated == 0 ? kNaN : abs_error_sum_px / static_cast<double>(estimated);
}

DisparityErrors evaluate_disparity(const cv::Mat& estimate, const cv::Mat& gt) {
  if (estimate.type() != CV_32F || gt.type() != CV_32F)
    throw InputError("evaluate_disparity: estimate and ground truth must be CV_32F disparity");
  if (estimate.size() != gt.size())
    throw InputError("evaluate_disparity: estimate is " + std::to_string(estimate.cols) + "x" +
                     std::to_string(estimate.rows) + " but ground truth is " +
                     std::to_string(gt.cols) + "x" + std::to_string(gt.rows));
  DisparityErrors e;
  for (int y = 0; y < gt.rows; ++y) {
    const float* g = gt.ptr<float>(y);
    const float* d = estimate.ptr<float>(y);
    for (int x = 0; x < gt.cols; ++x) {
      if (!(g[x] > 0.0f)) continue;  // NaN or ≤ 0: no ground truth
      ++e.gt_pixels;
      if (std::isnan(d[x])) continue;
      ++e.estimated;
      const double err = std::abs(static_cast<double>(d[x]) - g[x]);
      e.abs_error_sum_px += err;
      e.bad1 += err > 1.0;
      e.bad2 += err > 2.0;
      e.bad4 += err > 4.0;
      e.d1 += err > 3.0 && err > 0.05 * g[x];
    }
  }
  return e;
}

cv::Mat opencv_sgbm_disparity(const cv::Mat& left, const cv::Mat& right, int max_disparity,
                              int mode) {
  const int channels = left.channels();
  auto sgbm = cv::StereoSGBM::create(
      0, (max_disparity + 15) / 16 * 16, kSgbmBlock, 8 * channels * kSgbmBlock * kSgbmBlock,
      32 * channels * kSgbmBlock * kSgbmBlock, 1, 0, 10, 100, 2, mode);
  cv::Mat fixed_point;
  sgbm->compute(left, right, fixed_point);
  cv::Mat disparity;
  fixed_point.convertTo(disparity, CV_32F, 1.0 / 16.0);
  // OpenCV marks unmatched pixels < 0; disparity 0 (infinite depth) is invalid here too.
  disparity.setTo(std::numeric_limits<float>::quiet_NaN(), fixed_point <= 0);
  return disparity;
}

std::vector<StereoMethod> default_stereo_methods(const SgmConfig& sgm,
                                                 const ExtractionConfig& extraction) {
  std::vector<StereoMethod> methods;
  std::ostringstream p;
  p << "census " << sgm.census_width << "x" << sgm.census_height << ", lambda_grad "
    << sgm.lambda_grad << ", grad_cap " << sgm.grad_cap << ", " << sgm.paths << " paths, P1 "
    << sgm.p1 << ", P2 " << sgm.p2 << (sgm.p2_adaptive ? " (adaptive)" : "") << ", uniqueness "
    << sgm.uniqueness_ratio << "%, LR " << (sgm.lr_check ? "on" : "off") << ", speckle "
    << sgm.speckle_window_size << "/" << sgm.speckle_range_px << ", threads " << sgm.threads;
  methods.push_back({"planecell-sgm", p.str(), [sgm](const io::StereoSample& s) {
                       SgmConfig c = sgm;
                       c.max_disparity = std::min(s.max_disparity, s.left.cols - 1);
                       return stereo::compute_disparity(s.left, s.right, c);
                     }});
  const std::string sgbm_params =
      "blockSize 5, P1 8*3*5^2, P2 32*3*5^2, uniquenessRatio 10, speckle 100/2, disp12MaxDiff 1";
  methods.push_back({"opencv-sgbm", "MODE_SGBM, " + sgbm_params, [](const io::StereoSample& s) {
                       return opencv_sgbm_disparity(s.left, s.right, s.max_disparity,
                                                    cv::StereoSGBM::MODE_SGBM);
                     }});
  methods.push_back(
      {"opencv-sgbm-3way", "MODE_SGBM_3WAY, " + sgbm_params, [](const io::StereoSample& s) {
         return opencv_sgbm_disparity(s.left, s.right, s.max_disparity,
                                      cv::StereoSGBM::MODE_SGBM_3WAY);
       }});
  std::ostringstream q;
  q << "dense plane disparity of extract_planecells on planecell-sgm: " << extraction.target_cells
    << " cells, lambda_reg " << extraction.lambda_reg << ", lambda_depth "
    << extraction.lambda_depth << ", RANSAC " << extraction.ransac_iterations << " x "
    << extraction.inlier_threshold_px << " px";
  methods.push_back({"planecell", q.str(), [sgm, extraction](const io::StereoSample& s) {
                       SgmConfig c = sgm;
                       c.max_disparity = std::min(s.max_disparity, s.left.cols - 1);
                       const cv::Mat raw = stereo::compute_disparity(s.left, s.right, c);
                       return extraction::extract_planecells(
                                  s.left, s.right, raw, s.camera.value_or(StereoCamera{}), extraction)
                           .dense_disparity;
                     }});
  return methods;
}

PairResult evaluate_pair(const io::StereoSample& sample, const std::vector<StereoMethod>& methods) {
  PairResult result;
  result.pair = sample.name;
  result.max_disparity = sample.max_disparity;
  for (const auto& method : methods) {
    MethodResult m;
    m.method = method.name;
    const auto start = std::chrono::steady_clock::now();
    const cv::Mat disparity = method.run(sample);
    m.time_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    m.all = evaluate_disparity(disparity, sample.gt_disparity);
    if (!sample.gt_disparity_noc.empty())
      m.noc = evaluate_disparity(disparity, sample.gt_disparity_noc);
    if (sample.camera) m.points = evaluate_points(disparity, sample.gt_disparity, *sample.camera);
    result.methods.push_back(m);
  }
  return result;
}

std::vector<MethodResult> pooled_results(const std::vector<PairResult>& pairs,
                                         const std::vector<StereoMethod>& methods) {
  std::vector<MethodResult> total(methods.size());
  for (std::size_t k = 0; k < methods.size(); ++k) total[k].method = methods[k].name;
  for (const auto& pair : pairs)
    for (std::size_t k = 0; k < pair.methods.size() && k < total.size(); ++k) {
      total[k].time_ms += pair.methods[k].time_ms / static_cast<double>(pairs.size());
      total[k].all += pair.methods[k].all;
      total[k].noc += pair.methods[k].noc;
      total[k].points += pair.methods[k].points;
    }
  return total;
}

namespace {

/// "boundary recall 91.2 % (n/m), cells on one surface 88.0 % (k/c)".
std::string segmentation_summary(const SegmentationScores& s) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(1) << "boundary recall " << s.boundary_recall_pct()
    << " % (" << s.recalled_boundary_pixels << "/" << s.gt_boundary_pixels
    << "), cells on one surface " << s.single_surface_pct() << " % (" << s.single_surface_cells
    << "/" << s.cells << ")";
  return o.str();
}

/// The planecell segmentation lines of the pairs that have them, then their pooled figures.
void append_segmentation_lines(std::ostringstream& t, int width, const std::vector<PairResult>& pairs) {
  SegmentationScores total;
  bool any = false;
  for (const auto& pair : pairs) {
    if (!pair.segmentation) continue;
    if (!any) {
      const SegmentationOptions defaults;
      t << "\nPlanecell segmentation vs GT surfaces: GT boundary pixels with a cell boundary "
           "within "
        << defaults.boundary_tolerance_px << " px, cells with >= "
        << std::lround(100 * defaults.purity) << " % of their pixels on one surface.\n\n";
    }
    any = true;
    total += *pair.segmentation;
    t << std::left << std::setw(width) << pair.pair << std::right
      << segmentation_summary(*pair.segmentation) << "\n";
  }
  if (any)
    t << std::left << std::setw(width) << "OVERALL (pooled)" << std::right
      << segmentation_summary(total) << "\n";
}

/// {"boundary_recall_pct": …, …} (NaN as null).
std::string segmentation_json(const SegmentationScores& s) {
  auto number = [](double x) {
    std::ostringstream o;
    if (std::isfinite(x)) o << x;
    else o << "null";
    return o.str();
  };
  std::ostringstream j;
  j << "{\"boundary_recall_pct\": " << number(s.boundary_recall_pct())
    << ", \"gt_boundary_pixels\": " << s.gt_boundary_pixels
    << ", \"recalled_boundary_pixels\": " << s.recalled_boundary_pixels
    << ", \"single_surface_cells_pct\": " << number(s.single_surface_pct())
    << ", \"cells\": " << s.cells << ", \"single_surface_cells\": " << s.single_surface_cells
    << "}";
  return j.str();
}

}  // namespace

std::string format_table(const std::vector<PairResult>& pairs,
                         const std::vector<StereoMethod>& methods) {
  std::ostringstream t;
  t << "Methods:\n";
  for (const auto& m : methods) t << "  " << m.name << ": " << m.parameters << "\n";
  t << "Figures in %, over all GT pixels (a missing estimate counts as an error) | over the\n"
       "estimated pixels only (MAE in px) | non-occluded GT (when the dataset has it) | time.\n"
       "bad-t: |d - d_gt| > t px (GT pixel units); D1: > 3 px and > 5 % of d_gt (KITTI).\n\n";
  const int width = pair_column_width(pairs);
  t << std::left << std::setw(width) << "pair" << std::setw(18) << "method" << std::right
    << std::setw(7) << "bad1" << std::setw(7) << "bad2" << std::setw(7) << "bad4" << std::setw(7)
    << "D1" << std::setw(8) << "dens"
    << " |" << std::setw(7) << "bad2e" << std::setw(7) << "D1e" << std::setw(6) << "MAE"
    << " |" << std::setw(7) << "noc:b2" << std::setw(7) << "noc:D1"
    << " |" << std::setw(8) << "ms"
    << "\n";
  for (const auto& pair : pairs)
    for (const auto& m : pair.methods) append_row(t, width, pair.pair, m);
  t << "\n";
  const auto total = pooled_results(pairs, methods);
  for (const auto& m : total) append_row(t, width, "OVERALL (pooled px)", m);
  bool any_points = false;
  for (const auto& m : total) any_points |= m.points.gt_pixels > 0;
  if (any_points) {
    t << "\n3D accuracy (paper Table 1), pairs with a camera: % of all GT pixels whose point\n"
         "X(u, v, d) lies within r of the GT point X(u, v, d_gt) (missing counts as outside).\n\n";
    t << std::left << std::setw(width) << "pair" << std::setw(18) << "method" << std::right;
    for (double r : kPointRadiiM)
      t << std::setw(9) << ("<=" + std::to_string(std::lround(100 * r)) + "cm");
    t << "\n";
    for (const auto& pair : pairs)
      for (const auto& m : pair.methods) append_points_row(t, width, pair.pair, m);
    t << "\n";
    for (const auto& m : total) append_points_row(t, width, "OVERALL (pooled px)", m);
    t << std::left << std::setw(width) << "paper Table 1" << std::setw(18) << "SGBM + planecell" << std::right;
    for (double pct : kPaperTable1SgbmPct) t << std::setw(9) << fixed(pct);
    t << "   (its own KITTI frames: the row to beat)\n";
  }
  append_segmentation_lines(t, width, pairs);
  return t.str();
}

std::string format_json(const std::string& dataset, const std::vector<PairResult>& pairs,
                        const std::vector<StereoMethod>& methods) {
  std::ostringstream j;
  j << "{\"dataset\": " << json_string(dataset) << ",\n \"methods\": [";
  for (std::size_t k = 0; k < methods.size(); ++k)
    j << (k ? ", " : "") << "{\"name\": " << json_string(methods[k].name)
      << ", \"parameters\": " << json_string(methods[k].parameters) << "}";
  j << "],\n \"pairs\": [";
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    j << (i ? ",\n  " : "\n  ") << "{\"pair\": " << json_string(pairs[i].pair)
      << ", \"max_disparity\": " << pairs[i].max_disparity << ", \"results\": [";
    for (std::size_t k = 0; k < pairs[i].methods.size(); ++k) {
      if (k) j << ", ";
      append_method_json(j, pairs[i].methods[k]);
    }
    j << "]";
    if (pairs[i].segmentation)
      j << ", \"segmentation\": " << segmentation_json(*pairs[i].segmentation);
    j << "}";
  }
  j << "],\n \"overall\": [";
  const auto total = pooled_results(pairs, methods);
  for (std::size_t k = 0; k < total.size(); ++k) {
    if (k) j << ", ";
    append_method_json(j, total[k]);
  }
  j << "]";
  SegmentationScores segmentation;
  bool any_segmentation = false;
  for (const auto& pair : pairs)
    if (pair.segmentation) {
      segmentation += *pair.segmentation;
      any_segmentation = true;
    }
  if (any_segmentation) j << ",\n \"segmentation_overall\": " << segmentation_json(segmentation);
  j << "}\n";
  return j.str();
}

}  // namespace planecell::services::eval
