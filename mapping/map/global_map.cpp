#include "mapping/map/global_map.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <string>

#include "core/error.hpp"
#include "mapping/map/cell_union.hpp"
#include "mapping/map/container_bytes.hpp"
#include "mapping/map/coverage.hpp"

namespace planecell::map {
namespace {

/// Largest edge of a cell's bounding box the map accepts (m): a stereo planecell spans metres, and
/// the index visits (extent / bucket)³ buckets per cell, so a corrupt polygon must not reach it.
constexpr double kMaxCellExtentM = 200.0;

/// Consolidation finds a due square's cells by scanning its surface's cells while the surface
/// has at most this many cells per due square, and through the spatial index beyond: a query
/// over an 8 m square visits a few hundred ids of all surfaces, a scan costs a vertex centroid
/// per cell of the surface.
constexpr std::size_t kConsolidateScanCells = 64;

/// Why a polygon on `plane` cannot enter the map, or "" when it can: it needs a finite plane and
/// ≥ 3 finite vertices of non-zero area, inside the index's cube (±`max_coordinate_m`) and at most
/// kMaxCellExtentM across.
std::string cell_problem(const Plane3& plane, std::span<const Eigen::Vector3f> vertices,
                         double max_coordinate_m) {
  if (vertices.size() < 3) return "has fewer than 3 vertices";
  if (!plane.normal.allFinite() || !std::isfinite(plane.offset)) return "has a non-finite plane";
  for (const auto& v : vertices)
    if (!v.allFinite()) return "has a non-finite vertex";
  const Aabb box = bounds_of(vertices);
  if (box.min.minCoeff() < -max_coordinate_m || box.max.maxCoeff() > max_coordinate_m)
    return "has a vertex beyond ±" + std::to_string(max_coordinate_m) + " m";
  if ((box.max - box.min).maxCoeff() > kMaxCellExtentM)
    return "spans more than " + std::to_string(kMaxCellExtentM) + " m";
  if (!(polygon_area_m2(vertices) > 1e-9)) return "has zero area";
  return {};
}

}  // namespace

namespace {

/// No merge unit (yet).
constexpr std::uint32_t kNoUnit = std::numeric_limits<std::uint32_t>::max();

/// A surface's footprint basis on `plane` around `centre`: its origin half a footprint tile back
/// along u and v, so that the first cell lands mid-tile, not on the corner of four tiles; at
/// storage precision (geometry.hpp).
PlaneBasis tile_centred_basis(const Plane3& plane, const Eigen::Vector3d& centre, double resolution_m) {
  PlaneBasis basis = make_basis(plane, centre);
  const double half_tile_m = 0.5 * FootprintTile::kSize * resolution_m;
  basis.origin -= half_tile_m * (basis.u + basis.v);
  return to_float_precision(basis);
}

}  // namespace

QuietMoments quiet_moments_of(const PlaneMoments& moments) {
  QuietMoments q;
  if (!(moments.weight > 0.0)) return q;
  const Eigen::Vector3d mean = moments.sum / moments.weight;
  const Eigen::Matrix3d covariance = moments.sum_outer / moments.weight - mean * mean.transpose();
  q.mean = mean.cast<float>();
  q.covariance = {static_cast<float>(covariance(0, 0)), static_cast<float>(covariance(0, 1)),
                  static_cast<float>(covariance(0, 2)), static_cast<float>(covariance(1, 1)),
                  static_cast<float>(covariance(1, 2)), static_cast<float>(covariance(2, 2))};
  return q;
}

PlaneMoments moments_from(const QuietMoments& quiet, double weight) {
  PlaneMoments m;
  m.weight = weight;
  const Eigen::Vector3d mean = quiet.mean.cast<double>();
  const auto& c = quiet.covariance;
  Eigen::Matrix3d covariance;
  covariance << c[0], c[1], c[2], c[1], c[3], c[4], c[2], c[4], c[5];
  m.sum = weight * mean;
  m.sum_outer = weight * (covariance + mean * mean.transpose());
  return m;
}

PlaneMoments moments_of(const Surface& surface) {
  if (!surface.detail) return moments_from(surface.quiet_moments, surface.information);
  PlaneMoments m;
  m.weight = surface.information;
  m.sum = surface.detail->moment_sum;
  m.sum_outer = surface.detail->moment_outer;
  return m;
}

void set_moments(Surface& surface, const PlaneMoments& moments) {
  if (!surface.detail)
    throw std::logic_error("set_moments: surface " + std::to_string(surface.id) + " is dormant");
  surface.information = moments.weight;
  surface.detail->moment_sum = moments.sum;
  surface.detail->moment_outer = moments.sum_outer;
}

const char* fate_name(CellFate fate) {
  switch (fate) {
    case CellFate::kRejected: return "rejected";
    case CellFate::kNewSurface: return "new surface";
    case CellFate::kStored: return "stored";
    case CellFate::kFusedFoundFirst: return "found first";
    case CellFate::kFusedByFootprint: return "fused by footprint";
    case CellFate::kFusedByCoverage: return "fused by coverage";
    case CellFate::kCoveredElsewhere: return "covered by another surface";
  }
  return "unknown";
}

SurfaceDetail rebuild_detail(const Surface& surface, std::span<const MapCell* const> cells,
                             double resolution_m) {
  SurfaceDetail detail;
  const PlaneMoments moments = moments_of(surface);
  detail.moment_sum = moments.sum;
  detail.moment_outer = moments.sum_outer;
  const Plane3& plane = surface.plane;
  const Eigen::Vector3d centre = cells.empty() ? Eigen::Vector3d(-plane.offset * plane.normal)
                                               : vertex_centroid(cells.front()->vertices_m);
  detail.basis = tile_centred_basis(plane, centre, resolution_m);
  detail.footprint = Footprint(resolution_m);
  for (const MapCell* cell : cells)
    detail.footprint.add_polygon(project_to_basis(cell->vertices_m, detail.basis));
  return detail;
}

namespace {

/// Frame `frame_id` observed `surface` (a cell stored, fused or covered in it, or a merge):
/// frames_observed counts it once, last_observed_frame moves to it.
void observe(Surface& surface, std::uint64_t frame_id) {
  if (surface.frames_observed == 0 || surface.last_observed_frame != frame_id) ++surface.frames_observed;
  surface.last_observed_frame = std::max(surface.last_observed_frame, frame_id);
}

LabelState state_of_surface(const Surface& surface) {
  LabelState s;
  s.plane = surface.plane;
  s.moments = moments_of(surface);
  s.histogram = expand(surface.histogram);
  s.chromaticity = histogram_chromaticity(s.histogram);
  s.histogram_weight_m2 = surface.histogram_weight_m2;
  s.area_m2 = surface.area_m2;
  s.observed_area_m2 = surface.observed_area_m2;
  s.cells = surface.observations;
  return s;
}

/// How much of a new cell the map already holds, and where.
struct Coverage {
  double fraction = 0.0;             ///< share of the cell's grid points covered
  std::uint32_t surface = kNoSurface; ///< the surface covering most of them
};

/// Share of a cell (its coverage_grid `grid`) lying in a covering stored cell's polygon (projected
/// onto the cell's plane) or in a covering live surface's footprint (the cell's points projected
/// orthogonally onto its basis),
/// and the surface that covers most grid points (a stored cell counts for its surface; ties go to
/// the oldest surface). The grid points (coverage_grid) are tested in order, and the test stops
/// once the outcome against `min_fraction` is decided:
/// - the share can no longer reach min_fraction: `fraction` < min_fraction, `surface` unset;
/// - the share has reached it and no other surface can catch up with the leading one on the
///   points left: `fraction` (≥ min_fraction so far) and `surface` as the full test would give.
/// The step between two planes at m, one plane's point there: |n_b·m' + e_b| with m' = m − (n_a·m + e_a)·n_a
/// (m moved onto plane a). Two surfaces are of one plane where it is small.
double step_at(const Plane3& a, const Plane3& b, const Eigen::Vector3d& m) {
  return std::abs(b.signed_distance(m - a.signed_distance(m) * a.normal));
}

/// Whether `hit` holds at some point of the straight path from p to q, both moved onto `plane`,
/// sampled every 0.5 m from p (p included).
template <class Hit>
bool any_on_path(const Plane3& plane, const Eigen::Vector3d& p, const Eigen::Vector3d& q, Hit&& hit) {
  const Eigen::Vector3d pa = p - plane.signed_distance(p) * plane.normal;
  const Eigen::Vector3d pb = q - plane.signed_distance(q) * plane.normal;
  const double length = (pb - pa).norm();
  for (double t = 0.0; t <= length; t += 0.5)
    if (hit(Eigen::Vector3d(pa + (pb - pa) * (t / std::max(length, 1e-9))))) return true;
  return false;
}

Coverage coverage_of(const CoverageGrid& grid, std::span<const MapCell* const> cells,
                     std::span<const Surface* const> surfaces, double min_fraction) {
  if (grid.points.empty()) return {};
  std::vector<BoxedRing> rings;  // the cells projected into the grid's basis
  rings.reserve(cells.size());
  for (const MapCell* old : cells) rings.emplace_back(project_to_basis(old->vertices_m, grid.basis));
  // Points covered per surface, one slot per distinct surface id (a hit costs no lookup).
  std::vector<std::uint32_t> slot_surface;
  std::vector<std::size_t> hits;
  auto slot_of = [&](std::uint32_t id) {
    const auto it = std::find(slot_surface.begin(), slot_surface.end(), id);
    if (it != slot_surface.end()) return static_cast<std::size_t>(it - slot_surface.begin());
    slot_surface.push_back(id);
    hits.push_back(0);
    return slot_surface.size() - 1;
  };
  std::vector<std::size_t> cell_slot, surface_slot;
  for (const MapCell* old : cells) cell_slot.push_back(slot_of(old->surface));
  for (const Surface* s : surfaces) surface_slot.push_back(slot_of(s->id));
  constexpr auto kNone = static_cast<std::size_t>(-1);
  auto covering_slot = [&](const Eigen::Vector2d& st) {
    for (std::size_t i = 0; i < rings.size(); ++i)
      if (rings[i].contains(st)) return cell_slot[i];
    const Eigen::Vector3d p = grid.basis.to_3d(st);
    for (std::size_t j = 0; j < surfaces.size(); ++j) {
      const SurfaceDetail& detail = *surfaces[j]->detail;
      const Eigen::Vector2d q = detail.basis.to_2d(p);
      if (detail.footprint.contains(q.x(), q.y())) return surface_slot[j];
    }
    return kNone;
  };
  // The leading slot: most hits, ties to the smallest surface id.
  auto leader = [&] {
    std::size_t best = 0;
    for (std::size_t k = 1; k < hits.size(); ++k)
      if (hits[k] > hits[best] || (hits[k] == hits[best] && slot_surface[k] < slot_surface[best])) best = k;
    return best;
  };
  const std::size_t n = grid.points.size();
  std::size_t misses = 0, covered = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t slot = covering_slot(grid.points[i]);
    if (slot == kNone) {
      if (const double best = static_cast<double>(n - ++misses) / static_cast<double>(n); best < min_fraction)
        return {best, kNoSurface};
      continue;
    }
    ++covered, ++hits[slot];
    if (static_cast<double>(covered) / static_cast<double>(n) < min_fraction) continue;
    const std::size_t left = n - i - 1, lead = leader();
    bool decided = true;
    for (std::size_t k = 0; k < hits.size() && decided; ++k)
      decided = k == lead || hits[k] + left < hits[lead];
    if (decided) return {static_cast<double>(covered) / static_cast<double>(n), slot_surface[lead]};
  }
  Coverage c{static_cast<double>(covered) / static_cast<double>(n), kNoSurface};
  if (covered > 0) c.surface = slot_surface[leader()];
  return c;
}

}  // namespace

