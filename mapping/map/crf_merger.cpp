#include "mapping/map/crf_merger.hpp"

#include <Eigen/Eigenvalues>
#include <opencv2/core.hpp>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "core/error.hpp"
#include "mapping/map/geometry.hpp"

namespace planecell::map {
namespace {

double rms_distance_m(const Plane3& plane, std::span<const Eigen::Vector3f> vertices) {
  if (vertices.empty()) return 0.0;
  double sum = 0.0;
  for (const auto& v : vertices) {
    const double d = plane.signed_distance(v.cast<double>());
    sum += d * d;
  }
  return std::sqrt(sum / static_cast<double>(vertices.size()));
}

/// Midpoint of the closest pair of vertices of two polygons (the boundary point m of ψ).
Eigen::Vector3d boundary_point(std::span<const Eigen::Vector3f> a,
                               std::span<const Eigen::Vector3f> b) {
  if (a.empty() || b.empty()) return Eigen::Vector3d::Zero();
  float best = std::numeric_limits<float>::infinity();
  const Eigen::Vector3f* best_a = a.data();
  const Eigen::Vector3f* best_b = b.data();
  for (const auto& va : a)
    for (const auto& vb : b)
      if (const float d2 = (va - vb).squaredNorm(); d2 < best) best = d2, best_a = &va, best_b = &vb;
  return 0.5 * (*best_a + *best_b).cast<double>();  // the first closest pair
}

}  // namespace

std::vector<LabelEdge> label_adjacency(const cv::Mat& labels) {
  if (labels.empty() || labels.type() != CV_32S)
    throw InputError("label_adjacency: label image must be a non-empty CV_32S matrix");
  // The largest label, in a loop the compiler vectorises (cv::minMaxLoc also tracks where).
  std::int32_t max_label = -1;
  for (int r = 0; r < labels.rows; ++r) {
    const auto* row = labels.ptr<std::int32_t>(r);
    for (int c = 0; c < labels.cols; ++c) max_label = std::max(max_label, row[c]);
  }
  std::vector<LabelEdge> out;
  if (max_label < 0) return out;
  /// Visits every 4-connected pixel pair with two different non-negative labels as (lo, hi).
  /// Most pixels equal their right and lower neighbours: a block of 8 whose XORs with them are
  /// all zero holds no pair and is skipped whole (branch-free test, vectorised).
  auto for_each_pair = [&](auto&& count) {
    const int cols = labels.cols;
    for (int r = 0; r < labels.rows; ++r) {
      const auto* row = labels.ptr<std::int32_t>(r);
      // The last row has no row below: compared with itself, it adds no vertical pair.
      const auto* below = r + 1 < labels.rows ? labels.ptr<std::int32_t>(r + 1) : row;
      const auto visit = [&](int c) {
        const std::int32_t p = row[c];
        if (p < 0) return;
        if (c + 1 < cols && row[c + 1] != p && row[c + 1] >= 0) count(std::min(p, row[c + 1]), std::max(p, row[c + 1]));
        if (below[c] != p && below[c] >= 0) count(std::min(p, below[c]), std::max(p, below[c]));
      };
      constexpr int kBlock = 8;
      int c = 0;
      for (; c + kBlock < cols; c += kBlock) {  // row[c + kBlock] exists: the right neighbours
        std::int32_t differ = 0;
        for (int k = 0; k < kBlock; ++k) differ |= (row[c + k] ^ row[c + k + 1]) | (row[c + k] ^ below[c + k]);
        if (differ != 0)
          for (int k = 0; k < kBlock; ++k) visit(c + k);
      }
      for (; c < cols; ++c) visit(c);
    }
  };
  const auto pixels = static_cast<double>(labels.total());
  if (static_cast<double>(max_label) <= 4.0 * pixels + 1024.0) {
    // Dense labels (a segmentation's 0..n−1): each label's few neighbours in a short list.
    std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> neighbours(
        static_cast<std::size_t>(max_label) + 1);
    for_each_pair([&](std::int32_t lo, std::int32_t hi) {
      auto& list = neighbours[static_cast<std::size_t>(lo)];
      for (auto& [label, n] : list)
        if (label == static_cast<std::uint32_t>(hi)) {
          ++n;
          return;
        }
      list.emplace_back(static_cast<std::uint32_t>(hi), 1u);
    });
    for (std::size_t lo = 0; lo < neighbours.size(); ++lo) {
      auto& list = neighbours[lo];
      std::sort(list.begin(), list.end());
      for (const auto& [hi, n] : list) out.push_back({static_cast<std::uint32_t>(lo), hi, n});
    }
    return out;
  }
  // Sparse label values: a hash map of pairs.
  std::unordered_map<std::uint64_t, std::uint32_t> counts;
  for_each_pair([&](std::int32_t lo, std::int32_t hi) {
    ++counts[(static_cast<std::uint64_t>(lo) << 32) | static_cast<std::uint64_t>(hi)];
  });
  out.reserve(counts.size());
  for (const auto& [key, n] : counts)
    out.push_back({static_cast<std::uint32_t>(key >> 32), static_cast<std::uint32_t>(key), n});
  std::sort(out.begin(), out.end(),
            [](const LabelEdge& x, const LabelEdge& y) { return std::tie(x.a, x.b) < std::tie(y.a, y.b); });
  return out;
}

double colour_similarity(const ColourHistogram& a, const ColourHistogram& b) {
  // Four partial sums (bins q ≡ l mod 4): independent additions the compiler vectorises.
  static_assert(kColourHistogramBins % 4 == 0);
  double sum[4] = {0.0, 0.0, 0.0, 0.0};
  for (int q = 0; q < kColourHistogramBins; q += 4)
    for (int l = 0; l < 4; ++l) sum[l] += static_cast<double>(std::min(a[q + l], b[q + l]));
  return (sum[0] + sum[1]) + (sum[2] + sum[3]);
}

Eigen::Vector3d histogram_chromaticity(const ColourHistogram& histogram) {
  // Bin q = 16·l_R + 4·l_G + l_B; level l's centre is 31.5 + 64·l (mapping/planecell's soft bins).
  // Σ h and Σ h·l per channel, over the 16 runs of four bins sharing (l_R, l_G).
  static_assert(kColourHistogramBins == 64);
  double mass = 0.0;
  Eigen::Vector3d levels = Eigen::Vector3d::Zero();
  for (int r = 0; r < 4; ++r)
    for (int g = 0; g < 4; ++g) {
      const float* run = histogram.data() + 16 * r + 4 * g;  // l_B = 0, 1, 2, 3
      const double run_mass = (double{run[0]} + run[1]) + (double{run[2]} + run[3]);
      mass += run_mass;
      levels += Eigen::Vector3d(r * run_mass, g * run_mass, double{run[1]} + 2.0 * run[2] + 3.0 * run[3]);
    }
  if (!(mass > 0.0)) return Eigen::Vector3d::Constant(1.0 / 3.0);
  const Eigen::Vector3d sum = (31.5 * mass + 64.0 * levels.array()).matrix();
  return sum / sum.sum();
}

double plane_residual(const Plane3& plane_i, std::span<const Eigen::Vector3f> vertices_j,
                      double sigma_m) {
  return rms_distance_m(plane_i, vertices_j) / sigma_m;
}

double pose_potential(double area_i_m2, double area_j_m2, double theta_ij, double theta_ji) {
  return (area_i_m2 + area_j_m2) / (theta_ij * theta_ij + theta_ji * theta_ji + 1.0);
}

double boundary_potential(double boundary_m, double theta_c) {
  return boundary_m / (theta_c * theta_c + 1.0);
}

std::uint32_t UnionFind::find(std::uint32_t label) {
  auto it = parent_.find(label);
  if (it == parent_.end()) return label;
  std::uint32_t root = label;
  while (true) {
    auto p = parent_.find(root);
    if (p == parent_.end() || p->second == root) break;
    auto gp = parent_.find(p->second);
    if (gp != parent_.end()) p->second = gp->second;  // path halving
    root = p->second;
  }
  return root;
}

std::uint32_t UnionFind::unite(std::uint32_t a, std::uint32_t b) {
  const std::uint32_t ra = find(a), rb = find(b);
  if (ra == rb) return ra;
  const std::uint32_t root = std::min(ra, rb), child = std::max(ra, rb);
  parent_[child] = root;
  return root;
}

void PlaneMoments::add_polygon(std::span<const Eigen::Vector3f> vertices, double total_weight) {
  if (vertices.empty() || !(total_weight > 0.0)) return;
  const double w = total_weight / static_cast<double>(vertices.size());
  for (const auto& v : vertices) {
    const Eigen::Vector3d p = v.cast<double>();
    weight += w;
    sum += w * p;
    sum_outer += w * p * p.transpose();
  }
}

void PlaneMoments::add(const PlaneMoments& other) {
  weight += other.weight;
  sum += other.sum;
  sum_outer += other.sum_outer;
}

namespace {

/// The least-squares plane of moments through their mean: the normal is the scatter's eigenvector
/// of the smallest eigenvalue, turned towards `orientation`; `solver` holds the scatter's
/// decomposition.
Plane3 plane_of(const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>& solver, const Eigen::Vector3d& mean,
                const Eigen::Vector3d& orientation) {
  Plane3 plane;
  plane.normal = solver.eigenvectors().col(0).normalized();
  if (plane.normal.dot(orientation) < 0.0) plane.normal = -plane.normal;
  plane.offset = -plane.normal.dot(mean);
  return plane;
}

/// The moments' mean Σw·x / Σw and centred scatter Σw·x·xᵀ / Σw − mean·meanᵀ (weight > 0).
std::pair<Eigen::Vector3d, Eigen::Matrix3d> mean_and_scatter(const PlaneMoments& m) {
  const Eigen::Vector3d mean = m.sum / m.weight;
  return {mean, m.sum_outer / m.weight - mean * mean.transpose()};
}

}  // namespace

Plane3 PlaneMoments::fit(const Eigen::Vector3d& orientation) const {
  const auto [mean, scatter] = mean_and_scatter(*this);
  return plane_of(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter), mean, orientation);
}

