#pragma once
/// How well the CRF merger groups cells into surfaces, against the synthetic renderer's ground-truth
/// surface ids (issue "global map" targets: ≥ 90 % of GT surface area under one label each, < 2 %
/// of cells merged across different GT surfaces).
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "core/plane.hpp"
#include "core/planecell.hpp"
#include "io/synthetic/synthetic_world.hpp"
#include "mapping/map/global_map.hpp"

namespace planecell::services::eval {

struct MergeMetrics {
  std::size_t cells = 0;         ///< integrated cells with a pure GT surface (see add_frame)
  std::size_t mixed_cells = 0;   ///< cells left out: < 50 % of their pixels on one GT surface
  std::size_t gt_surfaces = 0;   ///< GT surfaces covered by at least one cell
  std::size_t labels = 0;        ///< final map surfaces those cells ended in
  std::size_t pruned_cells = 0;  ///< cells whose surface was pruned as unconfirmed (left out)
  /// Σ_g A(g, L*(g)) / Σ_g A(g): share of GT surface area (cell areas, m²) that lies in its GT
  /// surface's dominant label L*(g) = argmax_L A(g, L).
  double area_in_dominant_label = 0.0;
  /// Share of GT surface area belonging to GT surfaces that are "one label": A(g, L*(g)) ≥ 0.9 A(g).
  double area_one_label = 0.0;
  /// Share of cells whose final label's dominant GT surface (by area) is not their own.
  double cross_merged_cells = 0.0;
  /// The same over GT *planes* (MergeEvaluator::set_gt_planes): a cell counts only when its
  /// label's dominant GT surface lies on another plane than its own. The renderer gives one world
  /// plane several ids (the road of each leg, flush facades of neighbouring buildings), and
  /// merging those is what the CRF is for. Equals cross_merged_cells without planes.
  double cross_merged_cells_between_planes = 0.0;
  /// Of those, the share (of all counted cells) the cell's own depth could have told apart: the
  /// cell's vertex centroid c, moved onto its GT surface's plane (p = c − (n_g·c + e_g) n_g), lies
  /// more than 2 σ_Z (Planecell::depth_sigma_m) from the plane of its label's dominant GT surface,
  /// |n_d·p + e_d| > 2 σ_Z. A door 3 cm proud of its facade, a 15 cm sidewalk step seen from
  /// 15 m (σ_Z ≈ 27 cm) or two parked cars' coplanar sides are not; a cell merged across a step
  /// or a corner larger than its noise is. Needs the GT planes (set_gt_surface_planes); a cell
  /// whose GT planes are unknown counts as resolvable. A diagnostic beside the target's figure
  /// above, which it does not replace.
  double cross_merged_cells_resolvable = 0.0;
  /// Of cross_merged_cells_between_planes, the share (of all counted cells) of boundary cells:
  /// fewer than kPureCellShare of the cell's own pixels on its GT surface (a superpixel
  /// straddling a door's edge, 60 % door and 40 % facade, counts as a door cell in the facade's
  /// label). The extraction's share of the figure: the rest are pure cells the merge placed in
  /// another GT plane's label. A diagnostic beside the target's figure, like the one above.
  double cross_merged_cells_boundary = 0.0;
  static constexpr double kPureCellShare = 0.9;
  // --- the cells' planes against their GT surface's plane (MergeEvaluator::set_gt_surface_planes) --
  /// Cells measured: pure cells (as above, those of later pruned surfaces included) whose GT
  /// surface has a known plane; 0 = no GT planes.
  std::size_t plane_error_cells = 0;
  /// Each cell's plane error ε = √((1/K) Σ_k (n_g·v_k + e_g)²), the RMS distance of its K world
  /// vertices to its GT surface's plane n_g·X + e_g = 0 (m): median and 90th percentile
  /// (lower nearest rank, sorted[⌊q·(n−1)⌋]) over the measured cells.
  double plane_error_median_m = 0.0;
  double plane_error_p90_m = 0.0;
  /// Median of the same cells' modelled depth noise σ_Z (Planecell::depth_sigma_m), the noise the
  /// merger widens its range by (MapConfig::depth_sigma_factor): set against the plane error, it
  /// shows how far the model is from the cells' actual error.
  double depth_sigma_median_m = 0.0;
  /// Median of ε / σ_Z over the measured cells with σ_Z > 0.
  double plane_error_over_sigma_median = 0.0;
  /// The measured cells on weakly textured GT surfaces (MergeEvaluator::set_gt_weak_texture), their
  /// median ε and median ε / σ_Z: how far stereo's error there exceeds the modelled σ_Z. 0 cells
  /// without texture ground truth.
  std::size_t weak_plane_error_cells = 0;
  double weak_plane_error_median_m = 0.0;
  double weak_plane_error_over_sigma_median = 0.0;
  /// ε split into the cell plane's orientation and position, medians over the same cells (all,
  /// and those on weakly textured GT surfaces): the normal angle α = acos|n·n_g| (deg) and the
  /// centroid offset o = |n_g·c + e_g| (m), c the cell's vertex centroid. A cell tilted by α
  /// about its centroid has ε ≈ o plus α times its vertices' spread: a large α with a small o is
  /// a plane in the right place with the wrong orientation.
  double normal_error_median_deg = 0.0;
  double centroid_offset_median_m = 0.0;
  double weak_normal_error_median_deg = 0.0;
  double weak_centroid_offset_median_m = 0.0;
  // --- where the area not in one label lies (MergeEvaluator::set_gt_kinds) --------------------
  /// One kind of GT surface (the renderer's: facade, sidewalk, car, …; "unknown" without kinds).
  /// Shares are of the total GT area A = Σ_g A(g), so Σ_kinds lost = 1 − area_one_label.
  struct KindShare {
    std::string kind;
    std::size_t gt_surfaces = 0;
    double area = 0.0;       ///< Σ A(g) of the kind's GT surfaces / A
    double one_label = 0.0;  ///< Σ A(g) of those that are one label / A
    double lost = 0.0;       ///< area − one_label: what the kind takes from area_one_label
  };
  std::vector<KindShare> by_kind;  ///< sorted by `lost`, largest first
  /// The GT surfaces of every kind that are weakly textured (MergeEvaluator::set_gt_weak_texture;
  /// kind "weakly textured"): stereo matches them poorly, so their cells' planes are noisier
  /// than the modelled σ_Z. Empty (0 surfaces) without texture ground truth.
  KindShare weak_texture{"weakly textured"};
  /// A GT surface that is not one label: A(g, L*(g)) < 0.9 A(g).
  struct SplitSurface {
    std::uint16_t gt = 0;
    std::string kind;
    double area_m2 = 0.0;         ///< A(g): cell area over every frame
    double dominant_share = 0.0;  ///< A(g, L*(g)) / A(g)
    std::size_t labels = 0;       ///< final labels holding some of it
    bool weak_texture = false;    ///< in set_gt_weak_texture's set
  };
  /// The kSplitSurfacesReported largest of them by A(g), largest first.
  std::vector<SplitSurface> split_surfaces;
  static constexpr std::size_t kSplitSurfacesReported = 10;
  /// Cells merged across GT planes (cross_merged_cells_between_planes) by the kind of their own
  /// GT surface and the kind of their label's dominant GT surface (a door cell in a facade's label:
  /// "door" → "facade"). `cells` is the share of all counted cells, so the shares add up to
  /// cross_merged_cells_between_planes; sorted largest first.
  struct CrossedKinds {
    std::string own_kind;
    std::string label_kind;
    double cells = 0.0;
  };
  std::vector<CrossedKinds> crossed_by_kinds;
  /// The counted cells by the path that placed them (map::MergeReport::cell_fates): `cells` their
  /// share of all counted cells, `crossed` the share (of all counted cells) of those merged across
  /// GT planes, so the `crossed` shares add up to cross_merged_cells_between_planes. Only for
  /// cells whose report gave fates; in map::CellFate order, fates with no cell left out.
  struct CrossedFate {
    std::string fate;  ///< map::fate_name
    double cells = 0.0;
    double crossed = 0.0;
  };
  std::vector<CrossedFate> crossed_by_fate;
};

/// GT plane groups of a synthetic scene: surfaces a and b share a group when their planes agree
/// (normals within max_angle_deg, |e_a − e_b| ≤ max_offset_m with n_b oriented like n_a) and their
/// polygons touch (map::polygons_within_m(touch_m): a corner of one within touch_m of the
/// other); groups are the transitive closure (map::UnionFind). Returns id → group (the smallest
/// id in the group).
std::unordered_map<std::uint16_t, std::uint16_t> coplanar_groups(std::span<const io::SyntheticSurface> surfaces,
                                                                 double max_angle_deg = 1.0,
                                                                 double max_offset_m = 0.02,
                                                                 double touch_m = 0.05);

/// Accumulates, frame by frame, (GT surface, area, map surface) for every integrated cell, and
/// follows later surface merges to each cell's final label.
class MergeEvaluator {
 public:
  /// `labels` is the extraction label image (CV_32S, value = the cell's extraction id), `gt_surface_id` the
  /// renderer's CV_16U ids (0 = none), `cells_world` the cells handed to GlobalMap::integrate and
  /// `report` what it returned. A cell's GT surface is the id of the majority of its pixels; cells
  /// whose majority is below 50 % or is "none" are counted as mixed and left out.
  /// Throws InputError on mismatched sizes or types.
  void add_frame(const cv::Mat& labels, const cv::Mat& gt_surface_id,
                 std::span<const Planecell> cells_world, const map::MergeReport& report);