GlobalMap::GlobalMap(const MapConfig& config)
    : config_(config),
      up_(config.up_x, config.up_y, config.up_z),
      merger_(config),
      index_(config.index_cell_m) {
  if (!(up_.norm() > 1e-9) || !up_.allFinite())
    throw ConfigError("map.up_x/up_y/up_z: the up vector must be non-zero and finite");
  up_.normalize();
  if (!(config.max_range_m > 0.0))
    throw ConfigError("map.max_range_m: must be > 0, got " + std::to_string(config.max_range_m));
  (void)Footprint(config.footprint_resolution_m);  // validates the resolution (ConfigError)
  if (!(config.neighbour_gap_m >= 0.0))
    throw ConfigError("map.neighbour_gap_m: must be >= 0, got " + std::to_string(config.neighbour_gap_m));
  if (!(config.bridge_gap_m >= 0.0))
    throw ConfigError("map.bridge_gap_m: must be >= 0 (0 = off), got " + std::to_string(config.bridge_gap_m));
  if (config.bridge_long_gap_m != 0.0 &&
      (!(config.bridge_long_gap_m > config.bridge_gap_m) || !std::isfinite(config.bridge_long_gap_m) ||
       !(config.bridge_long_min_area_m2 >= 0.0) || !std::isfinite(config.bridge_long_min_area_m2) ||
       !(config.bridge_long_max_angle_deg > 0.0 && config.bridge_long_max_angle_deg <= 90.0) ||
       !(config.bridge_long_max_step_m > 0.0) || !std::isfinite(config.bridge_long_max_step_m) ||
       !(config.bridge_long_min_colour >= 0.0 && config.bridge_long_min_colour <= 1.0)))
    throw ConfigError("map.bridge_long_gap_m (" + std::to_string(config.bridge_long_gap_m) +
                      ") must be 0 (off) or a finite length > map.bridge_gap_m (" +
                      std::to_string(config.bridge_gap_m) +
                      "), with bridge_long_min_area_m2 >= 0, bridge_long_max_angle_deg in (0, 90], "
                      "bridge_long_max_step_m > 0 and bridge_long_min_colour in [0, 1]");
  if (!(config.bridge_max_cell_distance_m >= 0.0) || !std::isfinite(config.bridge_max_cell_distance_m))
    throw ConfigError("map.bridge_max_cell_distance_m: must be a finite distance >= 0 (0 = off), got " +
                      std::to_string(config.bridge_max_cell_distance_m));
  if (!(config.max_chromaticity_distance >= 0.0) || !std::isfinite(config.max_chromaticity_distance))
    throw ConfigError("map.max_chromaticity_distance: must be a finite chromaticity distance >= 0 (0 = off), got " +
                      std::to_string(config.max_chromaticity_distance));
  if (!(config.neighbour_max_rgb_distance >= 0.0) || !std::isfinite(config.neighbour_max_rgb_distance))
    throw ConfigError("map.neighbour_max_rgb_distance: must be a finite RGB distance >= 0 (0 = off), got " +
                      std::to_string(config.neighbour_max_rgb_distance));
  if (!(config.ground_join_gap_m >= 0.0) || !std::isfinite(config.ground_join_gap_m))
    throw ConfigError("map.ground_join_gap_m: must be finite and >= 0 (0 = off), got " +
                      std::to_string(config.ground_join_gap_m));
  if (!(config.ground_join_min_area_m2 >= 0.0) || !std::isfinite(config.ground_join_min_area_m2))
    throw ConfigError("map.ground_join_min_area_m2: must be a finite area >= 0, got " +
                      std::to_string(config.ground_join_min_area_m2));
  if (!(config.covered_elsewhere_min_colour >= 0.0 && config.covered_elsewhere_min_colour <= 1.0))
    throw ConfigError("map.covered_elsewhere_min_colour: must be a colour similarity in [0, 1], got " +
                      std::to_string(config.covered_elsewhere_min_colour));
  if (!(config.ground_join_min_colour >= 0.0 && config.ground_join_min_colour <= 1.0))
    throw ConfigError("map.ground_join_min_colour: must be a colour similarity in [0, 1], got " +
                      std::to_string(config.ground_join_min_colour));
  if (!(config.bridge_min_area_m2 >= 0.0))
    throw ConfigError("map.bridge_min_area_m2: must be >= 0 (0 = any), got " +
                      std::to_string(config.bridge_min_area_m2));
  if (!(config.min_inlier_ratio >= 0.0 && config.min_inlier_ratio <= 1.0))
    throw ConfigError("map.min_inlier_ratio: must be in [0, 1] (0 = no gate), got " +
                      std::to_string(config.min_inlier_ratio));
  if (config.dormant_after_frames < 0)
    throw ConfigError("map.dormant_after_frames: must be >= 0 (0 = never), got " +
                      std::to_string(config.dormant_after_frames));
  if (config.dormant_after_frames > 0 && config.dormant_after_frames < config.consolidate_after_frames)
    throw ConfigError("map.dormant_after_frames (" + std::to_string(config.dormant_after_frames) +
                      ") must be >= map.consolidate_after_frames (" +
                      std::to_string(config.consolidate_after_frames) +
                      "): a surface is consolidated before it goes dormant");
  if (!(config.fragment_max_area_m2 >= 0.0) || !std::isfinite(config.fragment_max_area_m2))
    throw ConfigError("map.fragment_max_area_m2: must be >= 0 (0 = off), got " +
                      std::to_string(config.fragment_max_area_m2));
  if (config.fragment_max_area_m2 > 0.0 &&
      (!(config.fragment_redundant_m > 0.0) || !std::isfinite(config.fragment_redundant_m)))
    throw ConfigError("map.fragment_redundant_m: must be > 0 when fragment_max_area_m2 > 0, got " +
                      std::to_string(config.fragment_redundant_m));
  if (!(config.fragment_join_max_area_m2 >= 0.0) || !std::isfinite(config.fragment_join_max_area_m2))
    throw ConfigError("map.fragment_join_max_area_m2: must be >= 0 (0 = off), got " +
                      std::to_string(config.fragment_join_max_area_m2));
  if (config.fragment_join_max_area_m2 > 0.0 &&
      (!(config.fragment_join_distance_m > 0.0) || !std::isfinite(config.fragment_join_distance_m) ||
       !(config.fragment_join_angle_deg > 0.0 && config.fragment_join_angle_deg <= 90.0)))
    throw ConfigError("map.fragment_join_distance_m (" + std::to_string(config.fragment_join_distance_m) +
                      ") must be > 0 and map.fragment_join_angle_deg (" +
                      std::to_string(config.fragment_join_angle_deg) +
                      ") in (0, 90] when fragment_join_max_area_m2 > 0");
  if (!(config.fragment_join_sigma_factor >= 0.0) || !std::isfinite(config.fragment_join_sigma_factor))
    throw ConfigError("map.fragment_join_sigma_factor: must be >= 0 (0 = off), got " +
                      std::to_string(config.fragment_join_sigma_factor));
  if (!(config.fragment_join_noise_colour >= 0.0 && config.fragment_join_noise_colour <= 1.0))
    throw ConfigError("map.fragment_join_noise_colour: must be in [0, 1] (a histogram intersection), got " +
                      std::to_string(config.fragment_join_noise_colour));
  if (config.consolidate_after_frames > 0) {
    auto positive = [](const char* key, double value) {
      if (!(value > 0.0) || !std::isfinite(value))
        throw ConfigError(std::string("map.") + key +
                          ": must be > 0 when consolidate_after_frames > 0, got " +
                          std::to_string(value));
    };
    positive("consolidate_tile_m", config.consolidate_tile_m);
    positive("consolidate_resolution_m", config.consolidate_resolution_m);
    positive("consolidate_square_reach_m", config.consolidate_square_reach_m);
    if (!(config.consolidate_max_hole_m2 >= 0.0) || !std::isfinite(config.consolidate_max_hole_m2))
      throw ConfigError("map.consolidate_max_hole_m2: must be >= 0, got " +
                        std::to_string(config.consolidate_max_hole_m2));
    if (!(config.consolidate_tolerance_m >= 0.0) || !std::isfinite(config.consolidate_tolerance_m))
      throw ConfigError("map.consolidate_tolerance_m: must be >= 0, got " +
                        std::to_string(config.consolidate_tolerance_m));
    if (!(config.consolidate_max_distance_m >= 0.0))
      throw ConfigError("map.consolidate_max_distance_m: must be >= 0, got " +
                        std::to_string(config.consolidate_max_distance_m));
  }
}

bool same_surface(const Surface& a, const Surface& b) {
  return a.id == b.id && a.observations == b.observations &&
         a.last_observed_frame == b.last_observed_frame && a.frames_observed == b.frames_observed && a.plane == b.plane && a.information == b.information &&
         a.histogram == b.histogram && a.histogram_weight_m2 == b.histogram_weight_m2 &&
         a.mean_rgb == b.mean_rgb && a.observed_area_m2 == b.observed_area_m2 &&
         a.area_m2 == b.area_m2 && a.bounds == b.bounds && a.cells == b.cells &&
         a.detail == b.detail && a.quiet_moments == b.quiet_moments;
}

std::vector<std::uint32_t> GlobalMap::cells_near(const Aabb& box) const { return query_cells(box); }

void GlobalMap::absorb_surface(std::uint32_t into_id, std::uint32_t absorbed_id, std::set<std::uint32_t>& touched,
                               MergeReport& report) {
  Surface& into = surfaces_.at(into_id);
  Surface& absorbed = surfaces_.at(absorbed_id);
  wake(into);  // the CRF's labels are awake already; a bridge tests dormant surfaces asleep
  wake(absorbed);
  for (std::uint32_t id : absorbed.cells) {
    cells_.at(id).surface = into.id;
    into.cells.push_back(id);
    report.relabelled_cells.push_back(id);
  }
  // Footprint bits move to into's basis through 3D (bit centres; ≤ one bit of blur).
  SurfaceDetail& to = *into.detail;
  const SurfaceDetail& from = *absorbed.detail;
  for (const Eigen::Vector2d& st : from.footprint.covered_centres()) {
    const Eigen::Vector2d moved = to.basis.to_2d(from.basis.to_3d(st));
    to.footprint.add_point(moved.x(), moved.y());
  }
  const double w = into.observed_area_m2 + absorbed.observed_area_m2;
  if (w > 0.0)
    into.mean_rgb = ((into.mean_rgb * into.observed_area_m2 + absorbed.mean_rgb * absorbed.observed_area_m2) / w)
                        .cast<float>();
  into.observed_area_m2 = static_cast<float>(w);
  into.area_m2 = static_cast<float>(to.footprint.area_m2());
  into.bounds.extend(absorbed.bounds);
  into.observations += absorbed.observations;
  // The frames that observed the two are not known one by one: the larger count, then this frame
  // (counted unless one of them was observed in it already).
  into.frames_observed = std::max(into.frames_observed, absorbed.frames_observed);
  into.last_observed_frame = std::max(into.last_observed_frame, absorbed.last_observed_frame);
  observe(into, report.frame_id);
  surfaces_.erase(absorbed_id);
  touched.erase(absorbed_id);
  touched.insert(into_id);
  report.removed_surfaces.push_back(absorbed_id);
  report.surface_merges.push_back({report.frame_id, absorbed_id, into_id});
}