double PlaneMoments::rms_distance_m(const Plane3& plane) const {
  if (!(weight > 0.0)) return 0.0;
  const Eigen::Vector3d& n = plane.normal;
  const double e = plane.offset;
  const double mean_square = (n.dot(sum_outer * n) + 2.0 * e * n.dot(sum) + e * e * weight) / weight;
  return std::sqrt(std::max(0.0, mean_square));
}

double effective_sigma_m(const PlaneMoments& moments, double observed_area_m2) {
  return effective_sigma_m(moments.weight, observed_area_m2);
}

double effective_sigma_m(double information, double observed_area_m2) {
  return information > 0.0 ? std::sqrt(observed_area_m2 / information) : 0.0;
}

double LabelState::sigma_m() const { return effective_sigma_m(moments, observed_area_m2); }

double LabelState::range_sigma_m() const {
  return range_information > 0.0 ? std::sqrt(observed_area_m2 / range_information) : sigma_m();
}

double normal_depth_sigma_m(const Planecell& cell, const Eigen::Vector3d& camera_centre) {
  if (cell.vertices_m.empty()) return 0.0;
  const double range = (vertex_centroid(cell.vertices_m) - camera_centre).norm();
  const double sigma_z = static_cast<double>(cell.depth_sigma_m);
  if (!(range > 0.0)) return sigma_z;
  return sigma_z * std::min(1.0, std::abs(cell.plane.signed_distance(camera_centre)) / range);
}

