/// 2D→3D conversion of planecells and the dense disparity rendered from their planes.
#include "mapping/planecell/conversion_3d.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.hpp"

namespace planecell::extraction {

void convert_to_3d(Planecell& cell, const StereoCamera& camera) {
  cell.vertices_m.clear();
  if (!cell.has_plane) return;
  cell.plane = plane_from_disparity(cell.disparity_plane, camera);
  cell.vertices_m.reserve(cell.vertices_px.size());
  for (const auto& p : cell.vertices_px) {
    const double d = std::max(kMinVertexDisparityPx, cell.disparity_plane.at(p.x(), p.y()));
    cell.vertices_m.push_back(camera.back_project(p.x(), p.y(), d).cast<float>());
  }
}

namespace {

/// Throws InputError unless every label indexes `cells`.
void check_labels(const cv::Mat& labels, int n) {
  for (int v = 0; v < labels.rows; ++v) {
    const auto* row = labels.ptr<std::int32_t>(v);
    std::int32_t lo = row[0], hi = row[0];
    for (int u = 1; u < labels.cols; ++u) {  // branch-free: vectorises
      lo = std::min(lo, row[u]);
      hi = std::max(hi, row[u]);
    }
    if (lo < 0 || hi >= n)
      throw InputError("render_dense_disparity: label " + std::to_string(lo < 0 ? lo : hi) +
                       " in row " + std::to_string(v) + " outside [0, " + std::to_string(n) + ")");
  }
}

/// For every planeless cell, the plane of its farther neighbour (smallest disparity at the
/// cell's centre) that has one, propagated a few rings inwards (see render_dense_disparity).
/// `source` holds k for cells with a plane and −1 otherwise on entry.
void borrow_neighbour_planes(const cv::Mat& labels, const std::vector<Planecell>& cells,
                             std::vector<int>& source) {
  const int n = static_cast<int>(cells.size());
  const int w = labels.cols, h = labels.rows;
  std::vector<std::uint8_t> planeless(n);
  for (int k = 0; k < n; ++k) planeless[k] = !cells[k].has_plane;
  // Centre and bounding box [u_min, u_max] × [v_min, v_max] of every planeless cell.
  std::vector<double> centre_u(n, 0.0), centre_v(n, 0.0);
  std::vector<int> area(n, 0);
  std::vector<std::array<int, 4>> box(n, {w, h, -1, -1});
  for (int v = 0; v < h; ++v) {
    const auto* row = labels.ptr<std::int32_t>(v);
    for (int u = 0; u < w; ++u) {
      const int l = row[u];
      if (!planeless[l]) continue;
      centre_u[l] += u;
      centre_v[l] += v;
      ++area[l];
      auto& b = box[l];
      b = {std::min(b[0], u), std::min(b[1], v), std::max(b[2], u), std::max(b[3], v)};
    }
  }
  // Neighbours of each planeless cell k in raster order of contact: pixel p of k or next to it
  // meets its right neighbour, then its lower neighbour. Only k's box, grown by one pixel to the
  // left and up, can hold such contacts.
  std::vector<std::vector<int>> neighbours(n);
  for (int k = 0; k < n; ++k) {
    if (area[k] == 0) continue;
    auto add = [&](int j) {
      if (std::find(neighbours[k].begin(), neighbours[k].end(), j) == neighbours[k].end())
        neighbours[k].push_back(j);
    };
    const auto& b = box[k];
    for (int v = std::max(0, b[1] - 1); v <= b[3]; ++v) {
      const auto* row = labels.ptr<std::int32_t>(v);
      const auto* below = v + 1 < h ? labels.ptr<std::int32_t>(v + 1) : nullptr;
      for (int u = std::max(0, b[0] - 1); u <= b[2]; ++u) {
        const int l = row[u];
        if (u + 1 < w && row[u + 1] != l) {
          if (l == k)
            add(row[u + 1]);
          else if (row[u + 1] == k)
            add(l);
        }
        if (below && below[u] != l) {
          if (l == k)
            add(below[u]);
          else if (below[u] == k)
            add(l);
        }
      }
    }
  }
  for (int round = 0; round < 4; ++round) {
    std::vector<int> next = source;
    bool changed = false;
    for (int k = 0; k < n; ++k) {
      if (source[k] >= 0 || area[k] == 0) continue;
      const double cu = centre_u[k] / area[k], cv = centre_v[k] / area[k];
      double farthest = std::numeric_limits<double>::infinity();
      for (int j : neighbours[k]) {
        if (source[j] < 0) continue;
        const double d = cells[source[j]].disparity_plane.at(cu, cv);
        if (d < farthest) {
          farthest = d;
          next[k] = source[j];
        }
      }
      changed |= next[k] >= 0;
    }
    source = std::move(next);
    if (!changed) break;
  }
}

}  // namespace

cv::Mat render_dense_disparity(const cv::Mat& labels, const std::vector<Planecell>& cells,
                               bool fill_planeless) {
  if (labels.empty() || labels.type() != CV_32SC1)
    throw InputError("render_dense_disparity: labels must be a non-empty CV_32S image");
  const int n = static_cast<int>(cells.size());
  const int w = labels.cols, h = labels.rows;
  check_labels(labels, n);
  // The plane used for each cell: its own, or (fill_planeless) the farther neighbour's.
  std::vector<int> source(n, -1);
  bool all_planes = true;
  for (int k = 0; k < n; ++k) {
    if (cells[k].has_plane) source[k] = k;
    all_planes &= cells[k].has_plane;
  }
  if (fill_planeless && !all_planes) borrow_neighbour_planes(labels, cells, source);
  cv::Mat dense(h, w, CV_32F);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < h; ++v) {
    const auto* row = labels.ptr<std::int32_t>(v);
    float* out = dense.ptr<float>(v);
    int u = 0;
    while (u < w) {  // one run of equal labels at a time
      const int l = row[u];
      const int s = source[l];
      if (s < 0) {
        for (; u < w && row[u] == l; ++u) out[u] = nan;
        continue;
      }
      const DisparityPlane plane = cells[s].disparity_plane;
      for (; u < w && row[u] == l; ++u) out[u] = static_cast<float>(std::max(0.0, plane.at(u, v)));
    }
  }
  return dense;
}

}  // namespace planecell::extraction

