#pragma once
/// Re-observation by coverage: how much of a new planecell the map already holds. A cell whose
/// polygon is mostly covered by nearly coplanar stored cells or surface footprints (whatever their
/// surface label) adds no new space to the map, so the map grows with the area explored, not with the number of frames.
#include <functional>
#include <span>
#include <vector>

#include "core/planecell.hpp"
#include "mapping/map/geometry.hpp"
#include "mapping/map/map_cell.hpp"

namespace planecell::map {

/// The polygon `vertices` (on `vertices_plane`) nearly lies on `plane`: the normals are within
/// `max_angle_deg` and the RMS distance of the vertices to `plane`, √(Σ (n·v + e)² / K), is within
/// `max_distance_m`. False for an empty polygon.
bool nearly_coplanar(const Plane3& plane, const Plane3& vertices_plane,
                     std::span<const Eigen::Vector3f> vertices, double max_angle_deg,
                     double max_distance_m);

/// Stored cell `old` may cover `cell`: old's polygon nearly lies on cell's plane (as above).
bool nearly_coplanar(const Planecell& cell, const MapCell& old, double max_angle_deg,
                     double max_distance_m);

/// Whether the grid point `st` of a cell's polygon (in the cell's own plane basis: 3D point
/// basis.to_3d(st)) is covered by something the map holds.
using CoverageTest = std::function<bool(const Eigen::Vector2d& st, const PlaneBasis& basis)>;

/// Grid points per coverage estimate, by default.
inline constexpr int kCoverageSamples = 64;

/// The sample points of a coverage estimate: the centres of a square grid of about `samples`
/// squares over `box`, the bounding box of the polygon `vertices` projected into `basis` =
/// make_basis(plane, vertex centroid), those inside the polygon (even-odd rule), in row order.
/// No points for fewer than 3 vertices, samples < 1, or a polygon of zero or non-finite area.
struct CoverageGrid {
  PlaneBasis basis;
  Eigen::AlignedBox2d box;
  std::vector<Eigen::Vector2d> points;
};
CoverageGrid coverage_grid(const Plane3& plane, std::span<const Eigen::Vector3f> vertices,
                           int samples = kCoverageSamples);

/// Share of `grid`'s points passing `covered` (0 without points). The points are tested in
/// order; once the share can no longer reach `min_fraction` (misses > (1 − min_fraction) · points),
/// testing stops and the share reachable at that point, (points − misses) / points < min_fraction,
/// is returned. So the result is exact whenever it is ≥ min_fraction, and
/// `covered_fraction(...) >= min_fraction` decides as the full estimate would (min_fraction = 0:
/// always exact).
double covered_fraction(const CoverageGrid& grid, const CoverageTest& covered, double min_fraction = 0.0);

/// covered_fraction(grid, covered, min_fraction) with the test inlined (`covered(st)` → bool).
template <class Test>
double covered_fraction_by(const CoverageGrid& grid, Test&& covered, double min_fraction = 0.0) {
  if (grid.points.empty()) return 0.0;
  const auto n = static_cast<double>(grid.points.size());
  std::size_t misses = 0;
  for (const auto& st : grid.points) {
    if (covered(st)) continue;
    // The share can reach at most (points − misses) / points: below min_fraction, stop here.
    if (const double best = static_cast<double>(grid.points.size() - ++misses) / n; best < min_fraction)
      return best;
  }
  return static_cast<double>(grid.points.size() - misses) / n;
}

/// Share of the polygon `vertices` (on `plane`) passing `covered`, estimated on its coverage_grid:
///   covered ≈ |{grid points in the polygon with covered(st)}| / |{grid points in the polygon}|,
/// 0 when no grid point falls inside it; `min_fraction` stops early as above.
double covered_fraction(const Plane3& plane, std::span<const Eigen::Vector3f> vertices,
                        const CoverageTest& covered, int samples = kCoverageSamples,
                        double min_fraction = 0.0);

/// The same estimate with "inside one of the `covering` polygons, all projected orthogonally onto
/// `plane`" as the test ∈ [0, 1]. The cost is O(samples · Σ vertices) whatever the polygons' sizes
/// in metres.
double covered_fraction(const Plane3& plane, std::span<const Eigen::Vector3f> vertices,
                        std::span<const std::span<const Eigen::Vector3f>> covering,
                        int samples = kCoverageSamples, double min_fraction = 0.0);

/// The same on a grid made already (coverage_grid of the covered polygon).
double covered_fraction(const CoverageGrid& grid, std::span<const std::span<const Eigen::Vector3f>> covering,
                        double min_fraction = 0.0);

/// covered_fraction of the polygon whose coverage grid is `grid` by the `covering` cells (any cells
/// with vertices_m: Planecell, MapCell).
template <class Covering>
double covered_fraction(const CoverageGrid& grid, const std::vector<const Covering*>& covering,
                        double min_fraction = 0.0) {
  std::vector<std::vector<Eigen::Vector3f>> scratch(covering.size());
  std::vector<std::span<const Eigen::Vector3f>> polygons;
  polygons.reserve(covering.size());
  for (std::size_t k = 0; k < covering.size(); ++k)
    polygons.push_back(as_span(covering[k]->vertices_m, scratch[k]));
  return covered_fraction(grid, polygons, min_fraction);
}

/// covered_fraction of `cell` by the `covering` cells (any cells with plane and vertices_m:
/// Planecell, MapCell).
template <class Cell, class Covering>
double covered_fraction(const Cell& cell, const std::vector<const Covering*>& covering,
                        int samples = kCoverageSamples, double min_fraction = 0.0) {
  if (covering.empty()) return 0.0;
  std::vector<Eigen::Vector3f> scratch;
  return covered_fraction(coverage_grid(cell.plane, as_span(cell.vertices_m, scratch), samples), covering,
                          min_fraction);
}

/// Whether the `covering` cells cover at least `min_fraction` of `cell`:
/// covered_fraction(cell, covering) ≥ min_fraction, testing no more points than that decision needs.
template <class Cell, class Covering>
bool covers_at_least(const Cell& cell, const std::vector<const Covering*>& covering, double min_fraction) {
  return covered_fraction(cell, covering, kCoverageSamples, min_fraction) >= min_fraction;
}
/// The same on the cell's coverage grid made already.
template <class Covering>
bool covers_at_least(const CoverageGrid& grid, const std::vector<const Covering*>& covering, double min_fraction) {
  return covered_fraction(grid, covering, min_fraction) >= min_fraction;
}

}  // namespace planecell::map