LabelState state_of_cell(const Planecell& cell, double area_m2, double range_sigma_m, double sigma_floor_m,
                         double tilt_scale) {
  const double sigma = std::max(static_cast<double>(cell.depth_sigma_m), sigma_floor_m);
  const double range_sigma = std::max(range_sigma_m, sigma_floor_m);
  LabelState s;
  s.plane = cell.plane;
  s.moments.add_polygon(cell.vertices_m, area_m2 / (sigma * sigma));
  s.range_information = area_m2 / (range_sigma * range_sigma);
  s.histogram = cell.histogram;
  s.chromaticity = histogram_chromaticity(s.histogram);
  s.histogram_weight_m2 = area_m2;
  s.area_m2 = area_m2;
  s.observed_area_m2 = area_m2;
  s.cells = 1;
  s.tilt_sigma_rad = tilt_scale * static_cast<double>(cell.normal_sigma_rad);
  return s;
}

void fold_label(LabelState& into, const LabelState& from) {
  const double w = into.histogram_weight_m2 + from.histogram_weight_m2;
  if (w > 0.0)
    for (int q = 0; q < kColourHistogramBins; ++q)
      into.histogram[q] = static_cast<float>(
          (into.histogram[q] * into.histogram_weight_m2 + from.histogram[q] * from.histogram_weight_m2) / w);
  into.chromaticity = histogram_chromaticity(into.histogram);
  into.histogram_weight_m2 = w;
  into.area_m2 += from.area_m2;
  into.observed_area_m2 += from.observed_area_m2;
  into.cells += from.cells;
  const auto range_information = [](const LabelState& l) {
    return l.range_information > 0.0 ? l.range_information : l.moments.weight;
  };
  into.range_information = range_information(into) + range_information(from);
  into.moments.add(from.moments);
  into.tilt_sigma_rad = into.tilt_sigma_rad > 0.0 && from.tilt_sigma_rad > 0.0
                            ? 1.0 / std::sqrt(1.0 / (into.tilt_sigma_rad * into.tilt_sigma_rad) +
                                              1.0 / (from.tilt_sigma_rad * from.tilt_sigma_rad))
                            : 0.0;
  // Refit only when the vertices span a plane (two non-negligible scatter eigenvalues).
  if (into.moments.weight > 0.0) {
    const auto [mean, scatter] = mean_and_scatter(into.moments);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
    if (solver.eigenvalues()(1) > 1e-8) into.plane = plane_of(solver, mean, into.plane.normal);
  }
}