MergeReport GlobalMap::integrate(std::uint64_t frame_id, const Pose& T_world_cam,
                                 std::span<const Planecell> cells_world,
                                 std::span<const LabelEdge> image_adjacency) {
  const auto start = std::chrono::steady_clock::now();
  validate_pose(T_world_cam, "frame " + std::to_string(frame_id));
  MergeReport report;
  report.frame_id = frame_id;
  report.input_cells = cells_world.size();

  // 1. Usable new cells within range; fresh labels next_surface_id_ + k.
  const Eigen::Vector3d camera_centre = T_world_cam.translation();
  std::vector<const Planecell*> fresh;
  std::vector<std::size_t> fresh_input;  ///< index of fresh[k] in cells_world
  std::vector<double> fresh_area;
  std::vector<Aabb> fresh_box;  ///< each new cell's bounds, computed once
  report.cell_surfaces.assign(cells_world.size(), kNoSurface);
  report.cell_fates.assign(cells_world.size(), CellFate::kRejected);
  std::unordered_map<std::uint32_t, std::uint32_t> unit_of_extraction_id;
  unit_of_extraction_id.reserve(cells_world.size());
  for (std::size_t i = 0; i < cells_world.size(); ++i) {
    const Planecell& cell = cells_world[i];
    // The cell's own fields first (cheap), then its geometry.
    if (!cell.has_plane || (config_.max_depth_sigma_m > 0.0 && cell.depth_sigma_m > config_.max_depth_sigma_m) ||
        (cell.inlier_ratio > 0.0f && cell.inlier_ratio < config_.min_inlier_ratio) ||
        !cell_problem(cell.plane, cell.vertices_m, index_.max_coordinate_m()).empty() ||
        (vertex_centroid(cell.vertices_m) - camera_centre).norm() > config_.max_range_m) {
      ++report.rejected_cells;
      continue;
    }
    unit_of_extraction_id[cell.id] = static_cast<std::uint32_t>(fresh.size());
    fresh.push_back(&cell);
    fresh_input.push_back(i);
    fresh_area.push_back(polygon_area_m2(cell.vertices_m));
    fresh_box.push_back(bounds_of(cell.vertices_m));
  }
  if (fresh.size() > 0xFFFFFFFFull - next_surface_id_)
    throw StorageError("global map: surface labels exhausted");

  std::vector<MergeUnit> units;
  std::unordered_map<std::uint32_t, LabelState> labels;
  labels.reserve(2 * fresh.size());  // the new cells' labels and about as many of the map's
  /// Each new cell's depth noise as coverage counts it (MapConfig::coverage_normal_noise).
  std::vector<double> coverage_sigma(fresh.size());
  for (std::size_t k = 0; k < fresh.size(); ++k) {
    const auto label = next_surface_id_ + static_cast<std::uint32_t>(k);
    units.push_back({label, fresh[k]->plane, fresh[k]->vertices_m, &fresh[k]->histogram, fresh_area[k]});
    // The range widens by the noise along the normal (MapConfig::normal_depth_noise); the plane
    // fits keep weighting by σ_Z.
    const double sigma_z = static_cast<double>(fresh[k]->depth_sigma_m);
    const double sigma_n = config_.normal_depth_noise || config_.coverage_normal_noise
                               ? normal_depth_sigma_m(*fresh[k], camera_centre)
                               : sigma_z;
    const double range_sigma = config_.normal_depth_noise ? sigma_n : sigma_z;
    coverage_sigma[k] = config_.coverage_normal_noise ? sigma_n : sigma_z;
    labels.emplace(label, state_of_cell(*fresh[k], fresh_area[k], range_sigma, config_.residual_scale_m,
                                        config_.normal_sigma_scale));
  }

  // 2. Neighbour edges: same frame (image adjacency, or 3D proximity), earlier cells (index).
  std::vector<MergeEdge> edges;
  const double gap = config_.neighbour_gap_m;
  auto metres_per_px = [&](std::size_t k) {
    const auto px = fresh[k]->area_px;
    return px > 0 ? std::sqrt(fresh_area[k] / px) : 0.01;
  };
  if (!image_adjacency.empty()) {
    for (const auto& e : image_adjacency) {
      auto ia = unit_of_extraction_id.find(e.a), ib = unit_of_extraction_id.find(e.b);
      if (ia == unit_of_extraction_id.end() || ib == unit_of_extraction_id.end()) continue;
      const double m_per_px = 0.5 * (metres_per_px(ia->second) + metres_per_px(ib->second));
      edges.push_back({ia->second, ib->second, e.boundary_px * m_per_px});
    }
  } else {
    SpatialIndex frame_index(config_.index_cell_m);
    for (std::size_t k = 0; k < fresh.size(); ++k) frame_index.insert(static_cast<std::uint32_t>(k), fresh_box[k]);
    const auto box_of = [&](std::uint32_t j) { return fresh_box[j]; };
    for (std::size_t k = 0; k < fresh.size(); ++k)
      for (std::uint32_t j : frame_index.query(fresh_box[k].inflated(gap), box_of)) {
        if (j <= k) continue;
        // Within the gap (polygons_within_m: early exit), not the whole polygon_gap_m.
        if (!polygons_within_m(fresh[k]->plane, fresh[k]->vertices_m, fresh_box[k], fresh[j]->plane,
                               fresh[j]->vertices_m, fresh_box[j], gap))
          continue;
        edges.push_back({static_cast<std::uint32_t>(k), j,
                         std::sqrt(std::min(fresh_area[k], fresh_area[j]))});
      }
  }
  // Stored cells near each new cell, in one index query: neighbour edges (within the gap) and
  // the cells and surfaces that may cover it (re-observation by coverage, step 5; tol ≥ gap).
  std::vector<std::vector<const MapCell*>> superseded(fresh.size());  ///< ... and much less precise
  std::vector<std::vector<std::uint32_t>> covering_surfaces(fresh.size());  ///< nearly coplanar
  const bool coverage_rule = config_.redundant_coverage <= 1.0;
  // Surfaces with a single observation, stored long enough ago, whose place new cells reach
  // again: pruned at the end of the frame unless this frame confirms them.
  std::set<std::uint32_t> unconfirmed;
  const auto max_age = static_cast<std::uint64_t>(std::max(0, config_.unconfirmed_max_age_frames));
  const auto confirm = static_cast<std::uint32_t>(std::max(1, config_.confirm_frames));
  const double reach = coverage_rule ? std::max(gap, config_.redundant_max_distance_m) : gap;
  /// The plane distance within which a surface's footprint covers a new cell (collect_coverage):
  /// the cell's own noise, at least residual_scale_m and at most the neighbour gap.
  const double surface_tol_min = config_.residual_scale_m;
  const double surface_tol_max = std::max(surface_tol_min, gap);
  std::vector<std::uint32_t> nearby;  // index candidates of one new cell (storage reused)
  /// Stored cells met this frame with their surface and bounds, and their polygon decoded
  /// (StoredPolygon) the first time a test needs it: neighbouring new cells share most of their
  /// candidates, so each stored cell is decoded once per frame, not once per new cell (nothing is
  /// added to or removed from the map before step 5). The merge units of stored cells view those
  /// vertices (hash nodes do not move; both live to the end of integrate).
  struct MetCell {
    const MapCell* cell = nullptr;
    const Surface* surface = nullptr;
    Aabb box;
    std::vector<Eigen::Vector3f> vertices;  ///< empty until decoded (a map polygon has ≥ 3)
    std::uint32_t unit = kNoUnit;            ///< its merge unit, once it neighbours a new cell
    std::span<const Eigen::Vector3f> polygon() {
      if (vertices.empty()) cell->vertices_m.vertices_into(vertices);
      return vertices;
    }
  };
  std::unordered_map<std::uint32_t, MetCell> met_cells;
  /// A stored cell that may cover a new one (not much less precise than it), and whether it is a
  /// neighbour of the new cell (within the gap already); its tolerances are made when tested.
  struct CoveringTest {
    MetCell* met = nullptr;
    bool neighbour = false;
  };
  /// The coverage tolerances of new cell k against a stored cell of depth noise old_sigma_m: the
  /// noise r·√(σ_new² + σ_old²) (r = redundant_sigma_factor; σ_new = coverage_sigma[k], σ_old the
  /// stored cell's σ_Z) clamped to [gap, reach] as the
  /// distance, and the normal angle base + atan(noise / √area_k), at most 2·base.
  struct Tolerances {
    double angle_deg;
    double tol;
  };
  const auto tolerances_of = [&](std::size_t k, float old_sigma_m) {
    const double sigma = std::hypot(coverage_sigma[k], static_cast<double>(old_sigma_m));
    const double noise = config_.redundant_sigma_factor * sigma;
    const double base_deg = config_.redundant_normal_angle_deg;
    const double widened_deg =
        base_deg + std::atan(noise / std::sqrt(fresh_area[k])) * 180.0 / M_PI;
    return Tolerances{std::min(2.0 * base_deg, widened_deg), std::clamp(noise, gap, reach)};
  };
  /// Do a new cell and a stored cell it meets look alike: mean colours within
  /// MapConfig::neighbour_max_rgb_distance (0 = off)?
  const double max_rgb = config_.neighbour_max_rgb_distance;
  const auto colours_near = [max_rgb](const Planecell& cell, const MapCell& old) {
    return !(max_rgb > 0.0) || (cell.mean_rgb - Eigen::Vector3f(old.mean_rgb)).norm() <= max_rgb;
  };
  /// Does the stored cell cover the new cell: its polygon within tol of the new cell's plane,
  /// normals within angle_deg, the polygons within tol of each other.
  const auto covers_test = [](const Planecell& cell, const Aabb& box, MetCell& met, double angle_deg, double tol,
                              bool neighbour) {
    const MapCell& old = *met.cell;
    return nearly_coplanar(cell.plane, old.plane, met.polygon(), angle_deg, tol) &&
           (neighbour || polygons_within_m(cell.plane, cell.vertices_m, box, old.plane, met.polygon(), met.box, tol));
  };
  /// The stored cells to test as covering each new cell, in index order: tested in step 5 only
  /// for the cells whose fate the coverage decides.
  std::vector<std::vector<CoveringTest>> covering_tests(fresh.size());
  // Coverage accepts normals at most 2·redundant_normal_angle_deg apart (nearly_coplanar below):
  // a stored cell tilted more against the new cell, and on a surface tilted more, is skipped
  // before the per-pair angle is computed.
  const double min_coverage_cos = std::cos(2.0 * config_.redundant_normal_angle_deg * M_PI / 180.0);
  /// A re-observation found before the neighbour search (MapConfig::prefuse_reobservations):
  /// the first stored cell within the gap of new cell k (index order) whose surface S is live,
  /// passes the CRF's variation range with the cell (CrfMerger::evaluate_range) and would gain
  /// less than fuse_new_area_fraction of the cell's area in its footprint. Not when S is known
  /// only from much less precise views than k's (σ_eff > redundant_precision_ratio · σ_Z): k may
  /// replace S's cells, which the regular path decides. k then meets S in the CRF through that
  /// one cell, not through every stored cell near it, and its coverage is not collected: if the
  /// CRF gives it S's label, step 5 fuses it into S with the raster kept here; else step 5
  /// collects its coverage from the stored cells it met.
  struct Reobserved {
    std::uint32_t cell = 0;              ///< the stored cell through which k meets S
    std::uint32_t surface = kNoSurface;  ///< S; kNoSurface: not found first
    FootprintRaster raster;              ///< k on S's footprint grid
  };
  std::vector<Reobserved> reobserved(fresh.size());
  /// A surface the search found in range of the new cell (or much less precise than it), none of
  /// its cells within the gap yet: its precision test, and its label state when the map's labels
  /// had none (made for the range test, kept for the CRF should the surface be taken).
  struct Ranged {
    std::uint32_t surface = kNoSurface;
    bool imprecise = false;
    std::optional<LabelState> made;
  };
  std::vector<std::uint32_t> tried;  // the search's surfaces done with, for one new cell (storage reused)
  std::vector<Ranged> ranged;        // its surfaces in range (storage reused)
  /// within[i]: whether new cell k lies within the gap of its candidate ids[i] (polygons_within_m),
  /// −1 untested: the search's tests, reused by the neighbour search (storage reused).
  std::vector<std::int8_t> within;
  /// The index's candidates of a bucket range (SpatialIndex::BucketRange: lo, hi, empty), with their
  /// met_cells entries and their bounds side by side (the per-cell bounds test runs over one
  /// contiguous array, not through the hash nodes): candidates(box) depends on the box only through
  /// the buckets it touches, and neighbouring new cells mostly touch the same ones, so each range
  /// is queried once a frame.
  struct RangeCandidates {
    std::vector<std::uint32_t> ids;
    std::vector<MetCell*> met_at;
    std::vector<Aabb> boxes;
  };
  std::map<std::array<std::int64_t, 7>, RangeCandidates> candidates_of_range;
  /// The positions i in a range's candidates whose bounds meet new cell k's reach, in index order
  /// (storage reused).
  std::vector<std::uint32_t> reached;
  const auto find_reobserved = [&](std::size_t k, const Aabb& near_box, std::span<const std::uint32_t> ids,
                                   std::span<MetCell* const> met_at) {
    const Planecell& cell = *fresh[k];
    // The search ends at the first candidate within the gap whose surface S decides it: S is
    // taken (in range, footprint test passed) or S is much less precise (the regular path). A
    // surface that cannot decide (dormant, out of the CRF's range) is set aside before its cells'
    // polygons are tested, and the footprint test runs on the first of its cells within the gap.
    tried.clear();   // surfaces done with: set aside, or met within the gap and not taken
    ranged.clear();  // surfaces in range of k (or much less precise), none of their cells within yet
    for (const std::uint32_t i : reached) {
      const std::uint32_t id = ids[i];
      MetCell& met = *met_at[i];
      const std::uint32_t surface_id = met.cell->surface;
      if (!met.box.overlaps(near_box) ||
          std::find(tried.begin(), tried.end(), surface_id) != tried.end())
        continue;
      const Surface& surface = *met.surface;
      auto seen = std::find_if(ranged.begin(), ranged.end(), [&](const Ranged& r) { return r.surface == surface_id; });
      if (seen == ranged.end()) {
        if (!surface.detail || surface.detail->footprint.empty()) {  // dormant: the regular path
          tried.push_back(surface_id);
          continue;
        }
        // Known only from much less precise views: the regular path (k may replace its cells).
        Ranged r{surface_id, effective_sigma_m(surface.information, surface.observed_area_m2) >
                                 config_.redundant_precision_ratio *
                                     std::max<double>(cell.depth_sigma_m, config_.residual_scale_m),
                 std::nullopt};
        if (!r.imprecise) {
          const auto state_it = labels.find(surface_id);
          const LabelState& state =
              state_it != labels.end() ? state_it->second : r.made.emplace(state_of_surface(surface));
          if (!merger_.evaluate_range(units[k], labels.at(units[k].label), units[k], state).in_range) {
            tried.push_back(surface_id);
            continue;
          }
        }
        ranged.push_back(std::move(r));
        seen = ranged.end() - 1;
      }
      within[i] = polygons_within_m(cell.plane, cell.vertices_m, fresh_box[k], met.cell->plane,
                                    met.polygon(), met.box, gap);
      if (!within[i]) continue;
      if (seen->imprecise) return false;
      if (!colours_near(cell, *met.cell)) continue;  // another of S's cells may be near in colour
      tried.push_back(surface_id);
      const SurfaceDetail& detail = *surface.detail;
      FootprintRaster raster =
          detail.footprint.rasterise(project_to_basis(cell.vertices_m, detail.basis));
      if (!(detail.footprint.new_area_m2(raster) < config_.fuse_new_area_fraction * fresh_area[k]))
        continue;
      if (seen->made) labels.emplace(surface_id, std::move(*seen->made));  // S's label state, for the CRF
      reobserved[k] = {id, surface_id, std::move(raster)};
      return true;
    }
    return false;
  };
  /// Coverage between new cell k and the stored cell `met` (on `surface`; `neighbour`: within
  /// the gap): whether k covers it and it is much less precise (superseded), or else whether it
  /// may cover k (covering_tests, tested in step 5); and whether its surface may cover k
  /// (covering_surfaces).
  const auto collect_coverage = [&](std::size_t k, MetCell& met, const Surface& surface,
                                    bool neighbour) {
    const Planecell& cell = *fresh[k];
    const MapCell& old = *met.cell;
    if (std::abs(cell.plane.normal.dot(old.plane.normal())) < min_coverage_cos &&
        std::abs(cell.plane.normal.dot(surface.plane.normal())) < min_coverage_cos)
      return;
    const bool less_precise =
        old.depth_sigma_m > config_.redundant_precision_ratio * cell.depth_sigma_m;
    std::optional<Tolerances> tolerances;  // made for the first test that needs them
    const auto tolerances_here = [&]() -> const Tolerances& {
      if (!tolerances) tolerances = tolerances_of(k, old.depth_sigma_m);
      return *tolerances;
    };
    if (!less_precise) {
      covering_tests[k].push_back({&met, neighbour});  // when needed (step 5)
    } else if (const Tolerances& t = tolerances_here();
               covers_test(cell, fresh_box[k], met, t.angle_deg, t.tol, neighbour)) {
      superseded[k].push_back(&old);
    }
    // The surface of a nearby cell covers the cell where its footprint (every observation
    // fused into it, stored or not) holds the cell's points, when its plane passes within the
    // cell's own noise and it is not much less precise than the cell (then the cell is stored,
    // as above): its σ_eff at most redundant_precision_ratio × the cell's σ (floored like the
    // surfaces' moments). The noise is not floored at the neighbour gap as for stored cells (the
    // footprint may hold noisy views) and counts up to that gap, not beyond: a footprint keeps no
    // planes of its fused views to test the cell against, and a plane farther than the gap is
    // another surface (a kerb's 15 cm, a step) as often as noise.
    auto& candidates = covering_surfaces[k];
    if (std::find(candidates.begin(), candidates.end(), old.surface) != candidates.end()) return;
    const double surface_tol = std::clamp(config_.redundant_sigma_factor * coverage_sigma[k],
                                          surface_tol_min, surface_tol_max);
    const double max_surface_sigma =
        config_.redundant_precision_ratio *
        std::max<double>(cell.depth_sigma_m, config_.residual_scale_m);
    if (effective_sigma_m(surface.information, surface.observed_area_m2) <= max_surface_sigma &&
        nearly_coplanar(surface.plane, cell.plane, cell.vertices_m, tolerances_here().angle_deg,
                        surface_tol)) {
      wake(surfaces_.at(old.surface));  // a dormant surface covers with its rebuilt footprint
      if (!surface.detail->footprint.empty()) candidates.push_back(old.surface);
    }
  };
  for (std::size_t k = 0; k < fresh.size(); ++k) {
    const Planecell& cell = *fresh[k];
    const Aabb& box = fresh_box[k];
    const Aabb near_box = box.inflated(gap);
    // The index's candidates, filtered by their bounds.
    const Aabb reach_box = box.inflated(reach);
    const SpatialIndex::BucketRange range = index_.bucket_range(reach_box);
    auto [memo, first_range] = candidates_of_range.try_emplace(
        {range.lo[0], range.lo[1], range.lo[2], range.hi[0], range.hi[1], range.hi[2], range.empty});
    auto& [ids, met_at, boxes] = memo->second;
    if (first_range) {
      index_.candidates(reach_box, ids);
      // Each candidate's entry, looked up once for the search and the neighbour loop (hash
      // nodes do not move).
      for (std::uint32_t id : ids) {
        auto [met, first_time] = met_cells.try_emplace(id);
        if (first_time) {
          const MapCell& c = cells_.at(id);
          met->second = {&c, &surfaces_.at(c.surface), bounds_of(c.vertices_m), {}, kNoUnit};
        }
        met_at.push_back(&met->second);
        boxes.push_back(met->second.box);
      }
    }
    reached.clear();
    for (std::size_t i = 0; i < boxes.size(); ++i)
      if (boxes[i].overlaps(reach_box)) reached.push_back(static_cast<std::uint32_t>(i));
    within.assign(ids.size(), -1);
    const bool prefused =
        config_.prefuse_reobservations && find_reobserved(k, near_box, ids, met_at);
    for (const std::uint32_t i : reached) {
      const std::uint32_t id = ids[i];
      MetCell& met_cell = *met_at[i];
      const MapCell& old = *met_cell.cell;
      const Aabb& old_box = met_cell.box;
      const Surface& surface = *met_cell.surface;
      if (max_age > 0 && surface.frames_observed < confirm && surface.last_observed_frame + max_age <= frame_id)
        unconfirmed.insert(old.surface);
      // A re-observation found first meets its surface through that one cell.
      const bool neighbour =
          prefused
              ? id == reobserved[k].cell
              : near_box.overlaps(old_box) &&
                    (within[i] >= 0 ? within[i] == 1
                                    : polygons_within_m(cell.plane, cell.vertices_m, box, old.plane,
                                                        met_cell.polygon(), old_box, gap));
      if (neighbour && colours_near(cell, old)) {
        if (met_cell.unit == kNoUnit) {
          met_cell.unit = static_cast<std::uint32_t>(units.size());
          units.push_back({old.surface, old.plane, met_cell.polygon(), nullptr, polygon_area_m2(met_cell.polygon())});
          if (!labels.contains(old.surface)) {
            wake(surfaces_.at(old.surface));  // its label state needs the moments
            labels.emplace(old.surface, state_of_surface(surface));
          }
        }
        edges.push_back({static_cast<std::uint32_t>(k), met_cell.unit,
                         std::sqrt(std::min(fresh_area[k], units[met_cell.unit].area_m2))});
      }
      if (!coverage_rule) continue;
      // A re-observation found first is tested for coverage only if step 5 needs it after all.
      if (!prefused) collect_coverage(k, met_cell, surface, neighbour);
    }
  }

  // 3. Circular greedy CRF merging.
  UnionFind union_find;
  const auto merges = merger_.merge(units, edges, labels, union_find);

  // 4. Surface merges between existing surfaces (root < absorbed, both existed before).
  std::set<std::uint32_t> touched;
  for (const auto& [absorbed, root] : merges) {
    if (absorbed >= next_surface_id_) continue;  // a fresh label joined a surface: not an event
    absorb_surface(root, absorbed, touched, report);
  }
  for (const auto& [absorbed, root] : merges)
    if (root < next_surface_id_ && surfaces_.contains(root)) touched.insert(root);

  // 5. New cells: create surfaces for fresh roots, fuse or store each cell.
  /// Stored cell id → (that cell, the new stored cells superseding it); by id, so replacement is
  /// deterministic.
  std::map<std::uint32_t, std::pair<const MapCell*, std::vector<const Planecell*>>> superseding;
  std::vector<std::uint32_t> created_surfaces;
  for (std::size_t k = 0; k < fresh.size(); ++k) {
    const Planecell& cell = *fresh[k];
    const std::uint32_t root = union_find.find(units[k].label);
    const double area = fresh_area[k];
    // A cell whose label is a surface already, adding less than fuse_new_area_fraction of its
    // area to that surface's footprint and not covering the much less precise stored cells it
    // might replace, is fused below whatever its coverage: the footprint's answer comes first
    // (rasterised before the footprint changes), the coverage test only for the cells it leaves.
    const auto root_it = surfaces_.find(root);
    const auto raster_on = [&](const SurfaceDetail& detail) {  // the cell on a surface's footprint grid
      return detail.footprint.rasterise(project_to_basis(cell.vertices_m, detail.basis));
    };
    FootprintRaster raster;
    std::optional<CoverageGrid> grid;  ///< the cell's coverage_grid, made when a coverage test needs it
    const auto grid_of = [&]() -> const CoverageGrid& {
      if (!grid) grid = coverage_grid(cell.plane, cell.vertices_m);
      return *grid;
    };
    std::optional<bool> covers_superseded;  ///< covers_at_least(cell, superseded[k]), once computed
    bool settled_by_footprint = false;
    bool found_first = false;  ///< settled by the raster of the re-observation search
    if (root_it != surfaces_.end()) {
      wake(root_it->second);  // a CRF label already: live
      const SurfaceDetail& detail = *root_it->second.detail;
      if (reobserved[k].surface == root) {
        // Found first on this surface: its footprint has only grown since (step 4's merges, this
        // step's earlier cells), so the cell still adds less than the fraction; its superseded
        // cells are not collected.
        raster = std::move(reobserved[k].raster);
        settled_by_footprint = found_first = true;
        ++report.prefused_cells;
      } else if (raster = raster_on(detail);
                 !detail.footprint.empty() &&
                 detail.footprint.new_area_m2(raster) < config_.fuse_new_area_fraction * area)
        settled_by_footprint =
            superseded[k].empty() ||
            !*(covers_superseded = covers_at_least(grid_of(), superseded[k], config_.redundant_coverage));
    }
    // Space the map already holds (any surface): a re-observation, fused without being stored,
    // into its own label's surface when that exists already, else into the first covering cell's.
    std::vector<const Surface*> covering_surface;  // alive after step 4's merges
    std::vector<const MapCell*> covering;          // stored cells covering it
    if (!settled_by_footprint) {
      // A re-observation found first that the CRF labelled otherwise: its coverage after all, by
      // the stored cells it met (those of step 2's query: met, unlike this frame's new cells) as
      // they are now (their surfaces after step 4's merges).
      if (reobserved[k].surface != kNoSurface) {
        const Aabb reach_box = fresh_box[k].inflated(reach);
        index_.candidates(reach_box, nearby);
        for (std::uint32_t id : nearby)
          if (const auto met = met_cells.find(id);
              met != met_cells.end() && met->second.box.overlaps(reach_box))
            collect_coverage(k, met->second, surfaces_.at(met->second.cell->surface), false);
      }
      for (const CoveringTest& test : covering_tests[k])
        if (const Tolerances t = tolerances_of(k, test.met->cell->depth_sigma_m);
            colours_near(cell, *test.met->cell) &&
            covers_test(cell, fresh_box[k], *test.met, t.angle_deg, t.tol, test.neighbour))
          covering.push_back(test.met->cell);
      // A surface of another paint does not cover the cell (MapConfig::max_chromaticity_distance),
      // nor one other than its CRF label unless their colours are alike
      // (MapConfig::covered_elsewhere_min_colour).
      const Eigen::Vector3d chromaticity =
          covering_surfaces[k].empty() ? Eigen::Vector3d::Zero() : histogram_chromaticity(cell.histogram);
      const double min_colour = config_.covered_elsewhere_min_colour;
      for (std::uint32_t id : covering_surfaces[k]) {
        const auto it = surfaces_.find(union_find.find(id));
        if (it == surfaces_.end() || !it->second.detail ||
            std::find(covering_surface.begin(), covering_surface.end(), &it->second) != covering_surface.end())
          continue;
        const ColourHistogram histogram = expand(it->second.histogram);  // once for both tests
        if (other_paint(histogram_chromaticity(histogram), chromaticity, config_.max_chromaticity_distance) ||
            (min_colour > 0.0 && it->second.id != root && colour_similarity(cell.histogram, histogram) < min_colour))
          continue;
        covering_surface.push_back(&it->second);
      }
    }
    const Coverage coverage = !settled_by_footprint && coverage_rule && (!covering.empty() || !covering_surface.empty())
                                  ? coverage_of(grid_of(), covering, covering_surface, config_.redundant_coverage)
                                  : Coverage{};
    const bool redundant = coverage.fraction >= config_.redundant_coverage;
    const std::uint32_t cover_surface = coverage.surface;
    if (redundant && !surfaces_.contains(root) && surfaces_.contains(cover_surface)) {
      Surface& covering_surface = surfaces_.at(cover_surface);
      ++covering_surface.observations;  // a re-observation confirms the surface
      observe(covering_surface, frame_id);
      touched.insert(cover_surface);
      report.cell_surfaces[fresh_input[k]] = cover_surface;
      report.cell_fates[fresh_input[k]] = CellFate::kCoveredElsewhere;
      ++report.fused_cells;
      ++report.redundant_cells;
      continue;
    }
    auto [it, created] = surfaces_.try_emplace(root);
    Surface& surface = it->second;
    if (created) {
      created_surfaces.push_back(root);
      surface.id = root;
      SurfaceDetail detail;
      detail.basis = tile_centred_basis(labels.at(root).plane, vertex_centroid(cell.vertices_m),
                                        config_.footprint_resolution_m);
      detail.footprint = Footprint(config_.footprint_resolution_m);
      surface.detail.emplace(std::move(detail));
      if (config_.dormant_after_frames > 0) dormancy_clock_.emplace(frame_id, root);
      raster = raster_on(*surface.detail);
    }
    touched.insert(root);
    report.cell_surfaces[fresh_input[k]] = root;
    observe(surface, frame_id);
    SurfaceDetail& detail = *surface.detail;
    const bool had_footprint = !detail.footprint.empty();
    const double added = detail.footprint.add(raster);
    const double w = surface.observed_area_m2 + area;
    surface.mean_rgb = ((surface.mean_rgb * surface.observed_area_m2 + cell.mean_rgb * area) / w).cast<float>();
    surface.observed_area_m2 = static_cast<float>(w);
    // Incremental: per-frame work stays local to the new cells.
    surface.area_m2 = static_cast<float>(surface.area_m2 + added);
    surface.bounds.extend(fresh_box[k]);
    ++surface.observations;
    // A re-observation lying on much less precise stored cells is stored (and replaces them
    // below) instead of being fused: the map keeps the nearer, better view of each place.
    const bool supersedes =
        !redundant && !superseded[k].empty() &&
        (covers_superseded ? *covers_superseded : covers_at_least(grid_of(), superseded[k], config_.redundant_coverage));
    if (had_footprint && !supersedes &&
        (redundant || added < config_.fuse_new_area_fraction * area)) {
      ++report.fused_cells;
      const bool by_coverage = redundant && added >= config_.fuse_new_area_fraction * area;
      if (by_coverage) ++report.redundant_cells;
      report.cell_fates[fresh_input[k]] = found_first   ? CellFate::kFusedFoundFirst
                                          : by_coverage ? CellFate::kFusedByCoverage
                                                        : CellFate::kFusedByFootprint;
      continue;
    }
    report.cell_fates[fresh_input[k]] = created ? CellFate::kNewSurface : CellFate::kStored;
    // Stored cells that nearer, more precise new cells cover are replaced by them (below).
    for (const MapCell* old : superseded[k]) {
      auto& entry = superseding[old->id];
      entry.first = old;
      entry.second.push_back(fresh[k]);
    }
    MapCell stored = map_cell_of(cell, next_cell_id_++, frame_id, root);  // storage precision
    index_.insert(stored.id, bounds_of(stored.vertices_m));
    surface.cells.push_back(stored.id);
    report.added_cells.push_back(stored.id);
    consolidation_queue_.emplace_back(frame_id, stored.id);
    cells_.emplace(stored.id, std::move(stored));
  }

  // Replaced cells leave the map (a surface keeps at least one cell: its last is never replaced).
  for (const auto& [id, entry] : superseding) {
    const auto& [old, newer] = entry;
    if (!covers_at_least(*old, newer, config_.redundant_coverage)) continue;
    const auto it = cells_.find(id);
    if (it == cells_.end()) continue;
    Surface& surface = surfaces_.at(it->second.surface);
    if (surface.cells.size() <= 1) continue;
    std::erase(surface.cells, id);
    index_.remove(id, bounds_of(it->second.vertices_m));
    touched.insert(surface.id);
    cells_.erase(it);
    report.removed_cells.push_back(id);
    ++report.replaced_cells;
  }
  // Unconfirmed surfaces this frame reached but did not observe leave the map with their cells.
  auto still_unconfirmed = [&](const Surface& surface) {
    return surface.frames_observed < confirm && !touched.contains(surface.id);
  };
  for (std::uint32_t id : unconfirmed)
    if (const auto it = surfaces_.find(id); it != surfaces_.end() && still_unconfirmed(it->second))
      prune_surface(id, report);
  // Unconfirmed surfaces no frame has observed for unconfirmed_timeout_frames: confirmed since,
  // gone, observed since (due later), or pruned now.
  if (config_.unconfirmed_timeout_frames > 0) {
    const auto timeout = static_cast<std::uint64_t>(config_.unconfirmed_timeout_frames);
    while (!unconfirmed_since_.empty() && unconfirmed_since_.begin()->first + timeout <= frame_id) {
      const std::uint32_t id = unconfirmed_since_.begin()->second;
      unconfirmed_since_.erase(unconfirmed_since_.begin());
      const auto it = surfaces_.find(id);
      if (it == surfaces_.end() || it->second.frames_observed >= confirm) continue;
      if (it->second.last_observed_frame + timeout > frame_id)
        unconfirmed_since_.emplace(it->second.last_observed_frame, id);
      else if (still_unconfirmed(it->second))
        prune_surface(id, report);
    }
  }
  for (std::uint32_t id : created_surfaces) {
    const auto it = surfaces_.find(id);
    if (it != surfaces_.end() && it->second.frames_observed < confirm) unconfirmed_since_.emplace(frame_id, id);
  }

  // 6. Surface descriptors from the merged label states (surfaces touched only by a replacement
  // keep theirs).
  for (std::uint32_t id : touched) {
    Surface& surface = surfaces_.at(id);
    const auto state_it = labels.find(id);
    if (state_it == labels.end()) continue;
    const LabelState& state = state_it->second;
    surface.plane = state.plane;  // StoredPlane: storage precision
    set_moments(surface, state.moments);
    surface.histogram = compact(state.histogram);
    surface.histogram_weight_m2 = static_cast<float>(state.histogram_weight_m2);
  }
  if (config_.bridge_gap_m > 0.0 || config_.bridge_long_gap_m > 0.0)
    bridge_surfaces(fresh, fresh_input, fresh_box, camera_centre, touched, report);
  age_and_finish(frame_id, frame_id, touched, report);
  next_surface_id_ += static_cast<std::uint32_t>(fresh.size());
  report.merge_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return report;
}

