#include "core/frame.hpp"

#include <cmath>

namespace planecell {

bool is_valid_disparity(float d) { return std::isfinite(d) && d > 0.0f; }

}  // namespace planecell