  /// Follows the surface merges and pruned surfaces of a report with no new cells
  /// (GlobalMap::settle); add_frame does so for each frame's.
  void add_map_changes(const map::MergeReport& report);

  MergeMetrics finish() const;

  /// GT surface id → GT plane group (coplanar_groups); ids missing from it are their own group.
  void set_gt_planes(std::unordered_map<std::uint16_t, std::uint16_t> groups) { groups_ = std::move(groups); }
  /// GT surface id → its world-frame plane (the synthetic scene's): from then on add_frame also
  /// measures each pure cell's plane error against its GT surface (MergeMetrics::plane_error_*).
  void set_gt_surface_planes(std::unordered_map<std::uint16_t, Plane3> planes) { gt_planes_ = std::move(planes); }
  /// GT surface id → its kind (the scene's): finish() then breaks the area not in one label down
  /// by kind (MergeMetrics::by_kind, split_surfaces, named by io::to_string).
  void set_gt_kinds(std::unordered_map<std::uint16_t, io::SurfaceKind> kinds) { gt_kinds_ = std::move(kinds); }
  /// The GT surfaces rendered with weak texture (io::is_weakly_textured): finish() then gives their
  /// share of the area not in one label (MergeMetrics::weak_texture) and flags them among the
  /// split surfaces.
  void set_gt_weak_texture(std::unordered_set<std::uint16_t> ids) { gt_weak_texture_ = std::move(ids); }

