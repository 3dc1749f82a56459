#pragma once
/// The global planecell map: world-frame cells grouped into surfaces by the incremental CRF merger
/// (paper §5.2), with a spatial index, footprint fusion (map size grows with area, not frames),
/// planner queries and memory accounting.
#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <queue>
#include <set>
#include <span>
#include <unordered_map>
#include <vector>

#include <boost/container/flat_set.hpp>

#include "core/config/map_config.hpp"
#include "core/planecell.hpp"
#include "core/pose.hpp"
#include "mapping/map/compact_histogram.hpp"
#include "mapping/map/crf_merger.hpp"
#include "mapping/map/footprint.hpp"
#include "mapping/map/geometry.hpp"
#include "mapping/map/heap_optional.hpp"
#include "mapping/map/map_cell.hpp"
#include "mapping/map/spatial_index.hpp"

namespace planecell::map {

/// What the map keeps of a surface only while observations keep reaching it
/// (MapConfig::dormant_after_frames): the moments behind its plane in double (their weight is
/// Surface::information) and its footprint in its 2D basis. A surface no observation has reached
/// for that long drops it (it is dormant) and keeps its moments as QuietMoments; when new cells
/// come near it again, the map rebuilds the detail (rebuild_detail).
struct SurfaceDetail {
  Eigen::Vector3d moment_sum = Eigen::Vector3d::Zero();        ///< PlaneMoments::sum
  Eigen::Matrix3d moment_outer = Eigen::Matrix3d::Zero();      ///< PlaneMoments::sum_outer
  PlaneBasis basis;    ///< 2D frame of the footprint (fixed when the detail is made)
  Footprint footprint;  ///< cells' union in `basis` (occupancy bits)
  bool operator==(const SurfaceDetail&) const = default;
};

/// A dormant surface's plane moments at float precision, centred: the mean p̄ = Σ w p / Σ w and
/// the upper triangle (xx, xy, xz, yy, yz, zz) of the covariance C = Σ w p pᵀ / Σ w − p̄ p̄ᵀ.
/// With the weight W = Σ w they give the moments back: Σ w p = W p̄, Σ w p pᵀ = W (C + p̄ p̄ᵀ)
/// (float: 0.06 mm at 1 km for p̄; the plane fit works on C, not on the large p̄ p̄ᵀ terms).
struct QuietMoments {
  Eigen::Vector3f mean = Eigen::Vector3f::Zero();
  std::array<float, 6> covariance{};
  bool operator==(const QuietMoments&) const = default;
};

/// `moments` centred at float precision (zero for zero weight).
QuietMoments quiet_moments_of(const PlaneMoments& moments);
/// The moments of weight `weight` that `quiet` summarises.
PlaneMoments moments_from(const QuietMoments& quiet, double weight);

/// A surface: coplanar cells sharing one CRF label. Its reals are kept at storage precision
/// (to_float_precision) in floats where the map rounds them anyway, so the record is as small as
/// what io::MapStore writes for it; `information` stays a double (a sum of weights).
struct Surface {
  std::uint32_t id = 0;
  std::uint32_t observations = 0;  ///< integrated cells, fused ones included
  /// Last frame whose cells reached the surface (stored, fused or merged into it; absorbing
  /// another surface counts too): its dormancy clock.
  std::uint64_t last_observed_frame = 0;
  StoredPlane plane;             ///< least-squares plane of all integrated cells (world)
  /// Σ w of the moments behind `plane` (w = area / σ² per observation): the surface's
  /// information, kept when it is dormant (σ_eff and the rebuilt moments need it).
  double information = 0.0;
  CompactHistogram histogram;  ///< area-weighted mean of the integrated cells' histograms
  float histogram_weight_m2 = 0.0f;
  float observed_area_m2 = 0.0f;  ///< Σ area of every integrated cell, fused ones included
  /// Area of the footprint (union of all integrated cells); a dormant surface keeps the figure
  /// it had when it went dormant, and a rebuilt footprint adds to it from then on.
  float area_m2 = 0.0f;
  Eigen::Vector3f mean_rgb = Eigen::Vector3f::Zero();  ///< area-weighted mean colour (0..255 RGB)
  StoredBox bounds;               ///< bounds of every integrated cell's vertices
  std::vector<std::uint32_t> cells;  ///< stored member cells (map cell ids)
  HeapOptional<SurfaceDetail> detail;  ///< empty while the surface is dormant
  QuietMoments quiet_moments;  ///< a dormant surface's moments; zero while it is live
  /// Distinct frames that observed it (cells stored, fused or covered in it; a merge joins the
  /// counts as max(a, b), then counts the merging frame): MapConfig::confirm_frames. (Last: it
  /// fills the record's tail padding.)
  std::uint32_t frames_observed = 0;
};

/// The surface's plane moments: {information, moment_sum, moment_outer} while it is live, from
/// its quiet moments while it is dormant.
PlaneMoments moments_of(const Surface& surface);
/// Stores `moments` in a live surface (information and detail); throws std::logic_error when the
/// surface is dormant.
void set_moments(Surface& surface, const PlaneMoments& moments);

/// The detail of `surface`, rebuilt for a dormant surface from what it keeps: the moments from its
/// quiet moments and information, its basis on its plane around the first of `cells`' vertex
/// centroid (the tile layout of a new surface), its footprint the polygons of `cells` (its stored
/// cells) rasterised at resolution_m. The observations fused without being stored are not in the
/// footprint: after consolidation the stored cells cover them to within a footprint bit.
SurfaceDetail rebuild_detail(const Surface& surface, std::span<const MapCell* const> cells,
                             double resolution_m);

/// True when every field of `a` and `b` is equal (GlobalMap::same_content compares surfaces so).
bool same_surface(const Surface& a, const Surface& b);

/// Two surfaces became one (an event for the map consumers).
struct SurfaceMerge {
  std::uint64_t frame_id = 0;
  std::uint32_t absorbed = 0;  ///< surface that no longer exists
  std::uint32_t into = 0;      ///< surface that now holds its cells
  bool operator==(const SurfaceMerge&) const = default;
};

/// What integrate() did with one input cell (MergeReport::cell_fates): the path that placed it.
enum class CellFate : std::uint8_t {
  kRejected,    ///< not integrated (planeless, degenerate, too far or too noisy)
  kNewSurface,  ///< stored as the first cell of a surface it created
  kStored,      ///< stored in a surface that existed (its CRF label, possibly replacing cells)
  /// Fused into the surface found before the neighbour search
  /// (MapConfig::prefuse_reobservations), the CRF agreeing.
  kFusedFoundFirst,
  /// Fused into its CRF label's surface, adding less than fuse_new_area_fraction of its area to
  /// the footprint.
  kFusedByFootprint,
  /// Fused into its CRF label's surface as covered (MapConfig::redundant_coverage), though it
  /// added more than that fraction.
  kFusedByCoverage,
  /// Fused, as covered, into another surface than its CRF label (the CRF gave it a new label).
  kCoveredElsewhere,
};
/// The fate's name as reports print it ("fused by footprint").
const char* fate_name(CellFate fate);

/// What one integrate() call changed.
struct MergeReport {
  std::uint64_t frame_id = 0;
  bool settled = false;  ///< the report of settle() after frame_id, not of a frame
  std::size_t input_cells = 0;    ///< cells handed in
  std::size_t rejected_cells = 0; ///< planeless, degenerate, beyond max_range_m or max_depth_sigma_m, below min_inlier_ratio
  std::size_t fused_cells = 0;    ///< re-observations folded into a surface, not stored
  std::size_t redundant_cells = 0;  ///< of those, fused by coverage (MapConfig::redundant_coverage)
  /// Of the fused cells, those found as re-observations before the neighbour search
  /// (MapConfig::prefuse_reobservations).
  std::size_t prefused_cells = 0;
  std::vector<std::uint32_t> added_cells;       ///< new stored cells (map ids)
  std::vector<std::uint32_t> relabelled_cells;  ///< existing cells whose surface changed
  std::size_t replaced_cells = 0;  ///< stored cells replaced by a nearer, more precise new cell
  std::vector<std::uint32_t>
      removed_cells;  ///< cells deleted from the map (replaced, pruned, consolidated)
  /// Old cells united into fewer, larger ones (MapConfig::consolidate_after_frames): they are in
  /// removed_cells, the cells standing for them in added_cells.
  std::size_t consolidated_cells = 0;
  std::vector<std::uint32_t> updated_surfaces;  ///< surfaces created or changed (alive, sorted)
  /// Surfaces that went dormant this frame (MapConfig::dormant_after_frames; sorted): they kept
  /// every descriptor field and dropped their detail, so the store rewrites them but map
  /// consumers see no change.
  std::vector<std::uint32_t> dormant_surfaces;
  std::vector<std::uint32_t> removed_surfaces;  ///< surfaces absorbed by merges or pruned
  /// Of removed_surfaces, those pruned as unconfirmed (MapConfig::unconfirmed_max_age_frames),
  /// with their cells; the others were absorbed (surface_merges).
  std::vector<std::uint32_t> pruned_surfaces;
  std::vector<SurfaceMerge> surface_merges;     ///< in merge order
  /// Per input cell (same order as the cells handed in): the surface it was integrated into at
  /// the end of this frame (stored or fused), kNoSurface when rejected. Later surface merges
  /// move it on; follow `surface_merges` of later frames.
  std::vector<std::uint32_t> cell_surfaces;
  /// Per input cell (same order): the path that placed it (a diagnostic: merge metrics break the
  /// cells merged across GT planes down by it).
  std::vector<CellFate> cell_fates;
  double merge_ms = 0.0;                        ///< wall time of integrate()
};

/// Heap bytes of the map's parts (GlobalMap::map_bytes_by_part).
struct MapBytes {
  std::size_t cells = 0;       ///< cell records and their hash table
  std::size_t vertices = 0;    ///< cells' polygon vertices
  std::size_t surfaces = 0;    ///< surface records, their hash table, member-id lists and clocks
  std::size_t footprints = 0;  ///< surfaces' footprint tiles
  std::size_t index = 0;       ///< spatial index buckets
  std::size_t total() const { return cells + vertices + surfaces + footprints + index; }
};

/// Distance of a point to the nearest planecell.
struct CellDistance {
  std::uint32_t cell_id = 0;
  double distance_m = 0.0;
};

/// The ground under a point.
struct GroundHit {
  std::uint32_t surface_id = 0;
  double height_above_m = 0.0;          ///< along "up", point minus ground
  Eigen::Vector3d ground_point = Eigen::Vector3d::Zero();
};

/// A 2D grid of maximum heights over a region of the ground plane.
struct HeightMap {
  Eigen::Vector3d axis_a = Eigen::Vector3d::UnitX();  ///< grid columns run along a
  Eigen::Vector3d axis_b = Eigen::Vector3d::UnitZ();  ///< grid rows run along b
  Eigen::Vector2d origin_ab = Eigen::Vector2d::Zero();  ///< (a, b) of the grid's corner (m)
  double resolution_m = 0.1;
  cv::Mat height_m;  ///< CV_32F rows × cols, max up·X of the cells over each grid square; NaN = none
};

/// Surfaces already tested against one surface in a walk (bridges, fragment joins): a sorted
/// vector, as a walk tests tens of them, each looked up once per stored cell met.
using CheckedSurfaces = boost::container::flat_set<std::uint32_t>;

class GlobalMap {
 public:
  /// Throws ConfigError on an invalid configuration (non-positive scales, zero up vector).
  explicit GlobalMap(const MapConfig& config = {});