CrfMerger::CrfMerger(const MapConfig& config) : config_(config) {
  if (!(config.residual_scale_m > 0.0))
    throw ConfigError("map.residual_scale_m: must be > 0, got " + std::to_string(config.residual_scale_m));
  if (!(config.max_normal_angle_deg >= 0.0 && config.max_normal_angle_deg <= 90.0))
    throw ConfigError("map.max_normal_angle_deg: must be in [0, 90], got " +
                      std::to_string(config.max_normal_angle_deg));
}

EdgeEvaluation CrfMerger::evaluate_range(const MergeUnit& a, const LabelState& label_a,
                                         const MergeUnit& b, const LabelState& label_b) const {
  EdgeEvaluation ev;
  const auto va = a.vertices;
  const auto vb = b.vertices;
  const double cos_angle = std::min(1.0, std::abs(label_a.plane.normal.dot(label_b.plane.normal)));
  ev.angle_deg = std::acos(cos_angle) * 180.0 / std::numbers::pi;
  // Variation range, asymmetric: the less-informed label (lo) on the better-informed one's plane.
  const bool a_is_hi = label_a.moments.weight >= label_b.moments.weight;
  const LabelState& hi = a_is_hi ? label_a : label_b;
  const LabelState& lo = a_is_hi ? label_b : label_a;
  const double k = config_.depth_sigma_factor;
  constexpr double kDeg = 180.0 / std::numbers::pi;
  // A tilt widens the range by at most max_noisy_normal_angle_deg in all.
  auto with_tilt = [&](double angle_deg, double tilt_rad) {
    return tilt_rad > 0.0 ? std::max(angle_deg, std::min(angle_deg + k * tilt_rad * kDeg,
                                                         config_.max_noisy_normal_angle_deg))
                          : angle_deg;
  };
  auto distance_tolerance = [&](const LabelState& s) {
    return std::max(config_.max_plane_distance_m, k * s.range_sigma_m());
  };
  auto angle_tolerance = [&](const LabelState& s) {
    const double extent_m = std::sqrt(std::max(s.observed_area_m2, 1e-6));
    const double widen = std::atan(k * s.range_sigma_m() / extent_m) * kDeg;
    return with_tilt(config_.max_normal_angle_deg + std::min(widen, config_.max_normal_angle_deg), s.tilt_sigma_rad);
  };
  ev.distance_m = lo.moments.rms_distance_m(hi.plane);
  const auto mature = static_cast<std::uint32_t>(std::max(config_.mature_cells, 1));
  bool in_range;
  if (lo.cells >= mature && hi.cells >= mature) {
    // Both planes are well determined: they must be parallel and continuous where they meet,
    // i.e. the step between them at the boundary point m (between the edge's two cells) is small.
    const Eigen::Vector3d m = 0.5 * (vertex_centroid(va) + vertex_centroid(vb));
    const double sign = hi.plane.normal.dot(lo.plane.normal) < 0.0 ? -1.0 : 1.0;
    const double step_m = std::abs(hi.plane.signed_distance(m) - sign * lo.plane.signed_distance(m));
    in_range = step_m <= config_.max_plane_distance_m &&
               ev.angle_deg <= with_tilt(config_.max_normal_angle_deg, std::hypot(lo.tilt_sigma_rad, hi.tilt_sigma_rad));
  } else {
    in_range = ev.distance_m <= distance_tolerance(lo) && ev.angle_deg <= angle_tolerance(lo);
    if (lo.moments.weight >= config_.mutual_information_fraction * hi.moments.weight)
      in_range = in_range && hi.moments.rms_distance_m(lo.plane) <= distance_tolerance(hi) &&
                 ev.angle_deg <= angle_tolerance(hi);
  }
  if (!in_range) return ev;  // out of the variation range: the colour is not needed
  ev.colour_similarity = colour_similarity(lo.histogram, hi.histogram);
  ev.in_range = ev.colour_similarity >= config_.min_colour_similarity &&
                !other_paint(lo.chromaticity, hi.chromaticity, config_.max_chromaticity_distance);
  return ev;
}

