#pragma once
/// Hand-made planecells shared by the map, merger, store tests and the merge benchmark.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/planecell.hpp"

namespace planecell::test {

/// The world axes, as rect_cell edge directions.
inline const Eigen::Vector3f kX(1, 0, 0), kY(0, 1, 0), kZ(0, 0, 1);

/// The axis-aligned rectangle [s0, s1] × [t0, t1] as a ring of four 2D vertices.
inline std::vector<Eigen::Vector2d> rectangle(double s0, double t0, double s1, double t1) {
  return {{s0, t0}, {s0, t1}, {s1, t1}, {s1, t0}};
}

/// A rectangular world-frame cell with vertices corner, corner+e1, corner+e1+e2, corner+e2, its
/// exact plane (n = e1×e2 normalised, offset −n·corner), a one-bin colour histogram at
/// `colour_bin`, mean colour (4·bin, 100, 50), area 400 px and a 20×20 px image square.
Planecell rect_cell(std::uint32_t id, const Eigen::Vector3f& corner, const Eigen::Vector3f& e1,
                    const Eigen::Vector3f& e2, int colour_bin);

/// Tiles the rectangle origin + [0, a_len]·a + [0, b_len]·b into square rect_cells of edge
/// `tile_m` (ids continue from out.size(), inlier ratio 1), starting `shift_m` into the rectangle
/// along both axes (cells are clipped to the rectangle).
void tile(std::vector<Planecell>& out, const Eigen::Vector3f& origin, const Eigen::Vector3f& a,
          const Eigen::Vector3f& b, float a_len, float b_len, float tile_m, float shift_m, int bin);

/// World (KITTI camera-style: x right, y down, z forward; road at y = 1.65) street cells: road
/// x ∈ [−5, 5], z ∈ [3, 20], and unless `ground_only` two side walls (x = ±5) and a facade at
/// z = 20, all 2 m tiles. `shift_m` offsets the tiling so a frame's cells differ from the map's.
std::vector<Planecell> street_cells(float shift_m, bool ground_only);

}  // namespace planecell::test
