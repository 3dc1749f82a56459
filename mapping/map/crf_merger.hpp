#pragma once
/// Incremental CRF merging of coplanar planecells into surfaces (paper §5.2, Eq. CRFFunction):
///   E = Σ_i δ_i(y_i) + Σ_{j∈N(i)} φ_ij(y_i, y_j) + Σ_{c∈B(i)} ψ_i(y_c),
/// maximised by the paper's circular greedy merging within a variation range (MapConfig).
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <span>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/config/map_config.hpp"
#include "core/planecell.hpp"

namespace planecell::map {

/// Two segments that touch in a label image, with the length of their shared boundary.
struct LabelEdge {
  std::uint32_t a = 0;  ///< smaller label
  std::uint32_t b = 0;  ///< larger label
  std::uint32_t boundary_px = 0;  ///< 4-connected pixel pairs (a, b) across the boundary
  bool operator==(const LabelEdge&) const = default;
};

/// Adjacent label pairs of a CV_32S label image (negative labels = no segment, ignored).
/// boundary_px counts horizontally and vertically neighbouring pixel pairs with labels {a, b}.
/// Sorted by (a, b). Throws InputError if `labels` is empty or not CV_32S.
std::vector<LabelEdge> label_adjacency(const cv::Mat& labels);

/// Unary δ: histogram intersection δ(h_a, h_b) = Σ_q min(h_a(q), h_b(q)) ∈ [0, 1] for histograms
/// normalised to sum 1 (1 = identical colour distributions).
double colour_similarity(const ColourHistogram& a, const ColourHistogram& b);

/// Chromaticity of a histogram's mean colour m: m / (m_R + m_G + m_B), with m = Σ_q h(q)·c(q) /
/// Σ_q h(q) over the bin centres c(q), one level l = 0..3 per channel at 31.5 + 64·l (bin
/// q = 16·l_R + 4·l_G + l_B, mapping/planecell's soft bins). Soft binning splits a value linearly
/// between its two nearest centres, so m is the members' exact mean RGB for values in
/// [31.5, 223.5] (darker or brighter ones count at the end centres). Scaling R, G and B alike
/// (shading, a texture's grey modulation) leaves it unchanged. Grey (⅓, ⅓, ⅓) for an empty histogram.
Eigen::Vector3d histogram_chromaticity(const ColourHistogram& histogram);

/// Two chromaticities of different paint: farther apart (Euclidean) than max_distance, when that
/// is > 0 (MapConfig::max_chromaticity_distance; 0 = every pair one paint).
inline bool other_paint(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double max_distance) {
  return max_distance > 0.0 && (a - b).norm() > max_distance;
}

/// θ'_i(x_j): RMS distance of x_j's polygon vertices to x_i's plane, in units of σ:
///   θ'_i(x_j) = sqrt( (1/K) Σ_k (n_i·v_jk + e_i)² ) / σ   (dimensionless; σ = residual_scale_m).
double plane_residual(const Plane3& plane_i, std::span<const Eigen::Vector3f> vertices_j,
                      double sigma_m);

/// Pairwise φ_ij = |x_i ∪ x_j| / (θ'_i(x_j)² + θ'_j(x_i)² + 1), |x_i ∪ x_j| = area_i + area_j (m²).
double pose_potential(double area_i_m2, double area_j_m2, double theta_ij, double theta_ji);

/// Boundary ψ = |c| / (θ'(c)² + 1): |c| the shared boundary length (m), θ'(c) the step between the
/// two planes across the boundary, |d_i(m) − s·d_j(m)| / σ at the boundary point m (the midpoint
/// of the closest vertex pair; d the signed plane distances, s = sign(n_i·n_j)).
double boundary_potential(double boundary_m, double theta_c);

/// Disjoint-set forest over surface labels (path halving; the smaller label becomes the root, so
/// older surfaces absorb newer ones).
class UnionFind {
 public:
  std::uint32_t find(std::uint32_t label);
  /// Joins the sets of a and b; returns the surviving root.
  std::uint32_t unite(std::uint32_t a, std::uint32_t b);

 private:
  std::unordered_map<std::uint32_t, std::uint32_t> parent_;
};

/// Weighted second moments of the vertices behind a label: the plane is their least-squares fit.
/// The map weights each cell by its information w = area / σ² (σ the cell's depth noise, floored
/// at MapConfig::residual_scale_m), so a far, noisy cell barely moves a precise surface's plane.
struct PlaneMoments {
  double weight = 0.0;                                   ///< Σ w
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();         ///< Σ w p
  Eigen::Matrix3d sum_outer = Eigen::Matrix3d::Zero();   ///< Σ w p pᵀ