template <class Reject, class Visit>
std::uint32_t GlobalMap::visit_reached_surfaces(std::uint32_t id, std::span<const Planecell* const> fresh,
                                                std::span<const std::size_t> ks, std::span<const Aabb> boxes,
                                                double gap_m, std::span<const ReachCell* const> candidates,
                                                CheckedSurfaces& checked, Reject&& reject, Visit&& visit) {
  std::vector<Aabb> reach;  // each reaching cell's bounds inflated by the gap
  for (const Aabb& box : boxes) reach.push_back(box.inflated(gap_m));
  const Surface* self = nullptr;  // surfaces_.at(id), looked up again after each visit
  for (const ReachCell* candidate : candidates) {
    const MapCell& old = *candidate->cell;
    const std::uint32_t other_id = old.surface;
    if (other_id == id || checked.contains(other_id)) continue;
    const auto other_it = surfaces_.find(other_id);
    if (other_it == surfaces_.end()) continue;
    if (!self) self = &surfaces_.at(id);
    if (reject(*self, other_it->second)) {
      checked.insert(other_id);
      continue;
    }
    // The stored box rules out most candidates; the polygons decide the rest.
    const Aabb& old_box = *candidate->box;
    if (std::none_of(reach.begin(), reach.end(), [&](const Aabb& r) { return r.overlaps(old_box); })) continue;
    const std::vector<Eigen::Vector3f> old_vertices = old.vertices_m.vertices();
    std::size_t w = 0;
    while (w < ks.size() && !(reach[w].overlaps(old_box) &&
                              polygons_within_m(fresh[ks[w]]->plane, fresh[ks[w]]->vertices_m, boxes[w],
                                                old.plane, old_vertices, old_box, gap_m)))
      ++w;
    if (w == ks.size()) continue;  // this stored cell is out of reach; another of its surface may not be
    checked.insert(other_id);
    id = visit(id, old, old_vertices, *fresh[ks[w]]);
    self = nullptr;  // a merge may have moved or removed it
  }
  return id;
}

