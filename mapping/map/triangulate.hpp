#pragma once
/// Triangulation of a planecell's polygon (for meshes: PLY export). Ear clipping in the polygon's
/// own plane, so non-convex cells (consolidated unions: L shapes, combs, notches) are covered
/// exactly, which a fan around the vertex centroid does not do (the centroid may lie outside).
#include <Eigen/Core>
#include <array>
#include <span>
#include <vector>

namespace planecell::map {

/// Triangles (index triples into `vertices`) covering the polygon: n − 2 of them for n ≥ 3
/// vertices (none below), in the polygon's orientation. The polygon is projected onto the
/// coordinate plane most nearly parallel to it (the largest component of its Newell normal
/// N = Σ_k v_k × v_{k+1} is dropped), and ears are clipped: a vertex whose turn agrees with N and
/// whose triangle with its two neighbours holds no other remaining vertex. For a simple polygon
/// the triangles tile it exactly (their areas sum to the polygon's); for one that is not simple
/// (a simplification that made it touch itself), when no ear is left the most convex remaining
/// vertex is clipped, so the count stays n − 2. O(n²) per polygon.
std::vector<std::array<int, 3>> triangulate_polygon(std::span<const Eigen::Vector3f> vertices);

}  // namespace planecell::map
