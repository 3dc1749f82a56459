/// Connected, gap-free segments after the hill climbing: 4-connected components of the label
/// image found on horizontal runs with a union–find (no per-pixel flood fill), orphan pieces
/// joined to a neighbouring segment, labels renumbered in raster order.
#include <algorithm>
#include <vector>

#include "mapping/planecell/superpixel_state.hpp"

namespace planecell::extraction::detail {
namespace {

/// Maximal horizontal runs of one label, row by row (raster order).
struct LabelRuns {
  std::vector<std::int32_t> u0, u1;     ///< columns [u0, u1) of each run
  std::vector<std::int32_t> label;      ///< label of each run
  std::vector<std::int32_t> row;        ///< row v of each run
  std::vector<std::int32_t> row_begin;  ///< runs of row v: [row_begin[v], row_begin[v + 1])
};

LabelRuns find_runs(const SuperpixelState& s) {
  LabelRuns r;
  r.row_begin.reserve(s.height + 1);
  const std::size_t expected = static_cast<std::size_t>(s.height) * (s.width / 8 + 2);
  r.u0.reserve(expected);
  r.u1.reserve(expected);
  r.label.reserve(expected);
  r.row.reserve(expected);
  for (int v = 0; v < s.height; ++v) {
    r.row_begin.push_back(static_cast<std::int32_t>(r.u0.size()));
    const std::int32_t* row = s.labels.data() + static_cast<std::size_t>(v) * s.width;
    int u = 0;
    while (u < s.width) {
      const int start = u;
      const std::int32_t l = row[u];
      while (u < s.width && row[u] == l) ++u;
      r.u0.push_back(start);
      r.u1.push_back(u);
      r.label.push_back(l);
      r.row.push_back(v);
    }
  }
  r.row_begin.push_back(static_cast<std::int32_t>(r.u0.size()));
  return r;
}

/// Union–find over runs whose root is always the smallest run index of the set, i.e. the
/// component's first run in raster order.
struct RunForest {
  std::vector<std::int32_t> parent;
  explicit RunForest(std::size_t n) : parent(n) {
    for (std::size_t k = 0; k < n; ++k) parent[k] = static_cast<std::int32_t>(k);
  }
  int find(int k) {
    while (parent[k] != k) {
      parent[k] = parent[parent[k]];  // path halving
      k = parent[k];
    }
    return k;
  }
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

/// Joins every run to the overlapping runs of the same label in the row above (4-connectivity).
void join_vertical_neighbours(const LabelRuns& r, int height, RunForest& forest) {
  for (int v = 1; v < height; ++v) {
    int a = r.row_begin[v - 1];
    const int a_end = r.row_begin[v];
    int b = r.row_begin[v];
    const int b_end = r.row_begin[v + 1];
    while (a < a_end && b < b_end) {
      if (r.label[a] == r.label[b] && r.u0[a] < r.u1[b] && r.u0[b] < r.u1[a]) forest.unite(a, b);
      if (r.u1[a] < r.u1[b])
        ++a;
      else if (r.u1[b] < r.u1[a])
        ++b;
      else {
        ++a;
        ++b;
      }
    }
  }
}

/// The run holding pixel (u, v).
int run_at(const LabelRuns& r, int u, int v) {
  const auto first = r.u0.begin() + r.row_begin[v];
  const auto last = r.u0.begin() + r.row_begin[v + 1];
  return static_cast<int>(std::upper_bound(first, last, u) - r.u0.begin()) - 1;
}

/// Moves pixel i (labelled `from`) to segment `to`, updating the segment statistics.
void relabel_pixel(SuperpixelState& s, int i, int to) {
  const int from = s.labels[i];
  move_pixel(s, i % s.width, i / s.width, from, to);
}

/// Joins the orphan component `c` (a root run, not the largest piece of its label) to a
/// neighbouring segment: the first keeper-owned 4-neighbour met in breadth-first order from the
/// component's first pixel, else (it only touches other orphans) the first pixel's left or upper
/// neighbour of another component. Orphans that join a segment count as part of its keeper.
void join_orphan(SuperpixelState& s, const LabelRuns& r, RunForest& forest,
                 const std::vector<std::int32_t>& keeper, int c, std::vector<std::uint8_t>& seen,
                 std::vector<std::int32_t>& order) {
  const int w = s.width, h = s.height;
  auto component_of = [&](int i) { return forest.find(run_at(r, i % w, i / w)); };
  // Breadth-first order of the component's pixels (neighbours: left, right, up, down).
  order.clear();
  const int first = r.row[c] * w + r.u0[c];
  order.push_back(first);
  seen[first] = 1;
  for (std::size_t head = 0; head < order.size(); ++head) {
    const int i = order[head];
    const int u = i % w, v = i / w;
    auto visit = [&](int j) {
      if (!seen[j] && component_of(j) == c) {
        seen[j] = 1;
        order.push_back(j);
      }
    };
    if (u > 0) visit(i - 1);
    if (u + 1 < w) visit(i + 1);
    if (v > 0) visit(i - w);
    if (v + 1 < h) visit(i + w);
  }
  int target = -1;
  for (std::size_t k = 0; k < order.size() && target < 0; ++k) {
    const int i = order[k];
    const int u = i % w, v = i / w;
    const int candidates[4] = {u > 0 ? i - 1 : -1, u + 1 < w ? i + 1 : -1, v > 0 ? i - w : -1,
                               v + 1 < h ? i + w : -1};
    for (int j : candidates) {
      if (j < 0) continue;
      const int cj = component_of(j);
      if (cj != c && keeper[s.labels[j]] == cj) {
        target = s.labels[j];
        break;
      }
    }
  }
  for (std::size_t k = 0; k < order.size() && target < 0; ++k) {
    const int i = order[k];
    if (i % w > 0 && component_of(i - 1) != c)
      target = s.labels[i - 1];
    else if (i >= w && component_of(i - w) != c)
      target = s.labels[i - w];
  }
  if (target < 0) return;
  for (const int i : order) relabel_pixel(s, i, target);
  forest.parent[c] = keeper[target];  // keepers stay roots
}

/// Renumbers the labels 0..n−1 in raster order of their first pixel, carrying planes and
/// statistics along.
void renumber_segments(SuperpixelState& s, const LabelRuns& r) {
  std::vector<std::int32_t> remap(s.num_segments, -1);
  std::vector<std::int32_t> old_of;  // new → old
  old_of.reserve(s.num_segments);
  for (std::size_t k = 0; k < r.u0.size(); ++k) {
    const int l = s.labels[static_cast<std::size_t>(r.row[k]) * s.width + r.u0[k]];  // current
    if (remap[l] < 0) {
      remap[l] = static_cast<std::int32_t>(old_of.size());
      old_of.push_back(l);
    }
  }
  const int n = static_cast<int>(old_of.size());
  bool identity = n == s.num_segments;
  for (int k = 0; k < n && identity; ++k) identity = old_of[k] == k;
  if (identity) return;
  for (auto& l : s.labels) l = remap[l];
  auto permute = [&](auto& values, std::size_t per_segment) {
    std::remove_reference_t<decltype(values)> out(static_cast<std::size_t>(n) * per_segment);
    for (int k = 0; k < n; ++k)
      std::copy_n(values.begin() + static_cast<std::size_t>(old_of[k]) * per_segment, per_segment,
                  out.begin() + static_cast<std::size_t>(k) * per_segment);
    values = std::move(out);
  };
  permute(s.histogram, kEnergyBins);
  permute(s.size, 1);
  permute(s.sum_u, 1);
  permute(s.sum_v, 1);
  permute(s.centre, 1);
  permute(s.planes, 1);
  permute(s.has_plane, 1);
  s.num_segments = n;
}

}  // namespace

void enforce_connectivity(SuperpixelState& s) {
  const LabelRuns runs = find_runs(s);
  const int n_runs = static_cast<int>(runs.u0.size());
  RunForest forest(n_runs);
  join_vertical_neighbours(runs, s.height, forest);
  // Component sizes; roots in increasing order are the components in raster order of their
  // first pixel. The largest component of each label (the first on ties) keeps it.
  std::vector<std::int32_t> component_size(n_runs, 0);
  for (int k = 0; k < n_runs; ++k) component_size[forest.find(k)] += runs.u1[k] - runs.u0[k];
  std::vector<std::int32_t> keeper(s.num_segments, -1);
  std::vector<std::int32_t> orphans;
  for (int k = 0; k < n_runs; ++k) {
    if (forest.parent[k] != k) continue;
    std::int32_t& kept = keeper[runs.label[k]];
    if (kept < 0 || component_size[k] > component_size[kept]) kept = k;
  }
  for (int k = 0; k < n_runs; ++k)
    if (forest.parent[k] == k && keeper[runs.label[k]] != k) orphans.push_back(k);
  if (!orphans.empty()) {
    std::vector<std::uint8_t> seen(s.labels.size(), 0);
    std::vector<std::int32_t> order;
    for (const int c : orphans) join_orphan(s, runs, forest, keeper, c, seen, order);
  }
  renumber_segments(s, runs);
}

}  // namespace planecell::extraction::detail