bool GlobalMap::third_surface_near(const Eigen::Vector3d& point, std::uint32_t a, std::uint32_t b,
                                   ProbeCells& probe) const {
  if (!point.allFinite()) throw InputError("third_surface_near: probe point is not finite");
  constexpr double kNear = 0.2;
  Aabb box;
  box.extend(point);
  box = box.inflated(kNear);
  // nearest_cell(point, kNear): the nearest of the cells whose bounds overlap the box (a cell
  // outside it lies farther than kNear along an axis), the first in id order on a tie.
  if (const SpatialIndex::BucketRange range = index_.bucket_range(box); probe.range != range) {
    probe.range = range;
    probe.cells.clear();
    index_.candidates(box, probe.ids);
    for (std::uint32_t id : probe.ids) {
      const MapCell& c = cells_.at(id);
      probe.cells.push_back({&c, c.vertices_m.bounds(), {}});
    }
  }
  const MapCell* nearest = nullptr;
  double nearest_m = kNear;
  for (ProbeCells::Met& met : probe.cells) {
    if (!met.box.overlaps(box)) continue;
    if (met.vertices.empty()) met.cell->vertices_m.vertices_into(met.vertices);
    const double d = distance_to_polygon(point, met.cell->plane, met.vertices);
    if (d < nearest_m || (!nearest && d <= nearest_m)) nearest = met.cell, nearest_m = d;
  }
  return nearest && nearest->surface != a && nearest->surface != b;
}

bool GlobalMap::seen_through(const Eigen::Vector3d& m, const Eigen::Vector3d& camera_centre, std::uint32_t a,
                             std::uint32_t b) const {
  const Eigen::Vector3d ray = (m - camera_centre).normalized();
  ProbeCells probe;
  for (double t = 0.3; t <= 10.0; t += 0.25)
    if (third_surface_near(m + t * ray, a, b, probe)) return true;
  return false;
}