  /// Integrates one frame's world-frame cells (map::to_world) seen from pose T_world_cam.
  /// `image_adjacency` (label_adjacency of the frame's label image, in the cells' extraction ids)
  /// gives the same-frame neighbours; when empty, same-frame neighbours are found in 3D. Earlier
  /// cells near the new ones come from the spatial index. Runs the CRF merger, then fuses every
  /// new cell into its surface's footprint: a cell adding less than fuse_new_area_fraction of its
  /// own area is not stored. A stored cell keeps its map fields only (MapCell); its colour
  /// histogram is folded into its surface's. A surface not yet confirmed by
  /// MapConfig::confirm_frames distinct frames is pruned (MergeReport::pruned_surfaces) when new
  /// cells come near it again MapConfig::unconfirmed_max_age_frames or more frames after it was
  /// last observed without confirming it, or when no frame has observed it for
  /// MapConfig::unconfirmed_timeout_frames. A surface no
  /// observation has reached for MapConfig::dormant_after_frames goes dormant (drops its
  /// SurfaceDetail: MergeReport::dormant_surfaces) and is woken, its detail rebuilt from its cells,
  /// when new cells come near it again. Throws InputError on a bad pose.
  MergeReport integrate(std::uint64_t frame_id, const Pose& T_world_cam,
                        std::span<const Planecell> cells_world,
                        std::span<const LabelEdge> image_adjacency = {});

