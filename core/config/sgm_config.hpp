#pragma once
/// Configuration of the SGM disparity stage (mapping/stereo).
#include <string>

namespace planecell {

/// SGM (paper Eq. 1–2): Census + gradient matching cost, 8- or 4-path aggregation.
///
/// Cost scale (Eq. 1): C(p, d) = H(T_L(p), T_R(p − d)) + λ_grad · min(|G_L(p) − G_R(p − d)|,
/// grad_cap), with H the Hamming distance of census descriptors (0 … census_w·census_h − 1) and
/// G the horizontal (epipolar) Sobel derivative of the grey image divided by 4 (grey levels/px).
/// P1/P2 are in the same unit.
struct SgmConfig {
  int max_disparity = 128;  ///< number of disparities searched, d ∈ [0, max_disparity)
  int threads = 2;          ///< worker threads for cost + aggregation (aggregation uses ≤ 2)

  // Matching cost (Eq. 1).
  int census_width = 9;     ///< census window width (odd, width·height ≤ 65)
  int census_height = 7;    ///< census window height (odd)
  double lambda_grad = 0.5;  ///< λ_grad, weight of the gradient term
  int grad_cap = 30;        ///< truncation of |G_L − G_R| (grey levels/px)
  /// Cost of a disparity whose match falls left of the right image (x − d < 0), as a share of the
  /// largest cost C_max = census_w·census_h − 1 + λ_grad·grad_cap (77 at the defaults). Such a
  /// match is unobservable, not wrong. At C_max (1.0) the paths pushed the left border strip
  /// (x < true d) towards the few disparities still inside the image, and the planes fitted there
  /// inherited them. Near the cost of an ordinary match, the paths carry the neighbours' disparity
  /// into the strip instead. 0.3 (23 of 77, about a third of the census bits differing) gave lower
  /// error on every Middlebury and KITTI sample and the synthetic street, raw SGM and planes alike
  /// (docs/PERFORMANCE.md, "Left border"). 0.25–0.35 are within noise of each other; 0 lets
  /// impossible disparities win.
  double out_of_image_cost = 0.3;

  // Aggregation (Eq. 2).
  int paths = 8;            ///< 8 (all directions) or 4 (horizontal + vertical)
  int p1 = 10;              ///< penalty for |Δd| = 1 between neighbours
  int p2 = 120;             ///< penalty for |Δd| > 1 (≤ 7900 so that 8 paths fit in 16 bits)
  bool p2_adaptive = true;  ///< P2' = max(P1, P2 − p2_slope·|I(p) − I(p − r)|)
  double p2_slope = 2.0;    ///< P2 decrease per grey level of intensity step along the path

  // Post-processing.
  bool subpixel = true;          ///< parabola fit through S(d−1), S(d), S(d+1)
  /// %, reject when the second best (|Δd| > 1) is within this margin; 0 = off. Off by default:
  /// on all Middlebury + KITTI samples together it removed more good pixels than bad ones.
  int uniqueness_ratio = 0;
  /// 3×3 median of the winner maps before the left-right check (Hirschmüller 2008, §3.4): the
  /// output disparity, and the integer left and right winners the check compares, are each
  /// replaced by the median of their 3×3 neighbourhood. An isolated wrong winner on either side
  /// then no longer rejects a correct pixel, nor survives as an outlier. On the Middlebury,
  /// KITTI, Scene Flow and synthetic samples it lowered the raw SGM's all-pixel error on every
  /// pair and its error on the estimated pixels; the planes fitted on it gained on Middlebury and
  /// kitti2012 and lost ≤ 0.1 point on kitti2015 and the synthetic street (docs/PERFORMANCE.md,
  /// "Median").
  bool median_filter = true;
  bool lr_check = true;          ///< left-right consistency from the same aggregated volume
  int lr_max_diff_px = 2;        ///< |d_L(x) − d_R(x − d_L)| allowed
  int speckle_window_size = 100; ///< max region size (px) removed by cv::filterSpeckles; 0 = off
  double speckle_range_px = 2.0; ///< max disparity step inside one speckle region

  // Resource limits, checked before anything is allocated (ConfigError / InputError).
  int max_disparity_limit = 1024;       ///< sanity bound on max_disparity (px)
  double max_image_pixels = 64e6;       ///< larger input images are refused (W·H, pixels)
  double max_cost_volume_mb = 4096.0;   ///< W·H·max_disparity bytes (the cost volume, MiB)
};

template <class Visitor>
void visit_fields(SgmConfig& c, Visitor&& visit) {
  visit("max_disparity", c.max_disparity);
  visit("threads", c.threads);
  visit("census_width", c.census_width);
  visit("census_height", c.census_height);
  visit("lambda_grad", c.lambda_grad);
  visit("grad_cap", c.grad_cap);
  visit("out_of_image_cost", c.out_of_image_cost);
  visit("paths", c.paths);
  visit("p1", c.p1);
  visit("p2", c.p2);
  visit("p2_adaptive", c.p2_adaptive);
  visit("p2_slope", c.p2_slope);
  visit("subpixel", c.subpixel);
  visit("uniqueness_ratio", c.uniqueness_ratio);
  visit("median_filter", c.median_filter);
  visit("lr_check", c.lr_check);
  visit("lr_max_diff_px", c.lr_max_diff_px);
  visit("speckle_window_size", c.speckle_window_size);
  visit("speckle_range_px", c.speckle_range_px);
  visit("max_disparity_limit", c.max_disparity_limit);
  visit("max_image_pixels", c.max_image_pixels);
  visit("max_cost_volume_mb", c.max_cost_volume_mb);
}

}  // namespace planecell
