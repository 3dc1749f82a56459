#pragma once
/// Re-observation by coverage: how much of a new planecell the map already holds. A cell whose
/// polygon is mostly covered by nearly coplanar stored cells (whatever their surface label) adds no
/// new space to the map, so the map grows with the area explored, not with the number of frames.
#include <functional>
#include <span>

#include "core/planecell.hpp"
#include "mapping/map/geometry.hpp"

namespace planecell::map {

/// Stored cell `old` may cover `cell` when their normals are within `max_angle_deg` and the RMS
/// distance of old's vertices to cell's plane, √(Σ (n·v + e)² / K), is within `max_distance_m`.
bool nearly_coplanar(const Planecell& cell, const Planecell& old, double max_angle_deg,
                     double max_distance_m);

/// Share of `cell`'s polygon covered by the `covering` polygons, all projected orthogonally onto
/// cell's plane, estimated on a grid of about `samples` points over cell's bounding box:
///   covered ≈ |{grid points in cell and in some covering polygon}| / |{grid points in cell}| ∈ [0, 1];
/// 0 when no grid point falls inside the cell. The cost is O(samples · Σ vertices) whatever the
/// polygons' sizes in metres.
double covered_fraction(const Planecell& cell, std::span<const Planecell* const> covering,
                        int samples = 64);

/// Whether the grid point `st` of a cell's polygon (in the cell's own plane basis: 3D point
/// basis.to_3d(st)) is covered by something the map holds.
using CoverageTest = std::function<bool(const Eigen::Vector2d& st, const PlaneBasis& basis)>;

/// The same grid estimate with any coverage test: |{grid points in cell with covered(st)}| /
/// |{grid points in cell}|; 0 when no grid point falls inside the cell.
double covered_fraction(const Planecell& cell, const CoverageTest& covered, int samples = 64);

}  // namespace planecell::map