  /// Settles the map at the end of a session (no frame after `last_frame_id` is coming now):
  /// what integrate() would do to it over the next frames if none of them reached it, except
  /// that nothing is pruned as unconfirmed (the last frames' single views may be confirmed in a
  /// later session). Every cell not yet consolidated is consolidated (as if
  /// consolidate_after_frames had passed), then every live surface goes quiet: it joins a
  /// neighbour or is pruned as a redundant fragment, as at dormancy, or it drops its detail
  /// (MergeReport::dormant_surfaces). The report (MergeReport::settled, frame_id =
  /// last_frame_id) carries the changes for the store (io::MapStore::commit_settle), the map's
  /// consumers and the merge scores. A settled map is smaller in RAM (no live working set)
  /// and integrates on like any map: new cells near a dormant surface wake it. Settling a settled
  /// map changes nothing. Needs consolidate_after_frames and dormant_after_frames > 0 for the
  /// respective steps (0: that step is skipped).
  MergeReport settle(std::uint64_t last_frame_id);

  const std::unordered_map<std::uint32_t, MapCell>& cells() const { return cells_; }
  const std::unordered_map<std::uint32_t, Surface>& surfaces() const { return surfaces_; }
  /// The stored cell / surface with this id, nullptr when absent (inline: io::MapStore uses them
  /// without linking planecell_mapping).
  const MapCell* cell(std::uint32_t id) const {
    auto it = cells_.find(id);
    return it == cells_.end() ? nullptr : &it->second;
  }
  const Surface* surface(std::uint32_t id) const {
    auto it = surfaces_.find(id);
    return it == surfaces_.end() ? nullptr : &it->second;
  }
  const MapConfig& config() const { return config_; }
  std::uint32_t next_cell_id() const { return next_cell_id_; }
  std::uint32_t next_surface_id() const { return next_surface_id_; }