EdgeEvaluation CrfMerger::evaluate(const MergeUnit& a, const LabelState& label_a,
                                   const MergeUnit& b, const LabelState& label_b,
                                   double boundary_m) const {
  EdgeEvaluation ev = evaluate_range(a, label_a, b, label_b);
  if (!ev.in_range) return ev;  // never merged: the gain only orders the edges in range
  const auto va = a.vertices;
  const auto vb = b.vertices;
  // Energy gained (the greedy's visiting order): δ + φ + ψ of the edge's two cells.
  const double sigma = config_.residual_scale_m;
  const double delta_a = colour_similarity(a.histogram ? *a.histogram : label_a.histogram, label_b.histogram);
  const double delta_b = colour_similarity(b.histogram ? *b.histogram : label_b.histogram, label_a.histogram);
  const double phi = pose_potential(a.area_m2, b.area_m2, plane_residual(a.plane, vb, sigma),
                                    plane_residual(b.plane, va, sigma));
  const Eigen::Vector3d m = boundary_point(va, vb);
  const double s = a.plane.normal.dot(b.plane.normal) < 0.0 ? -1.0 : 1.0;
  const double theta_c =
      std::abs(a.plane.signed_distance(m) - s * b.plane.signed_distance(m)) / sigma;
  ev.gain = delta_a + delta_b + phi + boundary_potential(boundary_m, theta_c);
  return ev;
}