void GlobalMap::bridge_surfaces(std::span<const Planecell* const> fresh, std::span<const std::size_t> fresh_input,
                                std::span<const Aabb> fresh_box,
                                const Eigen::Vector3d& camera_centre, std::set<std::uint32_t>& touched,
                                MergeReport& report) {
  const auto mature = static_cast<std::uint32_t>(std::max(config_.mature_cells, 1));
  const double min_cos = std::cos(config_.max_normal_angle_deg * M_PI / 180.0);
  // This frame's cells (stored or fused) by the surface they went to.
  std::map<std::uint32_t, std::vector<std::size_t>> reached;
  for (std::size_t k = 0; k < fresh.size(); ++k) {
    const std::uint32_t s = report.cell_surfaces[fresh_input[k]];
    if (surfaces_.contains(s)) reached[s].push_back(k);
  }
  // Mature surfaces that pass the CRF's test for mature labels, when one covers enough area.
  const auto reject = [&](const Surface& self, const Surface& other) {
    return other.observations < mature || std::abs(other.plane.normal().dot(self.plane.normal())) < min_cos ||
           std::max(self.area_m2, other.area_m2) < config_.bridge_min_area_m2;
  };
  std::optional<FrameReach> frame_reach;  // made for the first long bridge that needs it
  // The stored cells within bridge_gap_m of this frame's, from one index query, with the buckets
  // their boxes touch: a surface's walk takes those sharing a bucket with its reach, which are
  // its own query's candidates (SpatialIndex::BucketRange), without querying the index again.
  std::vector<ReachCell> near_cells;
  std::vector<SpatialIndex::BucketRange> near_buckets;
  std::vector<const ReachCell*> walk;  // one surface's candidates (storage reused)
  std::vector<Aabb> boxes;             // its reaching cells' bounds (storage reused)
  CheckedSurfaces checked;             // other surfaces tested against it (storage reused)
  for (const auto& [reached_id, ks] : reached) {
    std::uint32_t id = reached_id;  // follows the surface when a merge absorbs it
    if (const auto it = surfaces_.find(id); it == surfaces_.end() || it->second.observations < mature) continue;
    boxes.clear();
    for (std::size_t k : ks) boxes.push_back(fresh_box[k]);
    checked.clear();
    if (config_.bridge_gap_m > 0.0) {
      if (near_cells.empty()) {  // the first mature surface of the frame
        Aabb frame;
        for (const Aabb& box : fresh_box) frame.extend(box.inflated(config_.bridge_gap_m));
        std::vector<std::uint32_t> ids;
        index_.candidates(frame, ids);
        for (std::uint32_t cell_id : ids)
          if (const auto it = cells_.find(cell_id); it != cells_.end()) {
            const Aabb box = it->second.vertices_m.bounds();
            near_cells.push_back({&it->second, box});
            near_buckets.push_back(index_.bucket_range(box));
          }
      }
      Aabb all;
      for (const Aabb& box : boxes) all.extend(box.inflated(config_.bridge_gap_m));
      const SpatialIndex::BucketRange range = index_.bucket_range(all);
      walk.clear();
      for (std::size_t c = 0; c < near_cells.size(); ++c)
        if (near_buckets[c].overlaps(range)) walk.push_back(&near_cells[c]);
      id = visit_reached_surfaces(
          id, fresh, ks, boxes, config_.bridge_gap_m, walk, checked, reject,
          [&](std::uint32_t self_id, const MapCell& old, const std::vector<Eigen::Vector3f>& old_vertices,
              const Planecell& cell) {
            const std::uint32_t other_id = old.surface;
            const Surface& self = surfaces_.at(self_id);
            const Surface& other = surfaces_.at(other_id);
            // Each cell on the other's plane where it was observed (bridge_max_cell_distance_m).
            const Eigen::Vector3d ca = vertex_centroid(cell.vertices_m), cb = vertex_centroid(old_vertices);
            const double max_cell_m = config_.bridge_max_cell_distance_m;
            if (max_cell_m > 0.0 && (std::abs(other.plane.signed_distance(ca)) > max_cell_m ||
                                     std::abs(self.plane.signed_distance(cb)) > max_cell_m))
              return self_id;
            // A dormant surface's label state comes from its quiet moments: tested asleep, woken
            // only by a merge (absorb_surface).
            LabelState a = state_of_surface(self), b = state_of_surface(other);
            const MergeUnit ua{self_id, cell.plane, cell.vertices_m, nullptr, polygon_area_m2(cell.vertices_m)};
            const MergeUnit ub{other_id, old.plane, old_vertices, nullptr, polygon_area_m2(old_vertices)};
            if (!merger_.evaluate(ua, a, ub, b, 0.0).in_range ||
                seen_through(0.5 * (ca + cb), camera_centre, self_id, other_id))
              return self_id;
            return merge_surfaces(self_id, std::move(a), other_id, std::move(b), touched, report);
          });
    }
    if (config_.bridge_long_gap_m > 0.0)
      id = bridge_long(id, fresh, fresh_box, ks, boxes, camera_centre, checked, frame_reach,
                       touched, report);
  }
}

std::uint32_t GlobalMap::bridge_long(std::uint32_t id, std::span<const Planecell* const> fresh,
                                     std::span<const Aabb> fresh_box,
                                     std::span<const std::size_t> ks, std::span<const Aabb> boxes,
                                     const Eigen::Vector3d& camera_centre,
                                     CheckedSurfaces& checked,
                                     std::optional<FrameReach>& frame_reach,
                                     std::set<std::uint32_t>& touched, MergeReport& report) {
  const auto mature = static_cast<std::uint32_t>(std::max(config_.mature_cells, 1));
  const double min_area = config_.bridge_long_min_area_m2;
  if (const auto it = surfaces_.find(id);
      it == surfaces_.end() || it->second.observations < mature || it->second.area_m2 < min_area)
    return id;
  const double min_cos = std::cos(config_.bridge_long_max_angle_deg * M_PI / 180.0);
  const auto reject = [&](const Surface& self, const Surface& other) {
    return other.observations < mature || other.area_m2 < min_area ||
           std::abs(other.plane.normal().dot(self.plane.normal())) < min_cos;
  };
  const auto visit = [&](std::uint32_t self_id, const MapCell& old, const std::vector<Eigen::Vector3f>& old_vertices,
                         const Planecell& cell) {
    const std::uint32_t other_id = old.surface;
    const Surface& self = surfaces_.at(self_id);
    const Surface& other = surfaces_.at(other_id);
    // One plane: the step between the two planes at the cells' midpoint m (m moved onto self's).
    const Plane3 self_plane = self.plane, other_plane = other.plane;
    const Eigen::Vector3d a = vertex_centroid(cell.vertices_m), b = vertex_centroid(old_vertices);
    const Eigen::Vector3d m = 0.5 * (a + b);
    if (step_at(self_plane, other_plane, m) > config_.bridge_long_max_step_m) return self_id;
    // Hidden behind an occluder: a third surface near the camera ray in front of m, none behind.
    const Eigen::Vector3d to_m = m - camera_centre;
    const double range = to_m.norm();
    const Eigen::Vector3d ray = to_m / std::max(range, 1e-9);
    bool occluded = false;
    ProbeCells probe;
    for (double t = 0.5; t <= range - 0.5 && !occluded; t += 0.25)
      occluded = third_surface_near(camera_centre + t * ray, self_id, other_id, probe);
    if (!occluded || seen_through(m, camera_centre, self_id, other_id)) return self_id;
    // Unmapped: nothing else on the straight path between the two cells, on self's plane.
    if (any_on_path(self_plane, a, b,
                    [&](const Eigen::Vector3d& q) { return third_surface_near(q, self_id, other_id, probe); }))
      return self_id;
    LabelState sa = state_of_surface(self), sb = state_of_surface(other);  // asleep too (above)
    if (colour_similarity(sa.histogram, sb.histogram) < config_.bridge_long_min_colour ||
        other_paint(sa.chromaticity, sb.chromaticity, config_.max_chromaticity_distance))
      return self_id;
    return merge_surfaces(self_id, std::move(sa), other_id, std::move(sb), touched, report);
  };
  // Only large mature surfaces can pass `reject`: the walk visits their cells alone, found among
  // the stored cells near this frame's (one index query a frame; a walk over each large surface's
  // cells would grow with the drive, the road being one surface all along it).
  if (!frame_reach) {
    frame_reach.emplace();
    Aabb reach;
    for (const Aabb& box : fresh_box) reach.extend(box.inflated(config_.bridge_long_gap_m));
    std::vector<std::uint32_t> ids;
    index_.candidates(reach, ids);
    for (std::uint32_t cell_id : ids)
      if (const auto it = cells_.find(cell_id); it != cells_.end()) frame_reach->cells.push_back({&it->second, {}});
  }
  Aabb all;  // as visit_reached_surfaces bounds the reach
  for (const Aabb& box : boxes) all.extend(box.inflated(config_.bridge_long_gap_m));
  std::vector<const ReachCell*> given;
  for (ReachCell& reach_cell : frame_reach->cells) {
    const MapCell* cell = reach_cell.cell;
    if (cell->surface == id) continue;
    const auto it = surfaces_.find(cell->surface);
    if (it == surfaces_.end() || it->second.observations < mature || it->second.area_m2 < min_area ||
        !Aabb(it->second.bounds).overlaps(all))
      continue;
    if (!reach_cell.box) reach_cell.box = cell->vertices_m.bounds();
    if (all.overlaps(*reach_cell.box)) given.push_back(&reach_cell);
  }
  return visit_reached_surfaces(id, fresh, ks, boxes, config_.bridge_long_gap_m, given, checked, reject, visit);
}

std::uint32_t GlobalMap::merge_surfaces(std::uint32_t a_id, LabelState a, std::uint32_t b_id, LabelState b,
                                        std::set<std::uint32_t>& touched, MergeReport& report) {
  // The older (smaller id) surface absorbs the newer, as in the CRF's union-find.
  const std::uint32_t into_id = std::min(a_id, b_id), gone_id = std::max(a_id, b_id);
  LabelState& state = into_id == a_id ? a : b;
  fold_label(state, into_id == a_id ? b : a);
  absorb_surface(into_id, gone_id, touched, report);
  Surface& into = surfaces_.at(into_id);
  into.plane = state.plane;  // StoredPlane: storage precision
  set_moments(into, state.moments);
  into.histogram = compact(state.histogram);
  into.histogram_weight_m2 = static_cast<float>(state.histogram_weight_m2);
  return into_id;
}

bool GlobalMap::join_neighbour(Surface& surface, std::set<std::uint32_t>& touched, MergeReport& report) {
  if (config_.fragment_join_max_area_m2 <= 0.0 || !(surface.area_m2 < config_.fragment_join_max_area_m2))
    return false;
  const double gap = config_.neighbour_gap_m;
  // The largest larger neighbouring surface (a stored cell within the gap of one of this
  // surface's) that this one lies on.
  const Surface* best = nullptr;
  std::vector<std::uint32_t> nearby;
  CheckedSurfaces checked;
  const LabelState self = state_of_surface(surface);
  // Within its own depth noise, colours alike: the tolerance σ̄_Z·k (fragment_join_sigma_factor).
  double sigma_m = 0.0;
  for (std::uint32_t cell_id : surface.cells) sigma_m += cells_.at(cell_id).depth_sigma_m;
  const double noise_distance_m =
      config_.fragment_join_sigma_factor * sigma_m / static_cast<double>(std::max<std::size_t>(1, surface.cells.size()));
  for (std::uint32_t cell_id : surface.cells) {
    const MapCell& cell = cells_.at(cell_id);
    const Aabb box = bounds_of(cell.vertices_m);
    const Aabb near_box = box.inflated(gap);
    index_.candidates(near_box, nearby);
    for (std::uint32_t other_cell_id : nearby) {
      const MapCell& old = cells_.at(other_cell_id);
      if (old.surface == surface.id || checked.contains(old.surface)) continue;
      const Surface& other = surfaces_.at(old.surface);
      if (!(other.area_m2 > surface.area_m2) || (best && other.area_m2 <= best->area_m2)) {
        checked.insert(old.surface);
        continue;
      }
      const Aabb old_box = bounds_of(old.vertices_m);
      if (!near_box.overlaps(old_box) ||
          !polygons_within_m(cell.plane, cell.vertices_m, box, old.plane, old.vertices_m, old_box, gap))
        continue;
      checked.insert(old.surface);
      // Its points on the neighbour's plane, its normal (a small patch's is loosely determined)
      // near the neighbour's, and the CRF's colour gate; or its points within its own depth noise
      // of the plane and colours alike.
      const double angle_deg =
          std::acos(std::min(1.0, std::abs(surface.plane.normal().dot(other.plane.normal())))) * 180.0 / M_PI;
      if (angle_deg > config_.fragment_join_angle_deg) continue;
      const double rms_m = self.moments.rms_distance_m(other.plane);
      if (rms_m > std::max(config_.fragment_join_distance_m, noise_distance_m)) continue;
      const ColourHistogram other_histogram = expand(other.histogram);
      const double colour = colour_similarity(self.histogram, other_histogram);
      if (colour < (rms_m <= config_.fragment_join_distance_m ? config_.min_colour_similarity
                                                              : config_.fragment_join_noise_colour) ||
          other_paint(self.chromaticity, histogram_chromaticity(other_histogram), config_.max_chromaticity_distance))
        continue;
      best = &other;
    }
  }
  if (!best) return false;
  const std::uint32_t other_id = best->id;
  wake(surfaces_.at(other_id));
  // `surface` is live (it was going dormant): `self` is still its state; the neighbour's is taken
  // after waking it.
  merge_surfaces(surface.id, self, other_id, state_of_surface(surfaces_.at(other_id)), touched, report);
  return true;
}