  /// The detail of surface `id`: its own while it is live, rebuilt from its cells and quiet
  /// moments (rebuild_detail) while it is dormant. Throws InputError for an unknown id.
  SurfaceDetail surface_detail(std::uint32_t id) const;

  /// Ids of stored cells whose bounds overlap `box` (sorted).
  std::vector<std::uint32_t> cells_near(const Aabb& box) const;
  /// Ids of stored cells in the spatial-index buckets `box` touches (sorted): a superset of
  /// cells_near(box) without its bounds test, for callers that filter by cheaper criteria first.
  std::vector<std::uint32_t> cell_candidates(const Aabb& box) const { return index_.candidates(box); }

  /// Nearest stored cell within max_distance_m (distance_to_polygon: point-to-plane |n·p + e|
  /// inside the polygon, distance to the boundary outside). nullopt when none is that close.
  std::optional<CellDistance> nearest_cell(const Eigen::Vector3d& point, double max_distance_m) const;

  /// The ground surface under `point`: among surfaces whose normal is within max_ground_tilt_deg of
  /// "up", the one whose plane is closest below the point (0 ≤ height ≤ max_drop_m along up) and
  /// one of whose stored cells contains the point's vertical projection (seen along up; a live
  /// map and its LCM mirror, which holds the cells only, give the same answer).
  std::optional<GroundHit> ground_under(const Eigen::Vector3d& point, double max_drop_m = 10.0) const;

