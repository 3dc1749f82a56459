#pragma once
/// Configuration of the global map, CRF merger and voxel baseline (mapping/map, mapping/voxel).

namespace planecell {

/// Global planecell map and incremental CRF merging (paper §5.2, Eq. CRFFunction).
/// The "variation range" of the circular greedy merging is (max_normal_angle_deg,
/// max_plane_distance_m, min_colour_similarity, max_chromaticity_distance): a pair outside it is
/// never merged.
struct MapConfig {
  /// Cells whose vertex centroid lies farther than this from the camera are not mapped. Stereo depth
  /// noise grows as Z²: at 20 m (KITTI rig) a cell is ~0.1–0.3 m off its true plane, about the step
  /// between a road and its sidewalk; nearer re-observations of the same area are mapped instead.
  double max_range_m = 20.0;
  /// Cells whose stereo depth noise σ_Z (Planecell::depth_sigma_m = Z²·σ_d/(f_x·B)) exceeds this
  /// are not mapped either: the range gate in terms of the rig. 0.35 m is σ_Z at 15.4 m on the
  /// KITTI rig (f_x 721.5 px, B 0.54 m, σ_d = 1/√3 px; 20 m gives 0.6 m), more than twice a kerb's
  /// step: the CRF's range (k·σ_Z) there no longer tells road from sidewalk, nor a setback facade
  /// from its neighbour. A forward drive sees the same places nearer a few frames later. On 16
  /// synthetic 100-frame streets 0.6 → 0.35 m gives 1.2 points more GT area in one label, 0.3
  /// points fewer cells merged across GT planes, 3 points more of the map within 10 cm of a GT
  /// surface, for 0.8 points of the GT points within 10 cm of the map (docs/PERFORMANCE.md, "The
  /// depth-noise gate at 0.35 m"). EuRoC's rig (B 0.11 m) reaches 0.35 m at 5.5 m: its sample's
  /// map is the same. 0 = no gate.
  double max_depth_sigma_m = 0.35;
  /// Cells whose RANSAC plane explains less than this share of their valid disparities within the
  /// fit's inlier threshold (Planecell::inlier_ratio, ±1 px by default) are not mapped: their
  /// planes are the tail of the map's plane error. On the synthetic streets (docs/PERFORMANCE.md,
  /// "Weak plane fits stay out of the map") pure facade cells below 0.8 are off their GT plane by
  /// > 10 cm in 56–92 % of cases against 6 % at ≥ 0.99, and on the real KITTI pairs with GT their
  /// planes have 8–11× the D1 outlier rate of the others. They are 14–23 % of the cells there and
  /// 16 % of the integrated cells of a synthetic street; other frames see the same places with
  /// better fits. 0 = no gate; a cell with an unknown ratio (0: not fitted here, e.g. built by
  /// hand) is never gated.
  double min_inlier_ratio = 0.8;
  // --- CRF variation range --------------------------------------------------------------------
  double max_normal_angle_deg = 10.0;  ///< max angle between the two surfaces' normals
  double max_plane_distance_m = 0.08;  ///< smallest plane-distance tolerance d_min (m)
  double min_colour_similarity = 0.3;  ///< min histogram intersection δ ∈ [0, 1]
  /// Two labels whose mean chromaticities (histogram_chromaticity: the mean colour's
  /// (R, G, B)/(R + G + B)) lie farther apart than this (Euclidean) are of other paint (0 = off):
  /// out of the range, and never joined by the fragment join, the long bridge or the ground join;
  /// a surface's footprint covers a new cell (redundant_coverage) only when the cell's own
  /// chromaticity is as near the surface's. Shading and a texture's grey modulation scale R, G
  /// and B alike: they spread a surface's histogram along one line through black, wide enough on a
  /// textured facade for the intersection to pass a dark door of another paint, but leave its
  /// chromaticity unchanged. The synthetic streets' door paint lies 0.075–0.16 from five of their
  /// six facade paints (0.03 from the sixth); 0.045–0.06 cut the cells merged across GT planes
  /// most there while keeping the area in one label (docs/PERFORMANCE.md).
  double max_chromaticity_distance = 0.06;
  /// A new cell meets a stored cell (a neighbour edge for the CRF, the re-observation search, a
  /// stored cell that may cover it) only when their mean colours lie within this Euclidean RGB
  /// distance (levels 0–255 a channel; 0 = off). The CRF's colour term compares whole labels'
  /// histograms, which a textured facade spreads wide enough for a door cell to pass; the stored
  /// cell next to the new one is a local sample of its surface's colour. Surfaces' footprints
  /// still cover a cell of any mean colour within max_chromaticity_distance (a re-observation
  /// under other light), another surface than the cell's CRF label only with histograms alike
  /// (covered_elsewhere_min_colour).
  double neighbour_max_rgb_distance = 20.0;
  /// σ floor (m): θ' residuals are measured in units of it, and a cell's depth noise σ_Z
  /// (Planecell::depth_sigma_m) counts as at least this much when weighting it (area / σ²).
  double residual_scale_m = 0.05;
  /// Stereo depth noise widens the range per label: the less-informed label of a pair may lie
  /// max(max_plane_distance_m, k·σ_eff) off the other's plane, and its normal may differ by
  /// max_normal_angle_deg + atan(k·σ_eff / √area) (capped at 2× the angle). σ_eff is the label's
  /// information-weighted depth noise (LabelState::sigma_m).
  double depth_sigma_factor = 1.0;     ///< k (0 = fixed range, as in the paper)
  /// The range widens by a new cell's depth noise projected on its plane's normal,
  /// σ_n = σ_Z·|n·r̂| (map::normal_depth_sigma_m; r̂ the viewing ray): how far the plane itself may
  /// be off (LabelState::range_sigma_m). false: by σ_Z. Plane fits (weights area / σ_Z²),
  /// coverage and the stored cell keep σ_Z.
  bool normal_depth_noise = true;
  /// The angle range also widens by a new cell's uncertain orientation: by k·κ·σ_θ, its fit's
  /// normal σ_θ (Planecell::normal_sigma_rad) times this scale κ, up to
  /// max_noisy_normal_angle_deg. The fit takes the pixels' disparity errors as independent; SGM's
  /// aggregation correlates them, and on the synthetic streets the cells' actual normal error is
  /// 6–12× σ_θ (median per kind of surface), hence κ = 8. A label's κσ_θ combines its members'
  /// as 1/√Σ(κσ_θ)⁻² (stored surfaces count as exact); two mature labels may differ by
  /// max_normal_angle_deg widened by k·√(κσ_lo² + κσ_hi²). The distance range is not widened
  /// by the tilt: a weakly textured facade's cells sit on their plane (5–9 cm) while turned by
  /// 19–30°, and widening it as well merged sidewalks across their kerb (docs/PERFORMANCE.md,
  /// "Normals the plane fit cannot determine"). 0 = off.
  double normal_sigma_scale = 8.0;
  double max_noisy_normal_angle_deg = 45.0;  ///< cap of the angle range widened by σ_θ
  /// The reverse test (the better-informed label on the other's plane) applies when the other
  /// holds at least this share of its information (comparable labels are tested both ways).
  double mutual_information_fraction = 0.25;
  /// Labels with at least this many member cells are mature: two mature labels merge only when
  /// their normals are within max_normal_angle_deg and the step between their planes at the
  /// boundary (between the edge's two cells) is within max_plane_distance_m (no widening by noise).
  int mature_cells = 3;
  double neighbour_gap_m = 0.30;       ///< 3D neighbours: polygons closer than this (m)
  /// Bridging over occlusion gaps (m; 0 = off). A parked car hides the strip of sidewalk or facade
  /// behind it from every view, and the segments either side of it never become neighbours. After
  /// the CRF, a surface with ≥ mature_cells observations that this frame's cells reach is merged
  /// with another such surface when a stored cell of it lies within bridge_gap_m of one of those
  /// cells, the larger of the two covers at least bridge_min_area_m2, the two pass the CRF's test
  /// for mature labels (normals within max_normal_angle_deg, step between the planes at the two
  /// cells' midpoint m ≤ max_plane_distance_m, colour), and the gap is hidden rather than seen
  /// through: no stored cell of a third surface lies within 0.2 m of the camera ray behind m
  /// (0.3–10 m beyond it). On eight 100-frame synthetic streets (docs/PERFORMANCE.md, "Bridging
  /// occlusion gaps between large surfaces") it raises the GT area in one label from 73.6 to
  /// 78.1 % on average at the same share of cells merged across GT planes (6.0 %).
  double bridge_gap_m = 5.0;
  /// A gap is bridged only when one side of it has grown to this area (m²; 0 = any): an occluder
  /// splits a surface that extends beyond it (a sidewalk, a facade), while two small coplanar
  /// surfaces with a gap between them are more often two objects, such as the aligned sides of two
  /// parked cars (≤ 7 m² each), which the visibility test misses when nothing was mapped behind
  /// their gap. Without it the bridge merges different cars: cells merged across GT planes
  /// 6.0 → 7.0 % on the eight streets (seed 1: 6.8 → 7.9 %, 402 more car cells).
  double bridge_min_area_m2 = 20.0;
  /// A bridge's two cells must each lie within this distance of the other surface's plane (m;
  /// 0 = no such test). The CRF's step is measured at the cells' midpoint m, up to 2.5 m from
  /// either cell, where a small surface's plane is an extrapolation: a sidewalk fragment a few
  /// degrees off crosses the road's plane near the curb and passed the step test 15 cm above the
  /// road. The cells themselves are where each plane was observed. 12 cm: below a curb's 15 cm,
  /// above the 1° tilt (9 cm over 5 m) two views of one plane may differ by.
  double bridge_max_cell_distance_m = 0.12;
  /// Long bridges (m; 0 = off, else > bridge_gap_m): parked cars hide 10 m and more of a sidewalk
  /// from every view, beyond bridge_gap_m. Two mature surfaces each covering at least
  /// bridge_long_min_area_m2 (their planes are then well determined) merge across a gap of up to
  /// bridge_long_gap_m when their normals lie within bridge_long_max_angle_deg, the step between
  /// their planes at the two cells' midpoint m is at most bridge_long_max_step_m, their colours
  /// pass bridge_long_min_colour, and the gap is hidden behind an occluder and unmapped: a stored
  /// cell of a third surface lies within 0.2 m of the camera ray in front of m (0.5 m from either
  /// end), none near the ray behind m (as the short bridge), and none within 0.2 m of the straight
  /// path between the two cells on the plane (the two sidewalks across a road lie on one plane,
  /// with the road in between). On eight 100-frame synthetic streets it raises the GT area in one
  /// label from 79.5 to 80.6 % at the same share of cells merged across GT planes (6.1 %);
  /// docs/PERFORMANCE.md, "Long bridges".
  double bridge_long_gap_m = 15.0;
  double bridge_long_min_area_m2 = 20.0;
  double bridge_long_max_angle_deg = 3.0;
  double bridge_long_max_step_m = 0.04;
  double bridge_long_min_colour = 0.75;
  /// Ground surfaces across long gaps (m; 0 = off). A row of parked cars hides 20–40 m of a
  /// sidewalk from every view, and by the time the far piece is seen the near one has gone
  /// dormant, out of the long bridge's reach from the frame's cells. So a large mature ground
  /// surface (normal within max_ground_tilt_deg of `up`) going dormant joins another within this
  /// distance (between their nearest stored cells) under the long bridge's tests of one plane:
  /// one at least bridge_long_min_area_m2 and the other ground_join_min_area_m2, normals within
  /// bridge_long_max_angle_deg, the step between their planes at the two cells' midpoint at most
  /// bridge_long_max_step_m, colours at least ground_join_min_colour (not the long bridge's
  /// bridge_long_min_colour), and no other surface off the plane within 0.2 m of the straight
  /// path between the two cells on the plane (a road 15 cm below the two sidewalks either side of
  /// it, a curb); surfaces below fragment_join_max_area_m2 do not count (pieces of the ground seen
  /// between the occluders from afar, fitted 5–10 cm or tens of degrees off). Only ground
  /// surfaces: two coplanar facades tens of metres apart are as often
  /// two buildings as one behind an occluder, while the ground is one surface unless something
  /// lies between. docs/PERFORMANCE.md, "Ground surfaces joined across long gaps".
  double ground_join_gap_m = 40.0;
  /// The ground join's colour test: the two surfaces' histograms at least this alike (the CRF's
  /// δ, in [0, 1]), looser than bridge_long_min_colour because the tests of one plane above (3°,
  /// 4 cm step, nothing off the plane between) are what tell two ground surfaces apart, and one
  /// sidewalk's pieces mapped from 10 m and from 40 m differ in colour: the blur of distance
  /// narrows a textured surface's histogram (δ 0.51–0.68 between pieces of one GT sidewalk on the
  /// synthetic streets). docs/PERFORMANCE.md, "The ground join's own colour test and smaller
  /// pieces".
  double ground_join_min_colour = 0.5;
  /// The ground join's pair: one surface at least bridge_long_min_area_m2, the other at least this
  /// (m²), both mature and level (either order: the larger at least the larger threshold). A
  /// well-observed 10–20 m² piece of a sidewalk left between parked cars otherwise never joins
  /// the sidewalk it lies in line with (the tests of one plane still apply). docs/PERFORMANCE.md,
  /// "The ground join's own colour test and smaller pieces".
  double ground_join_min_area_m2 = 10.0;
  // --- fusion and index -----------------------------------------------------------------------
  /// Re-observations are found before the neighbour search: a new cell within neighbour_gap_m
  /// of a stored cell whose surface is live, in the CRF's variation range of it, and adding less
  /// than fuse_new_area_fraction of its area to its footprint meets that surface in the CRF
  /// through this one cell instead of through every stored cell near it, and is fused without a
  /// coverage test when the CRF gives it the surface's label (GlobalMap::integrate, step 2). 373
  /// of 423 new cells a frame re-observe a surface on the synthetic streets. false = every new
  /// cell meets every stored cell within the gap (docs/PERFORMANCE.md, "Re-observations found
  /// before the neighbour search").
  bool prefuse_reobservations = true;
  double fuse_new_area_fraction = 0.25;  ///< a re-observed cell adding < this share of its own
                                         ///< area to its surface is fused, not stored
  /// A new cell at least this share of which is already covered by stored cells nearly coplanar
  /// with it (map/coverage), whatever their surface, is a re-observation: fused, not stored. The
  /// map then grows with the area explored, not with the frames. > 1 turns the rule off.
  /// Nearly coplanar, within the pair's depth noise σ = √(σ_new² + σ_old²) (Planecell::depth_sigma_m;
  /// the same space seen from farther away is noisier): the stored cell's vertices (RMS) and
  /// polygon lie within tol = clamp(redundant_sigma_factor·σ, neighbour_gap_m,
  /// redundant_max_distance_m) of the new cell's plane, and the normals within
  /// redundant_normal_angle_deg + atan(redundant_sigma_factor·σ / √area_new) (at most twice that
  /// angle): a plane fitted over a cell of side √A with depth noise σ tilts by about atan(σ/√A).
  /// A stored cell much less precise than the new one (σ_old > redundant_precision_ratio·σ_new) does
  /// not count: the nearer, better observation is stored.
  /// The surfaces of those nearby cells cover the new cell too, where their footprints (every
  /// observation fused into them, stored or not) hold its points, when the cell's vertices lie
  /// within clamp(redundant_sigma_factor·σ_new, residual_scale_m, neighbour_gap_m) (RMS)
  /// of the surface's plane, the normals within the same angle, and the surface is not much less
  /// precise (σ_eff ≤ redundant_precision_ratio·max(σ_new, residual_scale_m)).
  double redundant_coverage = 0.75;
  /// A surface's footprint covers a new cell that the CRF labelled otherwise (the fate "covered
  /// by another surface") only when the cell's colour histogram intersects the surface's by at
  /// least this much (δ, as the CRF's colour term; the cell's own CRF label needs no such test).
  /// Overriding the CRF on geometry and paint alone was right for 87 % of those cells on the
  /// synthetic streets: they were 6.6 % of the cells and 0.86 of the 2.62 points merged across GT
  /// planes (kerbs under a road's or sidewalk's footprint, doors of a facade's paint, faces of one
  /// car). 0.7 lies below what pieces of one surface show (0.88 in the median) and near a door
  /// against its facade (0.72): on 16 streets it cuts the cells across GT planes by 0.22 points at
  /// the same GT area in one label, the map 5 % larger (docs/PERFORMANCE.md, "A footprint covers a
  /// cell the CRF labelled otherwise only in its colours"). A re-observation under other light
  /// meets the CRF first (its range needs δ ≥ min_colour_similarity). 0 = off.
  double covered_elsewhere_min_colour = 0.7;
  /// σ_new above is the new cell's noise along its plane normal, σ_n = σ_Z·|n·r̂|
  /// (map::normal_depth_sigma_m), as in the CRF's range (normal_depth_noise), instead of σ_Z: a
  /// far sidewalk cell seen at a grazing angle has its plane's offset known to σ_Z/6 at 10 m, the
  /// 15 cm step to the road is resolved, and 2σ_Z (0.3–0.6 m) fused it into the road
  /// (docs/PERFORMANCE.md, "Coverage within the noise along the normal"). Stored cells keep σ_Z
  /// (their viewing ray is not stored), and the stored-cell route keeps its neighbour_gap_m floor.
  bool coverage_normal_noise = true;
  double redundant_normal_angle_deg = 30.0;
  double redundant_sigma_factor = 2.0;
  double redundant_max_distance_m = 1.0;
  double redundant_precision_ratio = 4.0;  // σ ∝ Z²: a cell seen from half the distance
  /// A surface is confirmed once observations from this many distinct frames have reached it
  /// (Surface::frames_observed: cells stored, fused or covered in it, or a merge with it). Until
  /// then it may be a stereo error: a plane fitted across a depth edge or a mismatched patch,
  /// which the next frames, seeing the place from a little further on, do not repeat, while a
  /// real surface within max_range_m stays in view for ~15 frames at 1 m per frame. Cells of one
  /// frame that the CRF gives one label confirm nothing: on eight 100-frame synthetic streets
  /// 83 % of the area of labels seen in one frame only lies off its GT plane (beyond
  /// max(15 cm, 2σ_Z)) or is turned by over 45° (docs/PERFORMANCE.md, "Surfaces confirmed by a
  /// second frame"). 1 = every surface is confirmed (nothing pruned).
  int confirm_frames = 2;
  /// An unconfirmed surface is pruned when new cells come near it again this many frames or more
  /// after it was last observed without confirming it (no cell stored, fused or covered in it),
  /// so single-view outliers do not pile up and a revisit adds only what is new. 0 = off.
  int unconfirmed_max_age_frames = 3;
  /// An unconfirmed surface no frame has observed for this many frames is pruned even when no new
  /// cell came near it: a real surface in view is seen again within a few frames, a plane
  /// floating where the following frames see nothing is a mismatch. 0 = no time-out.
  int unconfirmed_timeout_frames = 10;
  double footprint_resolution_m = 0.10;  ///< edge of a surface footprint bit (m; see map/footprint)
  /// Edge of the hashed 3D grid of cell bounds (m). Each query reaches 1 m around a cell
  /// (redundant_max_distance_m), so 4 m buckets register a 1 m cell in ~2 buckets instead of ~4
  /// at the same merge time as 2 m (same map: the exact tests follow the index).
  double index_cell_m = 4.0;
  // --- consolidation: old cells retired into fewer, larger ones (map/cell_union) --------------
  /// Cells stored this many frames ago or earlier (the camera has driven past them: at ~1 m per
  /// frame a place leaves max_range_m within ~20 frames) are united into fewer, larger cells on
  /// their surface's plane (map/cell_union), surface by surface, per consolidate_tile_m square of
  /// the surface's basis (by vertex centroid), once every cell of the surface in the square is
  /// that old: rasterised at consolidate_resolution_m, holes up to consolidate_max_hole_m2 filled,
  /// larger ones cut around, each region's outline simplified to within consolidate_tolerance_m.
  /// A cell takes part when its vertices all lie within max(consolidate_max_distance_m, σ_Z) of
  /// the surface's plane (σ_Z its depth noise: the CRF's own range); one the surface's plane does
  /// not describe keeps its own. The map then keeps its surfaces' extent to within a bit and the
  /// tolerance, in far fewer records and vertices. 10 frames: on eight 100-frame synthetic
  /// streets the map is 9–12 % smaller in RAM and 5–10 % in store than at 20 (20 was 6–10 %
  /// below 30), every merge score within 0.5 points; 6 frames lost 6 points of one-label area
  /// on one street (docs/PERFORMANCE.md, "Consolidation and dormancy after 10 frames, 2 KiB
  /// pages"). A cell consolidated while still in view is covered by new views like any stored
  /// cell. 0 = off.
  int consolidate_after_frames = 10;
  double consolidate_tile_m = 8.0;
  /// 0.10 m, the footprints' bit (footprint_resolution_m) and the outlines' tolerance: against
  /// 0.05 m the eight synthetic streets keep their merge scores and map accuracy (GT points within
  /// 10 cm +0.3 points, map area within 10 cm −0.1), the map is 2 % smaller and consolidation
  /// costs half the instructions (docs/PERFORMANCE.md, "Consolidation at the footprint's bit").
  double consolidate_resolution_m = 0.10;
  double consolidate_tolerance_m = 0.10;
  double consolidate_max_hole_m2 = 0.5;
  double consolidate_max_distance_m = 0.10;
  /// A cell belongs to the square of its vertex centroid when the centroid lies within this
  /// distance of its surface's plane; the map finds a square's cells through its spatial index
  /// in the box this reach gives the square, so a frame's consolidation does not grow with the
  /// surface's length. A cell farther out takes no part and does not hold its square back. 2 m:
  /// well beyond max(consolidate_max_distance_m, σ_Z) of any cell that can take part (σ_Z ≈ 0.7 m
  /// at 30 m on the synthetic rig).
  double consolidate_square_reach_m = 2.0;
  /// A surface no observation has reached for this many frames (the camera has left it behind)
  /// goes dormant: it keeps its descriptor (plane, information, histogram, colour, areas, bounds,
  /// cells) and drops the detail that only merging and fusing need (the moments' point sums, the
  /// footprint and its basis), about two thirds of a surface's RAM and store bytes. New cells
  /// coming near it again (a loop) wake it: its moments are kept at float precision
  /// (QuietMoments), its footprint is rebuilt from its stored cells, which consolidation has made
  /// cover it to within a bit. Must be ≥ consolidate_after_frames (a surface is consolidated
  /// before it goes dormant). 10, as consolidate_after_frames. 0 = never.
  int dormant_after_frames = 10;
  /// At the end of a replay or a `run` session the map is settled (GlobalMap::settle): every
  /// cell not yet consolidated is, and every live surface goes dormant (or joins a neighbour, or
  /// is pruned as a redundant fragment) as it would over the next frames if none reached it. The
  /// store records it (MapStore::commit_settle) and LCM subscribers receive it as one more
  /// update. The last frames' working set (detail, young cells) is then not kept in RAM or in
  /// the store. A later session resumes from the settled map. false = leave the map as the last
  /// frame left it.
  bool settle_at_close = true;
  /// A surface going dormant that holds one stored cell covering less than this area (m²), every
  /// vertex and the centroid of which lie within fragment_redundant_m of another surface's stored
  /// cells (distance_to_polygon), is pruned instead (MergeReport::pruned_surfaces): a fragment the
  /// CRF left beside a surface that already maps the same place. Isolated small pieces (a pole,
  /// a sign) stay. Needs dormant_after_frames > 0. 0 = keep every fragment.
  double fragment_max_area_m2 = 1.0;
  /// A surface going dormant with a footprint smaller than this (m²) first joins its largest
  /// larger neighbour (a stored cell within neighbour_gap_m) when its points lie within
  /// fragment_join_distance_m RMS of that neighbour's plane, its normal within
  /// fragment_join_angle_deg of the neighbour's and its colours pass min_colour_similarity
  /// (GlobalMap::join_neighbour): a piece of a wall or a car the CRF left apart because a small
  /// cell's fitted normal is loose (20–30° off on SGM streets). 0 = off.
  double fragment_join_max_area_m2 = 20.0;
  double fragment_join_distance_m = 0.10;
  double fragment_join_angle_deg = 30.0;
  /// A fragment whose points lie farther than fragment_join_distance_m from the neighbour's plane
  /// still joins it when they lie within fragment_join_sigma_factor · σ̄_Z, the mean modelled
  /// depth noise of its stored cells (MapCell::depth_sigma_m: stereo cannot tell such a patch from
  /// the plane), provided its colours match the neighbour's closely, δ ≥
  /// fragment_join_noise_colour (the same material: on the synthetic streets a door 3 cm proud of
  /// its facade has δ ≈ 0.72 against it, pieces of one facade 0.88 in the median), and its paint
  /// is the neighbour's (max_chromaticity_distance). On eight 100-frame streets it raised the GT
  /// area in one label from 78.9 to 79.5 % at the same share of cells merged across GT planes, and
  /// the settled map was 3 % smaller (docs/PERFORMANCE.md, "Fragments within their own depth
  /// noise"). 0.93 kept out half the pieces of one facade while doors of another paint passed
  /// lower bars; with paint tested apart, 0.8 (between the door's 0.72 and the pieces' 0.88) joins
  /// 0.7 points more GT area at 0.04 points more cells across GT planes ("The depth-noise gate at
  /// 0.35 m"). 0 = off.
  double fragment_join_sigma_factor = 1.0;
  double fragment_join_noise_colour = 0.8;
  /// How near another surface's cells a fragment must lie to be redundant (m): the map's
  /// completeness is scored at 10 cm (replay's `map_vs_ground_truth`).
  double fragment_redundant_m = 0.10;
  // --- queries --------------------------------------------------------------------------------
  double up_x = 0.0;  ///< world "up" (KITTI camera-style world: y down, so up = (0, −1, 0))
  double up_y = -1.0;
  double up_z = 0.0;
  double max_ground_tilt_deg = 15.0;  ///< a ground surface's normal is within this of "up"
};

template <class Visitor>
void visit_fields(MapConfig& c, Visitor&& visit) {
  visit("max_range_m", c.max_range_m);
  visit("max_depth_sigma_m", c.max_depth_sigma_m);
  visit("min_inlier_ratio", c.min_inlier_ratio);
  visit("max_normal_angle_deg", c.max_normal_angle_deg);
  visit("max_plane_distance_m", c.max_plane_distance_m);
  visit("min_colour_similarity", c.min_colour_similarity);
  visit("max_chromaticity_distance", c.max_chromaticity_distance);
  visit("neighbour_max_rgb_distance", c.neighbour_max_rgb_distance);
  visit("residual_scale_m", c.residual_scale_m);
  visit("depth_sigma_factor", c.depth_sigma_factor);
  visit("normal_depth_noise", c.normal_depth_noise);
  visit("normal_sigma_scale", c.normal_sigma_scale);
  visit("max_noisy_normal_angle_deg", c.max_noisy_normal_angle_deg);
  visit("mutual_information_fraction", c.mutual_information_fraction);
  visit("mature_cells", c.mature_cells);
  visit("neighbour_gap_m", c.neighbour_gap_m);
  visit("bridge_gap_m", c.bridge_gap_m);
  visit("bridge_min_area_m2", c.bridge_min_area_m2);
  visit("bridge_max_cell_distance_m", c.bridge_max_cell_distance_m);
  visit("bridge_long_gap_m", c.bridge_long_gap_m);
  visit("bridge_long_min_area_m2", c.bridge_long_min_area_m2);
  visit("bridge_long_max_angle_deg", c.bridge_long_max_angle_deg);
  visit("bridge_long_max_step_m", c.bridge_long_max_step_m);
  visit("bridge_long_min_colour", c.bridge_long_min_colour);
  visit("ground_join_gap_m", c.ground_join_gap_m);
  visit("ground_join_min_colour", c.ground_join_min_colour);
  visit("ground_join_min_area_m2", c.ground_join_min_area_m2);
  visit("prefuse_reobservations", c.prefuse_reobservations);
  visit("fuse_new_area_fraction", c.fuse_new_area_fraction);
  visit("redundant_coverage", c.redundant_coverage);
  visit("covered_elsewhere_min_colour", c.covered_elsewhere_min_colour);
  visit("coverage_normal_noise", c.coverage_normal_noise);
  visit("redundant_normal_angle_deg", c.redundant_normal_angle_deg);
  visit("redundant_sigma_factor", c.redundant_sigma_factor);
  visit("redundant_max_distance_m", c.redundant_max_distance_m);
  visit("redundant_precision_ratio", c.redundant_precision_ratio);
  visit("confirm_frames", c.confirm_frames);
  visit("unconfirmed_max_age_frames", c.unconfirmed_max_age_frames);
  visit("unconfirmed_timeout_frames", c.unconfirmed_timeout_frames);
  visit("footprint_resolution_m", c.footprint_resolution_m);
  visit("index_cell_m", c.index_cell_m);
  visit("consolidate_after_frames", c.consolidate_after_frames);
  visit("consolidate_tile_m", c.consolidate_tile_m);
  visit("consolidate_resolution_m", c.consolidate_resolution_m);
  visit("consolidate_tolerance_m", c.consolidate_tolerance_m);
  visit("consolidate_max_hole_m2", c.consolidate_max_hole_m2);
  visit("consolidate_max_distance_m", c.consolidate_max_distance_m);
  visit("consolidate_square_reach_m", c.consolidate_square_reach_m);
  visit("dormant_after_frames", c.dormant_after_frames);
  visit("settle_at_close", c.settle_at_close);
  visit("fragment_max_area_m2", c.fragment_max_area_m2);
  visit("fragment_redundant_m", c.fragment_redundant_m);
  visit("fragment_join_max_area_m2", c.fragment_join_max_area_m2);
  visit("fragment_join_distance_m", c.fragment_join_distance_m);
  visit("fragment_join_angle_deg", c.fragment_join_angle_deg);
  visit("fragment_join_sigma_factor", c.fragment_join_sigma_factor);
  visit("fragment_join_noise_colour", c.fragment_join_noise_colour);
  visit("up_x", c.up_x);
  visit("up_y", c.up_y);
  visit("up_z", c.up_z);
  visit("max_ground_tilt_deg", c.max_ground_tilt_deg);
}

/// OctoMap voxel baseline (paper's 10 cm voxel map).
struct VoxelConfig {
  double resolution_m = 0.10;
  double max_range_m = 20.0;  ///< same as MapConfig::max_range_m: both maps see the same points
  bool ray_casting = false;  ///< insertPointCloud with free-space ray casting (slow)
};

template <class Visitor>
void visit_fields(VoxelConfig& c, Visitor&& visit) {
  visit("resolution_m", c.resolution_m);
  visit("max_range_m", c.max_range_m);
  visit("ray_casting", c.ray_casting);
}

}  // namespace planecell