bool GlobalMap::join_ground_across_gap(Surface& surface, std::set<std::uint32_t>& touched, MergeReport& report) {
  const double gap = config_.ground_join_gap_m;
  const auto mature = static_cast<std::uint32_t>(std::max(config_.mature_cells, 1));
  const double min_area = config_.bridge_long_min_area_m2;
  const double ground_cos = std::cos(config_.max_ground_tilt_deg * M_PI / 180.0);
  const double pair_cos = std::cos(config_.bridge_long_max_angle_deg * M_PI / 180.0);
  const auto ground_of = [&](const Surface& s, double area_m2) {
    return s.observations >= mature && s.area_m2 >= area_m2 && std::abs(s.plane.normal().dot(up_)) >= ground_cos;
  };
  // The pair: the larger at least the larger of bridge_long_min_area_m2 and
  // ground_join_min_area_m2, the smaller at least the smaller of them (whichever goes dormant).
  const double small_area = std::min(min_area, config_.ground_join_min_area_m2);
  const double large_area = std::max(min_area, config_.ground_join_min_area_m2);
  if (!(gap > 0.0) || !ground_of(surface, small_area)) return false;
  const double other_min_area = ground_of(surface, large_area) ? small_area : large_area;
  const auto large_ground = [&](const Surface& s) { return ground_of(s, other_min_area); };
  // Per other ground surface large enough (large_ground) of a nearly parallel plane with stored
  // cells within the gap of this one's bounds: the nearest pair of cell centroids (this one's,
  // the other's).
  struct Nearest {
    double distance_m = std::numeric_limits<double>::infinity();
    Eigen::Vector3d a, b;
  };
  std::vector<Eigen::Vector3d> own;
  for (std::uint32_t cell_id : surface.cells) own.push_back(vertex_centroid(cells_.at(cell_id).vertices_m.vertices()));
  std::vector<std::uint32_t> nearby;
  index_.candidates(Aabb(surface.bounds).inflated(gap), nearby);
  std::map<std::uint32_t, Nearest> nearest;  // by id: the candidates are tried in a fixed order
  CheckedSurfaces rejected;
  for (std::uint32_t cell_id : nearby) {
    const MapCell& old = cells_.at(cell_id);
    if (old.surface == surface.id || rejected.contains(old.surface)) continue;
    const Surface& other = surfaces_.at(old.surface);
    if (!large_ground(other) || std::abs(other.plane.normal().dot(surface.plane.normal())) < pair_cos) {
      rejected.insert(old.surface);
      continue;
    }
    const Eigen::Vector3d b = vertex_centroid(old.vertices_m.vertices());
    Nearest& n = nearest[old.surface];
    for (const Eigen::Vector3d& a : own)
      if (const double d = (a - b).norm(); d < n.distance_m) n = {d, a, b};
  }
  const Plane3 self_plane = surface.plane;
  /// Does a surface other than the pair's lie off self's plane within 0.2 m of q? Fragments
  /// (below fragment_join_max_area_m2) do not count: pieces of the ground seen between the
  /// occluders, fitted from afar, lie 5–10 cm or tens of degrees off it.
  const auto off_plane_near = [&](const Eigen::Vector3d& q, std::uint32_t other_id) {
    const auto hit = nearest_cell(q, 0.2);
    if (!hit) return false;
    const std::uint32_t s = cells_.at(hit->cell_id).surface;
    if (s == surface.id || s == other_id) return false;
    const Surface& third = surfaces_.at(s);
    if (third.area_m2 < config_.fragment_join_max_area_m2) return false;
    const Plane3 plane = third.plane;
    return std::abs(plane.normal.dot(self_plane.normal)) < pair_cos ||
           std::abs(plane.signed_distance(q)) > config_.bridge_long_max_step_m;
  };
  for (const auto& [id, n] : nearest) {
    const std::uint32_t other_id = id;  // a lambda below captures it (clang 14: not a binding)
    if (n.distance_m > gap) continue;
    // One plane: the step between the two planes at the cells' midpoint m (m moved onto self's).
    if (step_at(self_plane, surfaces_.at(other_id).plane, 0.5 * (n.a + n.b)) > config_.bridge_long_max_step_m) continue;
    // Nothing off the plane on the straight path between the two cells, on self's plane.
    if (any_on_path(self_plane, n.a, n.b, [&](const Eigen::Vector3d& q) { return off_plane_near(q, other_id); }))
      continue;
    Surface& other = surfaces_.at(other_id);
    LabelState self_state = state_of_surface(surface);
    const ColourHistogram other_histogram = expand(other.histogram);
    if (colour_similarity(self_state.histogram, other_histogram) < config_.ground_join_min_colour ||
        other_paint(self_state.chromaticity, histogram_chromaticity(other_histogram), config_.max_chromaticity_distance))
      continue;
    wake(other);  // `surface` is live (it was going dormant); the other's state is taken awake
    merge_surfaces(surface.id, std::move(self_state), other_id, state_of_surface(other), touched, report);
    return true;
  }
  return false;
}

MapBytes GlobalMap::map_bytes_by_part() const {
  MapBytes bytes;
  bytes.cells = hash_map_bytes(cells_);
  bytes.surfaces = hash_map_bytes(surfaces_);
  bytes.index = index_.bytes();
  bytes.cells += consolidation_queue_.size() * sizeof(consolidation_queue_.front());
  for (const auto& [id, cell] : cells_) bytes.vertices += cell.vertices_m.bytes();
  bytes.surfaces += dormancy_clock_.size() * sizeof(std::pair<std::uint64_t, std::uint32_t>) +
                    tree_bytes(unconfirmed_since_);
  for (const auto& [id, surface] : surfaces_) {
    bytes.surfaces += surface.cells.capacity() * sizeof(std::uint32_t) + surface.histogram.bytes();
    if (surface.detail) {
      bytes.surfaces += sizeof(SurfaceDetail);
      bytes.footprints += surface.detail->footprint.bytes();
    }
  }
  return bytes;
}

void GlobalMap::prune_surface(std::uint32_t id, MergeReport& report) {
  const auto it = surfaces_.find(id);
  if (it == surfaces_.end()) return;
  for (std::uint32_t cell_id : it->second.cells) {
    const auto cell_it = cells_.find(cell_id);
    if (cell_it == cells_.end()) continue;
    index_.remove(cell_id, bounds_of(cell_it->second.vertices_m));
    cells_.erase(cell_it);
    report.removed_cells.push_back(cell_id);
  }
  surfaces_.erase(it);
  report.removed_surfaces.push_back(id);
  report.pruned_surfaces.push_back(id);
}

void GlobalMap::consolidate(std::uint64_t frame_id, std::set<std::uint32_t>& touched,
                            MergeReport& report) {
  if (config_.consolidate_after_frames <= 0) {
    consolidation_queue_.clear();
    return;
  }
  const auto age = static_cast<std::uint64_t>(config_.consolidate_after_frames);
  using Tile = std::pair<std::int64_t, std::int64_t>;
  // A surface goes dormant only after its cells are consolidated (dormant_after_frames ≥
  // consolidate_after_frames): the wakes below are no-ops.
  // The square of a point: its basis coordinates in units of consolidate_tile_m, floored.
  auto square_of = [&](const PlaneBasis& basis, const Eigen::Vector3d& point) {
    const Eigen::Vector2d st = basis.to_2d(point) / config_.consolidate_tile_m;
    return Tile(static_cast<std::int64_t>(std::floor(st.x())),
                static_cast<std::int64_t>(std::floor(st.y())));
  };
  auto tile_of = [&](Surface& surface, const MapCell& cell) {
    wake(surface);
    return square_of(surface.detail->basis, vertex_centroid(cell.vertices_m));
  };
  // The squares of the cells coming of age now, by surface, in order.
  std::map<std::uint32_t, std::set<Tile>> due;
  while (!consolidation_queue_.empty() && consolidation_queue_.front().first + age <= frame_id) {
    const std::uint32_t id = consolidation_queue_.front().second;
    consolidation_queue_.pop_front();
    const auto it = cells_.find(id);
    if (it == cells_.end()) continue;  // replaced or pruned since
    due[it->second.surface].insert(tile_of(surfaces_.at(it->second.surface), it->second));
  }
  const CellUnionSettings settings{config_.consolidate_resolution_m,
                                   config_.consolidate_tolerance_m,
                                   config_.consolidate_max_hole_m2};
  // Unions made this frame are not united again in a later square this frame.
  const std::uint32_t first_union = next_cell_id_;
  std::vector<std::uint32_t> nearby, squares_near;
  for (const auto& due_surface : due) {
    // (not a structured binding: clang 14 cannot capture one in the lambda below)
    const std::uint32_t surface_id = due_surface.first;
    const std::set<Tile>& tiles = due_surface.second;
    Surface& surface = surfaces_.at(surface_id);
    const Eigen::Vector3d n = surface.plane.normal().normalized();
    const double e = surface.plane.offset() / surface.plane.normal().norm();
    // Each due square's cells: the surface's cells whose vertex centroid projects into the square
    // and lies within consolidate_square_reach_m of the surface's plane. (tile_of woke the
    // surface: its detail holds the basis.)
    const PlaneBasis& basis = surface.detail->basis;
    const double square_reach = config_.consolidate_square_reach_m;
    std::map<Tile, std::vector<const MapCell*>> in_square;
    auto sort_in = [&](std::uint32_t id, const MapCell& cell) {
      if (id >= first_union) return;
      const Eigen::Vector3d centroid = vertex_centroid(cell.vertices_m);
      if (std::abs(n.dot(centroid) + e) > square_reach) return;
      if (const Tile tile = square_of(basis, centroid); tiles.contains(tile)) in_square[tile].push_back(&cell);
    };
    const Eigen::Vector3d w = basis.u.cross(basis.v);
    const double n_dot_w = n.dot(w);
    if (surface.cells.size() <= kConsolidateScanCells * tiles.size() || std::abs(n_dot_w) < 0.5) {
      for (std::uint32_t id : surface.cells) sort_in(id, cells_.at(id));
    } else {
      // A long surface (a road): the index finds the squares' cells near them, so a frame's work
      // does not grow with the surface's length. The square lifted onto the surface's plane
      // along the basis normal w, widened by the reach along w, holds them: X with
      // basis.to_2d(X) in the square and |n·X + e| ≤ r lies at lift(s, t) + h·w with
      // |h| ≤ r / |n·w| (the basis was made on an earlier fit of the plane: n·w ≈ 1; a plane
      // turned more than 60° from its basis is scanned instead).
      const double lift_reach = square_reach / std::abs(n_dot_w);
      squares_near.clear();
      for (const Tile& tile : tiles) {
        Aabb box;
        for (int corner = 0; corner < 4; ++corner) {
          const Eigen::Vector3d on_basis = basis.to_3d(
              Eigen::Vector2d(static_cast<double>(tile.first + (corner & 1)),
                              static_cast<double>(tile.second + (corner >> 1))) *
              config_.consolidate_tile_m);
          const Eigen::Vector3d lifted = on_basis - (n.dot(on_basis) + e) / n_dot_w * w;
          box.extend(lifted + lift_reach * w);
          box.extend(lifted - lift_reach * w);
        }
        index_.candidates(box, nearby);
        squares_near.insert(squares_near.end(), nearby.begin(), nearby.end());
      }
      std::sort(squares_near.begin(), squares_near.end());
      squares_near.erase(std::unique(squares_near.begin(), squares_near.end()), squares_near.end());
      for (std::uint32_t id : squares_near)
        if (const MapCell& cell = cells_.at(id); cell.surface == surface_id) sort_in(id, cell);
    }
    for (const auto& [tile, cells] : in_square) {
      // The square's cells, once all of them are old, that the surface's plane describes.
      std::vector<const MapCell*> group;
      bool complete = true;
      for (const MapCell* cell_ptr : cells) {
        const MapCell& cell = *cell_ptr;
        if (cell.frame_id + age > frame_id) {
          complete = false;
          break;
        }
        const double reach =
            std::max<double>(config_.consolidate_max_distance_m, cell.depth_sigma_m);
        if (std::all_of(cell.vertices_m.begin(), cell.vertices_m.end(),
                        [&](const Eigen::Vector3f& v) {
                          return std::abs(n.dot(v.cast<double>()) + e) <= reach;
                        }))
          group.push_back(&cell);
      }
      if (!complete || group.size() < 2) continue;
      std::vector<std::vector<Eigen::Vector3f>> decoded(group.size());
      std::vector<std::span<const Eigen::Vector3f>> polygons;
      for (std::size_t k = 0; k < group.size(); ++k)
        polygons.push_back(as_span(group[k]->vertices_m, decoded[k]));
      const std::vector<CellUnion> unions =
          unite_cells(polygons, surface.detail->basis, surface.plane, settings);
      // A union the map cannot hold (cell_problem) is dropped, and its members stay.
      std::vector<bool> member(group.size(), false), kept(group.size(), false);
      std::vector<bool> usable(unions.size());
      for (std::size_t u = 0; u < unions.size(); ++u) {
        usable[u] =
            cell_problem(surface.plane, unions[u].vertices_m, index_.max_coordinate_m()).empty();
        for (std::size_t k : unions[u].members) (usable[u] ? member : kept)[k] = true;
      }
      for (std::size_t k = 0; k < group.size(); ++k) member[k] = member[k] && !kept[k];
      std::vector<MapCell> pieces;
      for (std::size_t u = 0; u < unions.size(); ++u) {
        if (!usable[u]) continue;
        const CellUnion& united = unions[u];
        MapCell piece;
        piece.surface = surface_id;
        piece.plane = surface.plane;
        piece.vertices_m = on_mm_grid(united.vertices_m);
        // Colour and depth noise: the members' area-weighted means; age: the newest member's frame.
        double weight = 0.0, sigma = 0.0;
        Eigen::Vector3d rgb = Eigen::Vector3d::Zero();
        for (std::size_t k : united.members) {
          const MapCell& cell = *group[k];
          const double area = polygon_area_m2(polygons[k]);  // decoded above
          weight += area;
          rgb += area * Eigen::Vector3f(cell.mean_rgb).cast<double>();
          sigma += area * cell.depth_sigma_m;
          piece.frame_id = std::max(piece.frame_id, cell.frame_id);
        }
        piece.mean_rgb = Eigen::Vector3f((rgb / weight).cast<float>());
        piece.depth_sigma_m = static_cast<float>(sigma / weight);
        pieces.push_back(std::move(piece));
      }
      if (pieces.empty()) continue;
      // The members leave (a member cut between two unions stands in both), the unions enter;
      // the surface's cell list is filtered once (a road holds thousands), not once per member.
      std::vector<std::uint32_t> leaving;
      for (std::size_t k = 0; k < group.size(); ++k) {
        if (!member[k]) continue;
        const std::uint32_t id = group[k]->id;
        index_.remove(id, bounds_of(group[k]->vertices_m));
        leaving.push_back(id);
        report.removed_cells.push_back(id);
        cells_.erase(id);
        ++report.consolidated_cells;
      }
      std::sort(leaving.begin(), leaving.end());
      std::erase_if(surface.cells,
                    [&](std::uint32_t id) { return std::binary_search(leaving.begin(), leaving.end(), id); });
      for (MapCell& piece : pieces) {
        piece.id = next_cell_id_++;
        index_.insert(piece.id, bounds_of(piece.vertices_m));
        surface.cells.push_back(piece.id);
        report.added_cells.push_back(piece.id);
        cells_.emplace(piece.id, std::move(piece));
      }
      shrink_if_sparse_vector(surface.cells);
      touched.insert(surface_id);
    }
  }
}