  /// Height map of the region [a0, a0 + cols·res) × [b0, b0 + rows·res) of the horizontal axes
  /// (a, b) ⟂ up (for up = (0, −1, 0): a = x, b = z). Each square holds the max height up·X of
  /// the cells above its centre (sloped cells: the plane's height at the centre; near-vertical
  /// cells: their edges, sampled). Throws InputError on a non-positive size or resolution.
  HeightMap height_map(const Eigen::Vector2d& origin_ab, int cols, int rows, double resolution_m) const;

  /// Heap bytes of cells, surfaces and the index (requested sizes: hash nodes and buckets,
  /// vectors' capacity, footprint tiles; allocator headers not included): map_bytes_by_part().total().
  std::size_t map_bytes() const { return map_bytes_by_part().total(); }
  /// map_bytes() split by what holds the bytes.
  MapBytes map_bytes_by_part() const;

  /// Rebuilds a map from stored cells and surfaces (io::MapStore). `last_frame_id`, the last
  /// frame integrated into them, tells which cells the consolidation has not yet considered (those
  /// stored after last_frame_id − consolidate_after_frames), so that integrating on from the
  /// restored map gives the same map as integrating on without a restart; without it every cell
  /// is considered again. Throws StorageError when a cell names a missing surface.
  /// `settled`: the map was settled after last_frame_id (settle()): the consolidation has
  /// considered every cell.
  static GlobalMap restore(const MapConfig& config, std::vector<MapCell> cells,
                           std::vector<Surface> surfaces, std::uint32_t next_cell_id,
                           std::uint32_t next_surface_id,
                           std::optional<std::uint64_t> last_frame_id = std::nullopt,
                           bool settled = false);

  /// True when both maps hold exactly the same cells, surfaces and id counters.
  bool same_content(const GlobalMap& other) const;

  /// World "up" (unit).
  Eigen::Vector3d up() const { return up_; }

