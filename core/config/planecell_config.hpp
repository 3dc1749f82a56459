#pragma once
/// Configuration of planecell extraction (mapping/planecell).

namespace planecell {

/// Depth-aware superpixels + RANSAC planes + vertices (paper §4.2–5.1).
struct ExtractionConfig {
  int target_cells = 800;  ///< |S|, the number of planecells asked for
};

template <class Visitor>
void visit_fields(ExtractionConfig& c, Visitor&& visit) {
  visit("target_cells", c.target_cells);
}

}  // namespace planecell
