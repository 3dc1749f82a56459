#pragma once
/// How well the CRF merger groups cells into surfaces, against the synthetic renderer's ground-truth
/// surface ids (issue "global map" targets: ≥ 90 % of GT surface area under one label each, < 2 %
/// of cells merged across different GT surfaces).
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <span>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "core/planecell.hpp"
#include "mapping/map/global_map.hpp"

namespace planecell::services::eval {

struct MergeMetrics {
  std::size_t cells = 0;         ///< integrated cells with a pure GT surface (see add_frame)
  std::size_t mixed_cells = 0;   ///< cells left out: < 50 % of their pixels on one GT surface
  std::size_t gt_surfaces = 0;   ///< GT surfaces covered by at least one cell
  std::size_t labels = 0;        ///< final map surfaces those cells ended in
  std::size_t pruned_cells = 0;  ///< cells whose surface was pruned as unconfirmed (left out)
  /// Σ_g A(g, L*(g)) / Σ_g A(g): share of GT surface area (cell areas, m²) that lies in its GT
  /// surface's dominant label L*(g) = argmax_L A(g, L).
  double area_in_dominant_label = 0.0;
  /// Share of GT surface area belonging to GT surfaces that are "one label": A(g, L*(g)) ≥ 0.9 A(g).
  double area_one_label = 0.0;
  /// Share of cells whose final label's dominant GT surface (by area) is not their own.
  double cross_merged_cells = 0.0;
};

/// Accumulates, frame by frame, (GT surface, area, map surface) for every integrated cell, and
/// follows later surface merges to each cell's final label.
class MergeEvaluator {
 public:
  /// `labels` is the extraction label image (CV_32S, value = the cell's extraction id), `gt_surface_id` the
  /// renderer's CV_16U ids (0 = none), `cells_world` the cells handed to GlobalMap::integrate and
  /// `report` what it returned. A cell's GT surface is the id of the majority of its pixels; cells
  /// whose majority is below 50 % or is "none" are counted as mixed and left out.
  /// Throws InputError on mismatched sizes or types.
  void add_frame(const cv::Mat& labels, const cv::Mat& gt_surface_id,
                 std::span<const Planecell> cells_world, const map::MergeReport& report);

  MergeMetrics finish() const;

 private:
  struct Sample {
    std::uint16_t gt = 0;
    float area_m2 = 0.0f;
    std::uint32_t label = 0;
  };
  std::uint32_t final_label(std::uint32_t label) const;

  std::vector<Sample> samples_;
  std::size_t mixed_ = 0;
  std::unordered_map<std::uint32_t, std::uint32_t> merged_into_;  ///< absorbed → into
  std::unordered_set<std::uint32_t> pruned_;  ///< surfaces pruned as unconfirmed: not in the map
};

}  // namespace planecell::services::eval