 private:
  /// Stored cells whose bounds overlap `box` (the index's buckets, then each cell's vertex bounds).
  std::vector<std::uint32_t> query_cells(const Aabb& box) const {
    return index_.query(box, [this](std::uint32_t id) { return bounds_of(cells_.at(id).vertices_m); });
  }
  /// Removes surface `id` and its cells (index entries included), recording them in `report` as
  /// removed and pruned.
  void prune_surface(std::uint32_t id, MergeReport& report);
  /// Folds surface `absorbed_id` into `into_id` (cells relabelled, footprint re-tiled in into's
  /// basis, colour, areas, bounds, observations) and removes it: recorded in `report` as removed
  /// and as a merge event, and in `touched`. The plane, moments and histogram are the caller's
  /// (the merged label state).
  void absorb_surface(std::uint32_t into_id, std::uint32_t absorbed_id, std::set<std::uint32_t>& touched,
                      MergeReport& report);
  /// MapConfig::bridge_gap_m: merges mature surfaces that this frame's cells (`fresh`, whose
  /// surfaces report.cell_surfaces names at input index fresh_input[k]) reach across a hidden gap,
  /// as events in `report`; `touched` follows the merges. fresh_box[k]: fresh[k]'s bounds (as
  /// integrate computed them).
  void bridge_surfaces(std::span<const Planecell* const> fresh, std::span<const std::size_t> fresh_input,
                       std::span<const Aabb> fresh_box, const Eigen::Vector3d& camera_centre,
                       std::set<std::uint32_t>& touched, MergeReport& report);
  /// A stored cell the bridges may reach, with its bounds once decoded.
  struct ReachCell {
    const MapCell* cell = nullptr;
    std::optional<Aabb> box;  ///< cell->vertices_m.bounds(), decoded when first needed
  };
  /// The bridges' walk: for each surface other than `id` and not in `checked` with a stored cell
  /// `old` that one of this frame's cells fresh[ks[w]] (bounds boxes[w]) of surface `id` reaches
  /// within `gap_m` (polygons_within_m), once per surface: `other` goes into `checked`, then
  /// `id = visit(id, old, old's vertices, *fresh[ks[w]])` (a merge may give `id` another surface).
  /// A surface with reject(self, other) goes into `checked` unvisited. `candidates`: the stored
  /// cells to walk, in id order, their boxes decoded. Returns `id`.
  template <class Reject, class Visit>
  std::uint32_t visit_reached_surfaces(std::uint32_t id, std::span<const Planecell* const> fresh,
                                       std::span<const std::size_t> ks, std::span<const Aabb> boxes,
                                       double gap_m, std::span<const ReachCell* const> candidates,
                                       CheckedSurfaces& checked, Reject&& reject, Visit&& visit);
  /// The stored cells met by a walk of probes (third_surface_near every 0.25–0.5 m along a ray or
  /// a path): the index's candidates of one bucket range with their bounds, their vertices
  /// decoded when first needed, kept while the probes' boxes touch the same buckets (consecutive
  /// probes mostly do). Valid while the map is unchanged: one walk, no merge within it.
  struct ProbeCells {
    struct Met {
      const MapCell* cell = nullptr;
      Aabb box;
      std::vector<Eigen::Vector3f> vertices;  ///< empty until decoded (a map polygon has ≥ 3)
    };
    std::optional<SpatialIndex::BucketRange> range;  ///< of `cells`; none before the first probe
    std::vector<Met> cells;                          ///< in id order
    std::vector<std::uint32_t> ids;                  ///< the index's answer (storage reused)
  };
  /// Is the stored cell nearest to `point` within 0.2 m (nearest_cell(point, 0.2)) on a surface
  /// other than `a` and `b`? `probe`: the walk's cells (ProbeCells).
  bool third_surface_near(const Eigen::Vector3d& point, std::uint32_t a, std::uint32_t b,
                          ProbeCells& probe) const;
  /// Does the camera see through the gap at `m` between surfaces `a` and `b`: a third surface
  /// near the camera ray 0.3–10 m behind m?
  bool seen_through(const Eigen::Vector3d& m, const Eigen::Vector3d& camera_centre, std::uint32_t a,
                    std::uint32_t b) const;
  /// MapConfig::bridge_long_gap_m: merges surface `id` (reached by the cells fresh[k], k in `ks`,
  /// with bounds `boxes`) with large surfaces on its plane across a gap that an occluder hides
  /// and nothing else fills; `checked` holds the surfaces already tested against it. Returns the
  /// id it ends under. `frame_reach`: the stored cells within bridge_long_gap_m of any of this
  /// frame's cells (bounds fresh_box), made by the first call of the frame that needs it.
  struct FrameReach {
    std::vector<ReachCell> cells;  ///< the index's candidates, in id order
  };
  std::uint32_t bridge_long(std::uint32_t id, std::span<const Planecell* const> fresh,
                            std::span<const Aabb> fresh_box, std::span<const std::size_t> ks,
                            std::span<const Aabb> boxes,
                            const Eigen::Vector3d& camera_centre, CheckedSurfaces& checked,
                            std::optional<FrameReach>& frame_reach, std::set<std::uint32_t>& touched,
                            MergeReport& report);

  /// The end of integrate() and settle(): consolidation as of `consolidation_frame`, dormancy as
  /// of `dormancy_frame`, then the report's lists as consumers read them (relabelled cells that
  /// left the map dropped, sorted and unique; updated_surfaces = `touched`) and the containers
  /// shrunk when sparse.
  void age_and_finish(std::uint64_t consolidation_frame, std::uint64_t dormancy_frame,
                      std::set<std::uint32_t>& touched, MergeReport& report);
  /// MapConfig::consolidate_after_frames: unites the old cells of each surface's tiles that
  /// cells coming of age this frame fall in; the cells leave the map (report.removed_cells) and
  /// their unions enter it (report.added_cells); `touched` gains their surfaces.
  void consolidate(std::uint64_t frame_id, std::set<std::uint32_t>& touched, MergeReport& report);