namespace planecell::extraction {

void prefer_background_in_holes(cv::Mat& dense, const cv::Mat& input, const cv::Mat& labels,
                                const std::vector<Planecell>& cells) {
  if (dense.size() != input.size() || dense.size() != labels.size() || dense.type() != CV_32F ||
      input.type() != CV_32F || labels.type() != CV_32S)
    throw InputError("prefer_background_in_holes: dense/input/labels sizes or types differ");
  const int w = dense.cols;
  for (int v = 0; v < dense.rows; ++v) {
    const float* in = input.ptr<float>(v);
    const auto* lab = labels.ptr<std::int32_t>(v);
    float* out = dense.ptr<float>(v);
    int u = 0;
    while (u < w) {
      if (!std::isnan(in[u])) {
        ++u;
        continue;
      }
      const int u0 = u;
      while (u < w && std::isnan(in[u])) ++u;
      const int left = u0 > 0 ? lab[u0 - 1] : -1;
      const int right = u < w ? lab[u] : -1;
      if (left == right) continue;  // inside one cell: its own plane is the best guess
      for (int x = u0; x < u; ++x) {
        float best = out[x];
        for (int c : {left, right}) {
          if (c < 0 || !cells[c].has_plane) continue;
          const float d = static_cast<float>(std::max(0.0, cells[c].disparity_plane.at(x, v)));
          if (std::isnan(best) || d < best) best = d;
        }
        out[x] = best;
      }
    }
  }
}

}  // namespace planecell::extraction
