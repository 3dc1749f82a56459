#pragma once
/// Configuration of the SGM disparity stage (mapping/stereo).
#include <string>

namespace planecell {

/// SGM (paper Eq. 1–2): Census + gradient matching cost, 8- or 4-path aggregation.
struct SgmConfig {
  int max_disparity = 128;  ///< number of disparities searched, d ∈ [0, max_disparity)
  int threads = 2;          ///< worker threads for cost + aggregation
};

template <class Visitor>
void visit_fields(SgmConfig& c, Visitor&& visit) {
  visit("max_disparity", c.max_disparity);
  visit("threads", c.threads);
}

}  // namespace planecell