  /// Gives dormant surface `surface` its detail again, rebuilt from its cells, and puts it back
  /// on the dormancy clock; a live surface is left as it is.
  void wake(Surface& surface);
  /// MapConfig::dormant_after_frames: surfaces no observation has reached since
  /// frame_id − dormant_after_frames drop their detail (report.dormant_surfaces), unless they
  /// join a neighbour (join_neighbour) or are pruned as redundant fragments (redundant_fragment;
  /// removed from `touched`).
  void retire_quiet_surfaces(std::uint64_t frame_id, std::set<std::uint32_t>& touched, MergeReport& report);
  /// Folds surface a into b or b into a (the smaller id absorbs the larger, absorb_surface) and
  /// gives the result the folded label state (plane, moments, histogram); returns its id.
  std::uint32_t merge_surfaces(std::uint32_t a_id, LabelState a, std::uint32_t b_id, LabelState b,
                               std::set<std::uint32_t>& touched, MergeReport& report);
  /// MapConfig::fragment_join_max_area_m2: `surface`, going dormant, joins the largest larger
  /// neighbouring surface (a stored cell within neighbour_gap_m) whose plane its moments lie on
  /// (normals within fragment_join_angle_deg, and RMS ≤ fragment_join_distance_m with colour ≥
  /// min_colour_similarity, or RMS ≤ fragment_join_sigma_factor · σ̄_Z of its stored cells with
  /// colour ≥ fragment_join_noise_colour); true when it did (`surface` may be gone).
  bool join_neighbour(Surface& surface, std::set<std::uint32_t>& touched, MergeReport& report);
  /// MapConfig::ground_join_gap_m: `surface`, a large mature ground surface going dormant, joins
  /// another one on its plane across a gap nothing is mapped in (see the config); true when it
  /// did (`surface` may be gone).
  bool join_ground_across_gap(Surface& surface, std::set<std::uint32_t>& touched, MergeReport& report);
  /// MapConfig::fragment_max_area_m2: `surface` holds one stored cell of footprint area below
  /// it, whose centroid and vertices all lie within fragment_redundant_m of other surfaces' cells.
  bool redundant_fragment(const Surface& surface) const;

  MapConfig config_;
  Eigen::Vector3d up_;
  CrfMerger merger_;
  SpatialIndex index_;
  std::unordered_map<std::uint32_t, MapCell> cells_;
  std::unordered_map<std::uint32_t, Surface> surfaces_;
  /// (frame, surface id) of the surfaces not yet confirmed (MapConfig::confirm_frames), at or before
  /// their last_observed_frame, oldest first: the candidates of MapConfig::unconfirmed_timeout_frames;
  /// an entry falling due for a surface observed since is put back at that frame (derived state:
  /// restore rebuilds it).
  std::multimap<std::uint64_t, std::uint32_t> unconfirmed_since_;
  /// (frame stored, cell id) of the cells the consolidation has not yet considered, oldest first
  /// (derived state: restore rebuilds it from last_frame_id).
  std::deque<std::pair<std::uint64_t, std::uint32_t>> consolidation_queue_;
  /// (frame, surface id), least first: one entry per live surface, at or before its
  /// last_observed_frame; an entry falling due for a surface observed since is put back at that
  /// frame (derived state: restore rebuilds it).
  std::priority_queue<std::pair<std::uint64_t, std::uint32_t>,
                      std::vector<std::pair<std::uint64_t, std::uint32_t>>, std::greater<>>
      dormancy_clock_;
  std::uint32_t next_cell_id_ = 0;
  std::uint32_t next_surface_id_ = 0;
};

/// Surfaces of `map` that are dormant (no SurfaceDetail: MapConfig::dormant_after_frames).
inline std::size_t dormant_surface_count(const GlobalMap& map) {
  std::size_t n = 0;
  for (const auto& [id, surface] : map.surfaces()) n += !surface.detail;
  return n;
}

}  // namespace planecell::map
