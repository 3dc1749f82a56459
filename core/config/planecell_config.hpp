#pragma once
/// Configuration of planecell extraction (mapping/planecell).

namespace planecell {

/// Depth-aware superpixels + RANSAC planes + vertices (paper §4.2–5.1).
///
/// Superpixel energy (paper Eq. 4): E(S) = H(S) + λ_reg·R(S) + λ_depth·D(S), evaluated per
/// boundary block b through the block costs  c1(S_i, b) = Σ_q min(h_{S_i}(q), h_b(q))  and
///   c2(S_i, b) = λ_reg·‖μ_{S_i} − b‖²/s² + λ_depth·min((θ_{S_i}(b) − d̄_b)², τ²)/τ²,
/// with s = ⌊√(|I|/|S|)⌋ the initial cell size and τ = depth_truncation_px; a block moves to the
/// neighbouring segment with the highest c1 − c2.
struct ExtractionConfig {
  int target_cells = 800;         ///< |S|, the number of planecells asked for
  int block_levels = 3;           ///< block levels l = 2, 4, 8, … (size s/l) before the pixel level
  int iterations_per_level = 2;   ///< hill-climbing sweeps per block level
  int pixel_iterations = 2;       ///< sweeps at the pixel level (colour + regularisation)
  int depth_iterations = 1;       ///< sweeps per level of the depth-aware boundary update
  double max_time_ms = 0.0;       ///< hill-climbing time bound (0 = bounded by iterations only)
  double lambda_reg = 0.4;        ///< λ_reg, weight of the position term (per s²)
  double lambda_depth = 0.8;      ///< λ_depth, weight of the truncated plane residual
  double depth_truncation_px = 3.0;  ///< τ: the plane residual saturates here (px)
  int ransac_iterations = 30;        ///< RANSAC hypotheses per segment (upper bound)
  double inlier_threshold_px = 1.0;  ///< |θ(p) − d(p)| below this = inlier (px)
  double target_inlier_ratio = 0.9;  ///< stop RANSAC once this share of valid pixels are inliers
  double min_inlier_ratio = 0.5;     ///< below this share the fit fails (segment planeless)
  int min_valid_pixels = 12;         ///< fewer valid disparities → no plane
  double min_valid_ratio = 0.1;      ///< share of the segment's pixels that must be valid
  bool junction_vertices_only = true; ///< polygons through junctions only (compact; see vertices)
  double polygon_tolerance_px = 1.0; ///< Douglas–Peucker tolerance otherwise (0 = every corner)
  bool fill_planeless = true;  ///< dense disparity of planeless cells from the farther neighbour
  bool background_fill_holes = false;  ///< input holes between two cells take the farther plane
  int random_seed = 1;         ///< RANSAC sampling seed (results are deterministic)
  /// Photometric refinement of each plane against the stereo pair (extraction/photometric_planes;
  /// only where the right image is passed): Levenberg–Marquardt steps per cell, 0 = off. Off by
  /// default (config/synthetic.yaml sets 5): it removes SGM's slant bias from the synthetic
  /// street's road (bottom rows −1.4 → −0.1 px) and lowers the pose refinement's drift on most
  /// streets, but costs ~8 ms per 1242×375 frame and raised bad-2 by 0.06–0.25 points on the KITTI
  /// and Middlebury samples (docs/PERFORMANCE.md, "Photometric planes").
  int photometric_iterations = 0;
  int photometric_sample_step = 2;           ///< every n-th pixel in u and v
  double photometric_min_gradient = 0.5;     ///< textured samples only (grey levels / px along u)
  double photometric_huber_grey = 8.0;       ///< Huber threshold (grey levels)
  double photometric_max_shift_px = 8.0;     ///< a refinement moving the plane farther is refused
  double photometric_min_cost_ratio = 0.3;   ///< ... and one lowering the cost less than this
};

template <class Visitor>
void visit_fields(ExtractionConfig& c, Visitor&& visit) {
  visit("target_cells", c.target_cells);
  visit("block_levels", c.block_levels);
  visit("iterations_per_level", c.iterations_per_level);
  visit("pixel_iterations", c.pixel_iterations);
  visit("depth_iterations", c.depth_iterations);
  visit("max_time_ms", c.max_time_ms);
  visit("lambda_reg", c.lambda_reg);
  visit("lambda_depth", c.lambda_depth);
  visit("depth_truncation_px", c.depth_truncation_px);
  visit("ransac_iterations", c.ransac_iterations);
  visit("inlier_threshold_px", c.inlier_threshold_px);
  visit("target_inlier_ratio", c.target_inlier_ratio);
  visit("min_inlier_ratio", c.min_inlier_ratio);
  visit("min_valid_pixels", c.min_valid_pixels);
  visit("min_valid_ratio", c.min_valid_ratio);
  visit("junction_vertices_only", c.junction_vertices_only);
  visit("polygon_tolerance_px", c.polygon_tolerance_px);
  visit("fill_planeless", c.fill_planeless);
  visit("background_fill_holes", c.background_fill_holes);
  visit("random_seed", c.random_seed);
  visit("photometric_iterations", c.photometric_iterations);
  visit("photometric_sample_step", c.photometric_sample_step);
  visit("photometric_min_gradient", c.photometric_min_gradient);
  visit("photometric_huber_grey", c.photometric_huber_grey);
  visit("photometric_max_shift_px", c.photometric_max_shift_px);
  visit("photometric_min_cost_ratio", c.photometric_min_cost_ratio);
}

}  // namespace planecell
