#pragma once
/// Hand-made planecells shared by the map, merger, store tests and the merge benchmark.
#include <Eigen/Core>
#include <cstdint>

#include "core/planecell.hpp"

namespace planecell::test {

/// A rectangular world-frame cell with vertices corner, corner+e1, corner+e1+e2, corner+e2, its
/// exact plane (n = e1×e2 normalised, offset −n·corner), a one-bin colour histogram at
/// `colour_bin`, mean colour (4·bin, 100, 50), area 400 px and a 20×20 px image square.
Planecell rect_cell(std::uint32_t id, const Eigen::Vector3f& corner, const Eigen::Vector3f& e1,
                    const Eigen::Vector3f& e2, int colour_bin);

}  // namespace planecell::test