 private:
  struct Sample {
    std::uint16_t gt = 0;
    float area_m2 = 0.0f;
    std::uint32_t label = 0;
    float depth_sigma_m = 0.0f;              ///< the cell's σ_Z
    Eigen::Vector3f centroid = Eigen::Vector3f::Zero();  ///< its vertex centroid (world)
    float purity = 1.0f;  ///< share of the cell's pixels on `gt` (≥ 0.5)
    std::optional<map::CellFate> fate;  ///< none when the report gave no fates
  };
  std::uint32_t final_label(std::uint32_t label) const;

  std::vector<Sample> samples_;
  std::size_t mixed_ = 0;
  std::unordered_map<std::uint32_t, std::uint32_t> merged_into_;  ///< absorbed → into
  std::unordered_set<std::uint32_t> pruned_;  ///< surfaces pruned as unconfirmed: not in the map
  std::unordered_map<std::uint16_t, std::uint16_t> groups_;  ///< GT id → GT plane group
  std::unordered_map<std::uint16_t, Plane3> gt_planes_;     ///< GT id → world plane
  std::unordered_map<std::uint16_t, io::SurfaceKind> gt_kinds_;  ///< GT id → kind
  std::unordered_set<std::uint16_t> gt_weak_texture_;           ///< weakly textured GT ids
  std::vector<float> plane_errors_m_;  ///< ε of each measured cell
  std::vector<bool> plane_error_weak_;  ///< ... whether its GT surface is weakly textured
  std::vector<float> depth_sigmas_m_;  ///< σ_Z of the same cells
  std::vector<float> normal_errors_deg_;   ///< α of the same cells
  std::vector<float> centroid_offsets_m_;  ///< o of the same cells
};

}  // namespace planecell::services::eval