  /// Adds a polygon with total weight `weight` spread evenly over its vertices.
  void add_polygon(std::span<const Eigen::Vector3f> vertices, double weight);
  void add(const PlaneMoments& other);
  /// Least-squares plane: normal = smallest eigenvector of the weighted scatter Σw(p−p̄)(p−p̄)ᵀ,
  /// oriented like `orientation` (n·orientation ≥ 0), offset e = −n·p̄.
  Plane3 fit(const Eigen::Vector3d& orientation) const;
  /// Weighted RMS distance of the moments' points to `plane`, exactly from the moments:
  ///   E_w[(n·p + e)²] = (nᵀ(Σ w p pᵀ)n + 2e·n·(Σ w p) + e²·Σ w) / Σ w.
  double rms_distance_m(const Plane3& plane) const;
  bool operator==(const PlaneMoments&) const = default;
};

/// Effective depth noise of observations with information-weighted moments `moments`
/// (weight Σ area_i / σ_i²) covering Σ area_i = observed_area_m2:
///   σ_eff = √(Σ area_i / Σ (area_i / σ_i²)) (m), the area-weighted harmonic mean of the σ², 0 when
/// there is no weight.
double effective_sigma_m(const PlaneMoments& moments, double observed_area_m2);
/// The same from the information Σ (area_i / σ_i²) alone: √(observed_area_m2 / information).
double effective_sigma_m(double information, double observed_area_m2);

/// State of one label during merging (a surface of the map or a fresh label of a new cell).
struct LabelState {
  Plane3 plane;
  PlaneMoments moments;         ///< information-weighted (moments.weight = Σ area_i / σ_i²)
  ColourHistogram histogram{};  ///< weighted mean of the members' histograms
  /// histogram_chromaticity(histogram), kept with it (state_of_cell, fold_label and the map's
  /// surface states set both): the variation range compares it for every edge.
  Eigen::Vector3d chromaticity = Eigen::Vector3d::Constant(1.0 / 3.0);
  double histogram_weight_m2 = 0.0;
  double area_m2 = 0.0;           ///< area the label covers (a surface: its footprint)
  double observed_area_m2 = 0.0;  ///< Σ area_i of every member observation
  std::uint32_t cells = 0;        ///< member observations (a mature label has ≥ MapConfig::mature_cells)
  /// Σ area_i / ρ_i² over the members, ρ_i the noise the variation range is widened by (a new
  /// cell's noise along its plane normal, MapConfig::normal_depth_noise); 0 = moments.weight.
  double range_information = 0.0;
  /// Angular noise of the label's normal (rad): a new cell's κ·σ_θ (MapConfig::normal_sigma_scale),
  /// members combined as 1/√Σ σ⁻²; 0 = exact (stored surfaces, cells without σ_θ).
  double tilt_sigma_rad = 0.0;

  /// Effective depth noise of the label, σ_eff = √(Σ area_i / Σ (area_i / σ_i²)) (m): the
  /// area-weighted harmonic mean of the members' σ², dominated by its most precise cells.
  double sigma_m() const;
  /// The same mean of the range noise, ρ_eff = √(Σ area_i / range_information); σ_eff when
  /// range_information is 0. The variation range widens by it.
  double range_sigma_m() const;
};

/// A planecell taking part in a merge (world frame), with its current label.
struct MergeUnit {
  std::uint32_t label = 0;
  Plane3 plane;
  std::span<const Eigen::Vector3f> vertices;
  /// The cell's own colour histogram (a new cell); nullptr for a stored cell, whose colour evidence
  /// is its label's (the map keeps colour per surface, not per cell).
  const ColourHistogram* histogram = nullptr;
  double area_m2 = 0.0;
};

/// A neighbour pair of units (indices into the unit list) with its shared boundary length.
struct MergeEdge {
  std::uint32_t a = 0;
  std::uint32_t b = 0;
  double boundary_m = 0.0;
};

/// Energy terms of merging an edge's two labels, and whether the pair is inside the variation range.
struct EdgeEvaluation {
  bool in_range = false;
  double angle_deg = 0.0;         ///< between the two labels' plane normals
  double distance_m = 0.0;        ///< RMS distance of the less-informed label's points to the
                                  ///< better-informed label's plane
  double colour_similarity = 0.0; ///< Σ_q min(h_lo[q], h_hi[q]) of the two labels' histograms;
                                  ///< 0 (not computed) when the planes are out of range
  double gain = 0.0;              ///< δ_a + δ_b + φ + ψ: energy gained by giving both one label
};

/// The circular greedy maximiser of E.
class CrfMerger {
 public:
  explicit CrfMerger(const MapConfig& config);