std::vector<std::pair<std::uint32_t, std::uint32_t>> CrfMerger::merge(
    std::span<const MergeUnit> units, std::span<const MergeEdge> edges,
    std::unordered_map<std::uint32_t, LabelState>& labels, UnionFind& union_find) const {
  std::vector<std::pair<std::uint32_t, std::uint32_t>> merges;
  struct Candidate {
    double gain;
    std::size_t edge;
  };
  std::vector<Candidate> candidates;
  candidates.reserve(edges.size());
  // The labels in play get dense slots (hash lookups once per unit, not per evaluation): slot s is
  // label label_of[s] with state *state[s], union-find parent parent[s] (a root's label is the
  // smallest of its set, as UnionFind::unite keeps it) and changed_in[s], the last round in which
  // its state changed.
  std::unordered_map<std::uint32_t, std::uint32_t> slot_of_label;
  std::vector<std::uint32_t> label_of, parent, unit_slot(units.size());
  std::vector<LabelState*> state;
  slot_of_label.reserve(units.size());
  label_of.reserve(units.size());
  parent.reserve(units.size());
  state.reserve(units.size());
  for (std::size_t u = 0; u < units.size(); ++u) {
    const std::uint32_t label = union_find.find(units[u].label);
    const auto [it, added] = slot_of_label.try_emplace(label, static_cast<std::uint32_t>(label_of.size()));
    if (added) {
      label_of.push_back(label);
      parent.push_back(it->second);
      state.push_back(&labels.at(label));
    }
    unit_slot[u] = it->second;
  }
  auto root_of = [&](std::uint32_t s) {
    while (parent[s] != s) s = parent[s] = parent[parent[s]];  // path halving
    return s;
  };
  std::vector<int> changed_in(label_of.size(), -1);
  for (int round = 0; round < 64; ++round) {
    candidates.clear();
    for (std::size_t e = 0; e < edges.size(); ++e) {
      const auto& edge = edges[e];
      const std::uint32_t sa = root_of(unit_slot[edge.a]), sb = root_of(unit_slot[edge.b]);
      if (sa == sb) continue;
      // After round 0 only edges touching a label changed in the round before can be in range:
      // an edge whose two labels kept their state was evaluated on that same state, and was
      // out of range then (one in range was merged when visited, its labels being unchanged).
      if (round > 0 && changed_in[sa] != round - 1 && changed_in[sb] != round - 1) continue;
      const auto ev = evaluate(units[edge.a], *state[sa], units[edge.b], *state[sb], edge.boundary_m);
      if (ev.in_range) candidates.push_back({ev.gain, e});
    }
    if (candidates.empty()) break;
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const Candidate& x, const Candidate& y) { return x.gain > y.gain; });
    bool merged_any = false;
    for (const auto& cand : candidates) {
      const auto& edge = edges[cand.edge];
      const std::uint32_t sa = root_of(unit_slot[edge.a]), sb = root_of(unit_slot[edge.b]);
      if (sa == sb) continue;
      // Planes may have moved since the round started: re-check the variation range (unless
      // neither label changed since the round's evaluation, which then still holds).
      if ((changed_in[sa] == round || changed_in[sb] == round) &&
          !evaluate_range(units[edge.a], *state[sa], units[edge.b], *state[sb]).in_range)
        continue;
      const bool a_is_root = label_of[sa] < label_of[sb];
      const std::uint32_t root = a_is_root ? sa : sb, absorbed = a_is_root ? sb : sa;
      parent[absorbed] = root;
      union_find.unite(label_of[sa], label_of[sb]);  // the caller's view of the same merge
      changed_in[root] = round;
      fold_label(*state[root], *state[absorbed]);
      labels.erase(label_of[absorbed]);
      merges.emplace_back(label_of[absorbed], label_of[root]);
      merged_any = true;
    }
    if (!merged_any) break;
  }
  return merges;
}

}  // namespace planecell::map
