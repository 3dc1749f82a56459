/// 2D→3D conversion of planecells and the dense disparity rendered from their planes.
#include "mapping/planecell/conversion_3d.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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

cv::Mat render_dense_disparity(const cv::Mat& labels, const std::vector<Planecell>& cells,
                               bool fill_planeless) {
  if (labels.empty() || labels.type() != CV_32SC1)
    throw InputError("render_dense_disparity: labels must be a non-empty CV_32S image");
  const int n = static_cast<int>(cells.size());
  const int w = labels.cols, h = labels.rows;
  // The plane used for each cell: its own, or (fill_planeless) the farther neighbour's.
  std::vector<int> source(n, -1);
  for (int k = 0; k < n; ++k)
    if (cells[k].has_plane) source[k] = k;
  if (fill_planeless) {
    std::vector<double> centre_u(n, 0.0), centre_v(n, 0.0);
    std::vector<int> area(n, 0);
    std::vector<std::vector<int>> neighbours(n);
    auto link = [&](int a, int b) {
      if (a == b) return;
      if (!cells[a].has_plane && std::find(neighbours[a].begin(), neighbours[a].end(), b) ==
                                     neighbours[a].end())
        neighbours[a].push_back(b);
      if (!cells[b].has_plane && std::find(neighbours[b].begin(), neighbours[b].end(), a) ==
                                     neighbours[b].end())
        neighbours[b].push_back(a);
    };
    for (int v = 0; v < h; ++v) {
      const auto* row = labels.ptr<std::int32_t>(v);
      const auto* below = v + 1 < h ? labels.ptr<std::int32_t>(v + 1) : nullptr;
      for (int u = 0; u < w; ++u) {
        const int l = row[u];
        if (l < 0 || l >= n) throw InputError("render_dense_disparity: label out of range");
        if (!cells[l].has_plane) {
          centre_u[l] += u;
          centre_v[l] += v;
          ++area[l];
        }
        if (u + 1 < w) link(l, row[u + 1]);
        if (below) link(l, below[u]);
      }
    }
    // Propagate a few rings inwards so that clusters of planeless cells are filled as well.
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
  cv::Mat dense(h, w, CV_32F);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < h; ++v) {
    const auto* row = labels.ptr<std::int32_t>(v);
    float* out = dense.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      const int l = row[u];
      if (l < 0 || l >= n) throw InputError("render_dense_disparity: label out of range");
      const int s = source[l];
      out[u] = s < 0 ? nan
                     : static_cast<float>(std::max(0.0, cells[s].disparity_plane.at(u, v)));
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