  /// Evaluates an edge under the current labels' states. The variation range is asymmetric: the
  /// label with less information (lo) must lie on the plane of the one with more (hi):
  ///   rms_w(lo → hi.plane) ≤ max(max_plane_distance_m, k·σ_eff(lo)),
  ///   ∠(n_lo, n_hi) ≤ max_normal_angle_deg + min(max_normal_angle_deg, atan(k·σ_eff(lo)/√area_lo)),
  /// and, when lo holds at least mutual_information_fraction of hi's information, the same with
  /// the roles swapped; colour δ(h_lo, h_hi) ≥ min_colour_similarity. A label whose normal is
  /// uncertain (LabelState::tilt_sigma_rad = κσ_θ > 0) gets its angle range widened by k·κσ_θ, up
  /// to max_noisy_normal_angle_deg. Two mature labels (both
  /// with ≥ mature_cells members) must be parallel within max_normal_angle_deg (widened by
  /// k·√(κσ_lo² + κσ_hi²), with the same cap) and continuous at
  /// their boundary: the step |d_hi(m) − s·d_lo(m)| between the planes at the midpoint m of the
  /// edge's two cell centroids ≤ max_plane_distance_m, never widened by noise. One noisy cell can
  /// join a surface, but cannot bridge two surfaces that are not on one plane themselves.
  EdgeEvaluation evaluate(const MergeUnit& a, const LabelState& label_a, const MergeUnit& b,
                          const LabelState& label_b, double boundary_m) const;

  /// Circular greedy merging: each round evaluates every edge whose units carry different labels,
  /// visits them by decreasing gain, and merges (union-find) those still inside the variation
  /// range under the labels' updated planes; rounds repeat until one merges nothing. Rounds after
  /// the first evaluate only the edges touching a label that changed in the round before: the
  /// others were out of range on the same label states (same merges as evaluating them all).
  /// `labels` holds the state of every label used by `units` and is updated in place (a merged
  /// label's state is folded into its root's). Returns the merges as (absorbed, root) pairs in order.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> merge(
      std::span<const MergeUnit> units, std::span<const MergeEdge> edges,
      std::unordered_map<std::uint32_t, LabelState>& labels, UnionFind& union_find) const;

  /// evaluate() without the gain (0): all the greedy needs to re-check an edge whose labels
  /// changed since the round's evaluation, and all GlobalMap needs to find a re-observation.
  EdgeEvaluation evaluate_range(const MergeUnit& a, const LabelState& label_a, const MergeUnit& b,
                                const LabelState& label_b) const;

  const MapConfig& config() const { return config_; }

 private:
  MapConfig config_;
};

/// The one-cell label of a world-frame cell of area `area_m2`: moments weighted by area / σ² with
/// σ = max(cell.depth_sigma_m, sigma_floor_m), range information area / ρ² with
/// ρ = max(range_sigma_m, sigma_floor_m).
/// Its tilt noise is tilt_scale·cell.normal_sigma_rad (MapConfig::normal_sigma_scale).
LabelState state_of_cell(const Planecell& cell, double area_m2, double range_sigma_m, double sigma_floor_m,
                         double tilt_scale = 0.0);
/// The same with ρ = σ (the cell's own σ_Z).
inline LabelState state_of_cell(const Planecell& cell, double area_m2, double sigma_floor_m) {
  return state_of_cell(cell, area_m2, static_cast<double>(cell.depth_sigma_m), sigma_floor_m);
}

/// A cell's depth noise along its plane's normal, seen from the camera centre C (world frame):
///   σ_n = σ_Z · |n·C + e| / |X̄ − C|,
/// with X̄ the polygon's vertex centroid. A depth error moves the cell along the viewing ray
/// r̂ = (X̄ − C) / |X̄ − C| (σ_Z taken as the error along the ray), which moves its plane by that
/// error times |n·r̂| = |n·C + e| / |X̄ − C| along the normal, since n·X̄ + e = 0. The CRF's
/// plane-distance range is a distance along the normal: a plane seen head-on keeps σ_n = σ_Z,
/// a road 1.65 m below the camera and 16.5 m away gets σ_Z / 10, so a 15 cm kerb step stays
/// apart at a range where σ_Z alone (0.3 m) would hide it. 0 for an empty polygon; σ_Z when
/// the centroid is at C.
double normal_depth_sigma_m(const Planecell& cell, const Eigen::Vector3d& camera_centre);

/// Folds `from` into `into`: moments and histograms add (area-weighted), plane refitted.
void fold_label(LabelState& into, const LabelState& from);

}  // namespace planecell::map