GlobalMap GlobalMap::restore(const MapConfig& config, std::vector<MapCell> cells,
                             std::vector<Surface> surfaces, std::uint32_t next_cell_id,
                             std::uint32_t next_surface_id,
                             std::optional<std::uint64_t> last_frame_id, bool settled) {
  GlobalMap map(config);
  for (auto& surface : surfaces) {
    const auto id = surface.id;
    map.surfaces_.emplace(id, std::move(surface));
  }
  for (auto& cell : cells) {
    if (const std::string problem = cell_problem(cell.plane, cell.vertices_m.vertices(), map.index_.max_coordinate_m());
        !problem.empty())
      throw StorageError("map restore: cell " + std::to_string(cell.id) + " " + problem);
    if (!map.surfaces_.contains(cell.surface))
      throw StorageError("map restore: cell " + std::to_string(cell.id) + " names missing surface " +
                         std::to_string(cell.surface));
    map.index_.insert(cell.id, bounds_of(cell.vertices_m));
    const auto id = cell.id;
    map.cells_.emplace(id, std::move(cell));
  }
  map.next_cell_id_ = next_cell_id;
  map.next_surface_id_ = next_surface_id;
  const auto confirm = static_cast<std::uint32_t>(std::max(1, config.confirm_frames));
  for (const auto& [id, surface] : map.surfaces_)
    if (surface.frames_observed < confirm) map.unconfirmed_since_.emplace(surface.last_observed_frame, id);
  if (config.dormant_after_frames > 0)
    for (const auto& [id, surface] : map.surfaces_)
      if (surface.detail) map.dormancy_clock_.emplace(surface.last_observed_frame, id);
  // Cells the consolidation had not yet considered: stored after last_frame_id − age.
  const auto age = static_cast<std::uint64_t>(std::max(0, config.consolidate_after_frames));
  for (const auto& [id, cell] : map.cells_)
    if (!settled && (!last_frame_id || cell.frame_id + age > *last_frame_id))
      map.consolidation_queue_.emplace_back(cell.frame_id, id);
  std::sort(map.consolidation_queue_.begin(), map.consolidation_queue_.end());
  return map;
}

void GlobalMap::age_and_finish(std::uint64_t consolidation_frame, std::uint64_t dormancy_frame,
                               std::set<std::uint32_t>& touched, MergeReport& report) {
  consolidate(consolidation_frame, touched, report);
  retire_quiet_surfaces(dormancy_frame, touched, report);
  if (!report.removed_cells.empty())  // replaced, pruned or consolidated
    std::erase_if(report.relabelled_cells, [&](std::uint32_t id) { return !cells_.contains(id); });
  report.updated_surfaces.assign(touched.begin(), touched.end());
  shrink_if_sparse(cells_);  // after replacements, pruning and consolidation
  shrink_if_sparse(surfaces_);
  std::sort(report.relabelled_cells.begin(), report.relabelled_cells.end());
  report.relabelled_cells.erase(std::unique(report.relabelled_cells.begin(), report.relabelled_cells.end()),
                                report.relabelled_cells.end());
}

MergeReport GlobalMap::settle(std::uint64_t last_frame_id) {
  const auto start = std::chrono::steady_clock::now();
  MergeReport report;
  report.frame_id = last_frame_id;
  report.settled = true;
  std::set<std::uint32_t> touched;
  // The clocks as they will read once every cell and surface is due, with nothing observed since
  // last_frame_id (a surface a join touches is observed at last_frame_id: due then too).
  const auto age = static_cast<std::uint64_t>(std::max(0, config_.consolidate_after_frames));
  const auto quiet = static_cast<std::uint64_t>(std::max(0, config_.dormant_after_frames));
  age_and_finish(last_frame_id + age, last_frame_id + quiet, touched, report);
  report.merge_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return report;
}

void GlobalMap::wake(Surface& surface) {
  if (surface.detail) return;
  std::vector<const MapCell*> cells;
  cells.reserve(surface.cells.size());
  for (std::uint32_t id : surface.cells) cells.push_back(&cells_.at(id));
  surface.detail.emplace(rebuild_detail(surface, cells, config_.footprint_resolution_m));
  surface.quiet_moments = {};
  if (config_.dormant_after_frames > 0) dormancy_clock_.emplace(surface.last_observed_frame, surface.id);
}

bool GlobalMap::redundant_fragment(const Surface& surface) const {
  if (config_.fragment_max_area_m2 <= 0.0 || surface.cells.size() != 1 ||
      !(surface.area_m2 < config_.fragment_max_area_m2))
    return false;
  const MapCell& cell = cells_.at(surface.cells.front());
  const double tolerance = config_.fragment_redundant_m;
  const std::vector<Eigen::Vector3f> vertices = cell.vertices_m.vertices();
  // The other surfaces' cells nearby, decoded once for every point tested against them.
  std::vector<std::pair<Plane3, std::vector<Eigen::Vector3f>>> others;
  for (std::uint32_t id : query_cells(bounds_of(vertices).inflated(tolerance))) {
    const MapCell& other = cells_.at(id);
    if (other.surface != surface.id) others.emplace_back(other.plane, other.vertices_m.vertices());
  }
  auto covered = [&](const Eigen::Vector3d& point) {
    return std::any_of(others.begin(), others.end(), [&](const auto& other) {
      return distance_to_polygon(point, other.first, other.second) <= tolerance;
    });
  };
  if (!covered(vertex_centroid(vertices))) return false;
  return std::all_of(vertices.begin(), vertices.end(),
                     [&](const Eigen::Vector3f& v) { return covered(v.cast<double>()); });
}

void GlobalMap::retire_quiet_surfaces(std::uint64_t frame_id, std::set<std::uint32_t>& touched,
                                      MergeReport& report) {
  if (config_.dormant_after_frames <= 0) return;
  const auto quiet = static_cast<std::uint64_t>(config_.dormant_after_frames);
  // Surfaces due to go dormant drop their detail only after every due fragment has had its
  // join: a fragment may still join one of them (wakes it: observed now) or be joined by it.
  std::vector<std::uint32_t> due;
  while (!dormancy_clock_.empty() && dormancy_clock_.top().first + quiet <= frame_id) {
    const std::uint32_t id = dormancy_clock_.top().second;
    dormancy_clock_.pop();
    const auto it = surfaces_.find(id);
    if (it == surfaces_.end() || !it->second.detail) continue;  // absorbed, pruned or dormant
    Surface& surface = it->second;
    if (surface.last_observed_frame + quiet > frame_id) {  // observed since: due later
      dormancy_clock_.emplace(surface.last_observed_frame, id);
      continue;
    }
    if (join_neighbour(surface, touched, report)) {
      // The merged surface is live, observed now. When this one absorbed its neighbour, its own
      // clock entry was the one just taken (the neighbour's is gone with it): back on the clock.
      if (const auto merged = surfaces_.find(id); merged != surfaces_.end())
        dormancy_clock_.emplace(merged->second.last_observed_frame, id);
      continue;
    }
    if (join_ground_across_gap(surface, touched, report)) {  // as join_neighbour
      if (const auto merged = surfaces_.find(id); merged != surfaces_.end())
        dormancy_clock_.emplace(merged->second.last_observed_frame, id);
      continue;
    }
    if (redundant_fragment(surface)) {
      // Its cell may be this frame's (consolidation): then the map's consumers never see it.
      const std::uint32_t cell_id = surface.cells.front();
      const bool added_now = std::erase(report.added_cells, cell_id) > 0;
      prune_surface(id, report);
      if (added_now) std::erase(report.removed_cells, cell_id);
      touched.erase(id);
      continue;
    }
    due.push_back(id);
  }
  for (std::uint32_t id : due) {
    const auto it = surfaces_.find(id);
    if (it == surfaces_.end()) continue;  // absorbed by a later fragment's join
    Surface& surface = it->second;
    if (surface.last_observed_frame + quiet > frame_id) {  // a fragment joined it: live, due later
      dormancy_clock_.emplace(surface.last_observed_frame, id);
      continue;
    }
    surface.quiet_moments = quiet_moments_of(moments_of(surface));
    surface.detail.reset();
    report.dormant_surfaces.push_back(id);
  }
  std::sort(report.dormant_surfaces.begin(), report.dormant_surfaces.end());
}

SurfaceDetail GlobalMap::surface_detail(std::uint32_t id) const {
  const Surface* surface = this->surface(id);
  if (!surface) throw InputError("surface_detail: no surface " + std::to_string(id) + " in the map");
  if (surface->detail) return *surface->detail;
  std::vector<const MapCell*> cells;
  for (std::uint32_t cell_id : surface->cells) cells.push_back(&cells_.at(cell_id));
  return rebuild_detail(*surface, cells, config_.footprint_resolution_m);
}

bool GlobalMap::same_content(const GlobalMap& other) const {
  if (next_cell_id_ != other.next_cell_id_ || next_surface_id_ != other.next_surface_id_ ||
      cells_.size() != other.cells_.size() || surfaces_.size() != other.surfaces_.size())
    return false;
  for (const auto& [id, cell] : cells_) {
    const MapCell* o = other.cell(id);
    if (!o || !(cell == *o)) return false;
  }
  for (const auto& [id, surface] : surfaces_) {
    const Surface* o = other.surface(id);
    if (!o || !same_surface(surface, *o)) return false;
  }
  return true;
}

}  // namespace planecell::map
