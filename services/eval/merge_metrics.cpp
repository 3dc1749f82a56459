#include "services/eval/merge_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include "core/error.hpp"
#include "mapping/map/crf_merger.hpp"
#include "mapping/map/geometry.hpp"

namespace planecell::services::eval {

void MergeEvaluator::add_frame(const cv::Mat& labels, const cv::Mat& gt_surface_id,
                               std::span<const Planecell> cells_world,
                               const map::MergeReport& report) {
  if (labels.type() != CV_32S || gt_surface_id.type() != CV_16U || labels.size() != gt_surface_id.size())
    throw InputError("merge evaluation: label image (CV_32S) and GT surface ids (CV_16U) must have the same size");
  if (report.cell_surfaces.size() != cells_world.size())
    throw InputError("merge evaluation: the merge report does not describe these cells");
  // Pixel counts per (label, GT id); label = extraction id = Planecell::id.
  // Extraction ids are small (the frame's cell indices): label → slot through a dense table.
  std::uint32_t max_id = 0;
  for (const auto& cell : cells_world) max_id = std::max(max_id, cell.id);
  constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::vector<std::size_t> slot(cells_world.empty() ? 0 : static_cast<std::size_t>(max_id) + 1, kNone);
  for (std::size_t i = 0; i < cells_world.size(); ++i) slot[cells_world[i].id] = i;
  std::vector<std::map<std::uint16_t, std::uint32_t>> counts(cells_world.size());
  std::vector<std::uint32_t> totals(cells_world.size(), 0);
  for (int r = 0; r < labels.rows; ++r) {
    const auto* l = labels.ptr<std::int32_t>(r);
    const auto* g = gt_surface_id.ptr<std::uint16_t>(r);
    for (int c = 0; c < labels.cols; ++c) {
      if (l[c] < 0 || static_cast<std::size_t>(l[c]) >= slot.size() || slot[l[c]] == kNone) continue;
      ++counts[slot[l[c]]][g[c]];
      ++totals[slot[l[c]]];
    }
  }
  for (std::size_t i = 0; i < cells_world.size(); ++i) {
    if (report.cell_surfaces[i] == kNoSurface || totals[i] == 0) continue;
    const auto best = std::max_element(counts[i].begin(), counts[i].end(),
                                       [](const auto& a, const auto& b) { return a.second < b.second; });
    if (best->first == 0 || 2 * best->second < totals[i]) {
      ++mixed_;
      continue;
    }
    const Eigen::Vector3d centroid = map::vertex_centroid(cells_world[i].vertices_m);
    samples_.push_back({best->first, static_cast<float>(map::polygon_area_m2(cells_world[i].vertices_m)),
                        report.cell_surfaces[i], cells_world[i].depth_sigma_m, centroid.cast<float>(),
                        static_cast<float>(best->second) / static_cast<float>(totals[i]),
                        report.cell_fates.size() == cells_world.size() ? std::optional(report.cell_fates[i])
                                                                       : std::nullopt});
    if (const auto plane = gt_planes_.find(best->first); plane != gt_planes_.end() && !cells_world[i].vertices_m.empty()) {
      // θ' with σ = 1 m: the RMS distance of the vertices to the GT plane, in metres.
      plane_errors_m_.push_back(static_cast<float>(map::plane_residual(plane->second, cells_world[i].vertices_m, 1.0)));
      depth_sigmas_m_.push_back(cells_world[i].depth_sigma_m);
      plane_error_weak_.push_back(gt_weak_texture_.contains(best->first));
      const double cos_angle = std::min(1.0, std::abs(plane->second.normal.dot(cells_world[i].plane.normal)));
      normal_errors_deg_.push_back(static_cast<float>(std::acos(cos_angle) * 180.0 / std::numbers::pi));
      centroid_offsets_m_.push_back(static_cast<float>(std::abs(plane->second.signed_distance(centroid))));
    }
  }
  add_map_changes(report);
}

std::uint32_t MergeEvaluator::final_label(std::uint32_t label) const {
  for (auto it = merged_into_.find(label); it != merged_into_.end(); it = merged_into_.find(label))
    label = it->second;
  return label;
}

namespace {

/// sorted(values)[⌊q·(n−1)⌋] (lower nearest rank); 0 for no values.
double lower_quantile(std::vector<float> values, double q) {
  if (values.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(std::floor(q * static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

void MergeEvaluator::add_map_changes(const map::MergeReport& report) {
  for (const auto& merge : report.surface_merges) merged_into_[merge.absorbed] = merge.into;
  pruned_.insert(report.pruned_surfaces.begin(), report.pruned_surfaces.end());
}

MergeMetrics MergeEvaluator::finish() const {
  MergeMetrics m;
  m.plane_error_cells = plane_errors_m_.size();
  m.plane_error_median_m = lower_quantile(plane_errors_m_, 0.5);
  m.plane_error_p90_m = lower_quantile(plane_errors_m_, 0.9);
  m.depth_sigma_median_m = lower_quantile(depth_sigmas_m_, 0.5);
  m.normal_error_median_deg = lower_quantile(normal_errors_deg_, 0.5);
  m.centroid_offset_median_m = lower_quantile(centroid_offsets_m_, 0.5);
  std::vector<float> ratios, weak_errors, weak_ratios, weak_angles, weak_offsets;
  for (std::size_t i = 0; i < plane_errors_m_.size(); ++i) {
    if (plane_error_weak_[i]) {
      weak_errors.push_back(plane_errors_m_[i]);
      weak_angles.push_back(normal_errors_deg_[i]);
      weak_offsets.push_back(centroid_offsets_m_[i]);
    }
    if (!(depth_sigmas_m_[i] > 0.0f)) continue;
    ratios.push_back(plane_errors_m_[i] / depth_sigmas_m_[i]);
    if (plane_error_weak_[i]) weak_ratios.push_back(ratios.back());
  }
  m.plane_error_over_sigma_median = lower_quantile(std::move(ratios), 0.5);
  m.weak_plane_error_cells = weak_errors.size();
  m.weak_plane_error_median_m = lower_quantile(std::move(weak_errors), 0.5);
  m.weak_plane_error_over_sigma_median = lower_quantile(std::move(weak_ratios), 0.5);
  m.weak_normal_error_median_deg = lower_quantile(std::move(weak_angles), 0.5);
  m.weak_centroid_offset_median_m = lower_quantile(std::move(weak_offsets), 0.5);
  m.mixed_cells = mixed_;
  std::map<std::uint16_t, std::map<std::uint32_t, double>> gt_label_area;
  std::map<std::uint32_t, std::map<std::uint16_t, double>> label_gt_area;
  std::vector<std::uint32_t> final_labels;
  std::vector<const Sample*> kept;  // samples whose final label is still in the map
  final_labels.reserve(samples_.size());
  for (const auto& s : samples_) {
    const std::uint32_t label = final_label(s.label);
    if (pruned_.contains(label)) {
      ++m.pruned_cells;
      continue;
    }
    kept.push_back(&s);
    final_labels.push_back(label);
    gt_label_area[s.gt][label] += s.area_m2;
    label_gt_area[label][s.gt] += s.area_m2;
  }
  m.gt_surfaces = gt_label_area.size();
  m.labels = label_gt_area.size();
  // A GT surface's kind as named in the report ("unknown" without kinds).
  const auto kind_of = [this](std::uint16_t gt) {
    const auto it = gt_kinds_.find(gt);
    return it == gt_kinds_.end() ? std::string("unknown") : io::to_string(it->second);
  };
  double total = 0.0, dominant = 0.0, one_label = 0.0;
  std::map<std::string, MergeMetrics::KindShare> kinds;
  for (const auto& [gt, per_label] : gt_label_area) {
    double area = 0.0, best = 0.0;
    for (const auto& [label, a] : per_label) {
      area += a;
      best = std::max(best, a);
    }
    total += area;
    dominant += best;
    const bool one = best >= 0.9 * area;
    if (one) one_label += area;
    const std::string kind = kind_of(gt);
    const auto add_to = [&](MergeMetrics::KindShare& share) {
      ++share.gt_surfaces;
      share.area += area;
      if (one) share.one_label += area;
    };
    add_to(kinds.try_emplace(kind, MergeMetrics::KindShare{kind}).first->second);
    const bool weak = gt_weak_texture_.contains(gt);
    if (weak) add_to(m.weak_texture);
    if (!one && area > 0.0) m.split_surfaces.push_back({gt, kind, area, best / area, per_label.size(), weak});
  }
  if (total > 0.0) {
    m.area_in_dominant_label = dominant / total;
    m.area_one_label = one_label / total;
    const auto as_shares = [total](MergeMetrics::KindShare& share) {
      share.area /= total;
      share.one_label /= total;
      share.lost = share.area - share.one_label;
    };
    for (auto& [kind, share] : kinds) {
      as_shares(share);
      m.by_kind.push_back(share);
    }
    as_shares(m.weak_texture);
  }
  std::stable_sort(m.by_kind.begin(), m.by_kind.end(), [](const auto& a, const auto& b) { return a.lost > b.lost; });
  std::stable_sort(m.split_surfaces.begin(), m.split_surfaces.end(),
                   [](const auto& a, const auto& b) { return a.area_m2 > b.area_m2; });
  if (m.split_surfaces.size() > MergeMetrics::kSplitSurfacesReported)
    m.split_surfaces.resize(MergeMetrics::kSplitSurfacesReported);
  std::map<std::uint32_t, std::uint16_t> dominant_gt;
  for (const auto& [label, per_gt] : label_gt_area)
    dominant_gt[label] = std::max_element(per_gt.begin(), per_gt.end(), [](const auto& a, const auto& b) {
                           return a.second < b.second;
                         })->first;
  const auto group = [this](std::uint16_t gt) {
    const auto it = groups_.find(gt);
    return it == groups_.end() ? gt : it->second;
  };
  // Whether a cell's depth resolves its own GT plane from its label's (see the field's doc).
  const auto resolvable = [this](const Sample& s, std::uint16_t dominant) {
    const auto own = gt_planes_.find(s.gt), other = gt_planes_.find(dominant);
    if (own == gt_planes_.end() || other == gt_planes_.end()) return true;
    const Eigen::Vector3d c = s.centroid.cast<double>();
    const Eigen::Vector3d p = c - own->second.signed_distance(c) * own->second.normal;
    return std::abs(other->second.signed_distance(p)) > 2.0 * static_cast<double>(s.depth_sigma_m);
  };
  std::size_t crossed = 0, crossed_planes = 0, crossed_resolvable = 0, crossed_boundary = 0;
  std::map<std::pair<std::string, std::string>, std::size_t> crossed_kinds;
  std::map<map::CellFate, std::pair<std::size_t, std::size_t>> by_fate;  ///< fate → (cells, crossed)
  for (std::size_t k = 0; k < kept.size(); ++k) {
    const std::uint16_t dominant = dominant_gt.at(final_labels[k]);
    if (dominant != kept[k]->gt) ++crossed;
    const bool crossed_plane = group(dominant) != group(kept[k]->gt);
    if (kept[k]->fate) {
      auto& [cells, crossed_cells] = by_fate[*kept[k]->fate];
      ++cells;
      crossed_cells += crossed_plane;
    }
    if (crossed_plane) {
      ++crossed_planes;
      ++crossed_kinds[{kind_of(kept[k]->gt), kind_of(dominant)}];
      if (resolvable(*kept[k], dominant)) ++crossed_resolvable;
      if (kept[k]->purity < MergeMetrics::kPureCellShare) ++crossed_boundary;
    }
  }
  for (const auto& [kinds, count] : crossed_kinds)
    m.crossed_by_kinds.push_back(
        {kinds.first, kinds.second, static_cast<double>(count) / static_cast<double>(kept.size())});
  std::stable_sort(m.crossed_by_kinds.begin(), m.crossed_by_kinds.end(),
                   [](const auto& a, const auto& b) { return a.cells > b.cells; });
  for (const auto& [fate, counts] : by_fate)
    m.crossed_by_fate.push_back({map::fate_name(fate),
                                 static_cast<double>(counts.first) / static_cast<double>(kept.size()),
                                 static_cast<double>(counts.second) / static_cast<double>(kept.size())});
  m.cells = kept.size();
  if (!kept.empty()) {
    m.cross_merged_cells = static_cast<double>(crossed) / static_cast<double>(kept.size());
    m.cross_merged_cells_between_planes = static_cast<double>(crossed_planes) / static_cast<double>(kept.size());
    m.cross_merged_cells_resolvable = static_cast<double>(crossed_resolvable) / static_cast<double>(kept.size());
    m.cross_merged_cells_boundary = static_cast<double>(crossed_boundary) / static_cast<double>(kept.size());
  }
  return m;
}

std::unordered_map<std::uint16_t, std::uint16_t> coplanar_groups(std::span<const io::SyntheticSurface> surfaces,
                                                                 double max_angle_deg, double max_offset_m,
                                                                 double touch_m) {
  const double cos_max = std::cos(max_angle_deg * std::numbers::pi / 180.0);
  std::vector<std::vector<Eigen::Vector3f>> corners;
  corners.reserve(surfaces.size());
  for (const auto& s : surfaces) {
    corners.emplace_back();
    for (const Eigen::Vector3d& c : s.corners_world()) corners.back().push_back(c.cast<float>());
  }
  map::UnionFind groups;  // the smaller id becomes the root
  for (std::size_t i = 0; i < surfaces.size(); ++i)
    for (std::size_t j = i + 1; j < surfaces.size(); ++j) {
      const Plane3& a = surfaces[i].plane;
      const Plane3& b = surfaces[j].plane;
      const double dot = a.normal.dot(b.normal);
      const double offset_b = dot < 0.0 ? -b.offset : b.offset;
      if (std::abs(dot) < cos_max || std::abs(a.offset - offset_b) > max_offset_m) continue;
      if (groups.find(surfaces[i].id) == groups.find(surfaces[j].id)) continue;
      if (map::polygons_within_m(a, corners[i], b, corners[j], touch_m)) groups.unite(surfaces[i].id, surfaces[j].id);
    }
  std::unordered_map<std::uint16_t, std::uint16_t> out;
  for (const auto& s : surfaces) out[s.id] = static_cast<std::uint16_t>(groups.find(s.id));
  return out;
}

}  // namespace planecell::services::eval
