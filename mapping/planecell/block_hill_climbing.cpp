/// Block-level hill climbing in the SEEDS hierarchy (paper §4.5): boundary blocks of size
/// ⌊√(|I|/|S|)⌋/l move to a horizontal or vertical neighbour segment when c1 − c2 improves,
/// coarse to fine down to single pixels; segments are kept connected.
#include <algorithm>
#include <array>
#include <cmath>

#include "mapping/planecell/superpixel_state.hpp"

namespace planecell::extraction::detail {
namespace {

/// True when removing the centre of a 3×3 neighbourhood from segment `label` keeps the segment's
/// pixels in that neighbourhood 4-connected. `ring` lists the 8 neighbours clockwise from the
/// top-left (NW, N, NE, E, SE, S, SW, W). Consecutive ring entries are 4-adjacent, so the
/// neighbours of `label` form as many local components as there are circular runs that contain
/// an edge neighbour (N, E, S, W).
bool keeps_connected(const std::array<int, 8>& ring, int label) {
  int first_gap = -1;
  for (int k = 0; k < 8; ++k)
    if (ring[k] != label) {
      first_gap = k;
      break;
    }
  if (first_gap < 0) return true;  // surrounded by its own segment (interior)
  int runs_with_edge = 0;
  bool in_run = false, run_has_edge = false;
  for (int step = 1; step <= 8; ++step) {
    const int k = (first_gap + step) % 8;
    if (ring[k] == label) {
      if (!in_run) {
        in_run = true;
        run_has_edge = false;
      }
      if (k % 2 == 1) run_has_edge = true;
    } else if (in_run) {
      in_run = false;
      if (run_has_edge) ++runs_with_edge;
    }
  }
  if (in_run && run_has_edge) ++runs_with_edge;
  return runs_with_edge <= 1;
}

/// Label of every b×b tile when all its pixels share one, else −1.
std::vector<int> tile_labels(const SuperpixelState& s, int b, int tiles_x, int tiles_y) {
  std::vector<int> out(static_cast<std::size_t>(tiles_x) * tiles_y);
  for (int ty = 0; ty < tiles_y; ++ty) {
    for (int tx = 0; tx < tiles_x; ++tx) {
      const int u0 = tx * b, v0 = ty * b;
      const int u1 = std::min(u0 + b, s.width), v1 = std::min(v0 + b, s.height);
      const int l = s.labels[s.index(u0, v0)];
      bool same = true;
      for (int v = v0; v < v1 && same; ++v) {
        const std::int32_t* row = s.labels.data() + v * s.width;
        for (int u = u0; u < u1; ++u)
          if (row[u] != l) {
            same = false;
            break;
          }
      }
      out[ty * tiles_x + tx] = same ? l : -1;
    }
  }
  return out;
}

/// Histogram, centre and mean disparity of the pixel rectangle [u0,u1)×[v0,v1).
void gather_block(const SuperpixelState& s, int u0, int v0, int u1, int v1,
                  std::array<std::uint16_t, kEnergyBins>& scratch, BlockData& b) {
  b.distinct_bins = 0;
  for (int v = v0; v < v1; ++v) {
    const std::uint8_t* row = s.bins.data() + v * s.width;
    for (int u = u0; u < u1; ++u) {
      const std::uint8_t q = row[u];
      if (scratch[q]++ == 0) b.bin_ids[b.distinct_bins++] = q;
    }
  }
  for (int k = 0; k < b.distinct_bins; ++k) {
    b.bin_counts[k] = scratch[b.bin_ids[k]];
    scratch[b.bin_ids[k]] = 0;
  }
  b.pixels = (u1 - u0) * (v1 - v0);
  b.centre_u = 0.5 * (u0 + u1 - 1);
  b.centre_v = 0.5 * (v0 + v1 - 1);
  int valid = 0;
  b.mean_disparity = s.mean_disparity(u0, v0, u1, v1, &valid);
  b.has_disparity = 2 * valid >= b.pixels;  // d̄_b only when half of the block is matched
}


/// The label the block should carry: its own, or the distinct 4-neighbour label whose block score
/// (E's change when the block joins it, see block_score) is strictly the highest. Ties keep the
/// current label, so a move always increases E.
int best_neighbour_label(const SuperpixelState& s, int label, const std::array<int, 4>& neighbours,
                         const BlockData& block) {
  double best = block_score(s, label, block);
  int best_label = label;
  for (int k = 0; k < 4; ++k) {
    const int nl = neighbours[k];
    if (nl < 0 || nl == label) continue;
    bool seen = false;
    for (int j = 0; j < k; ++j) seen |= (neighbours[j] == nl);
    if (seen) continue;
    const double score = block_score(s, nl, block);
    if (score > best + 1e-12) {
      best = score;
      best_label = nl;
    }
  }
  return best_label;
}

/// One sweep of b×b blocks (b ≥ 2) over the tile grid; returns the number of moves.
int block_sweep(SuperpixelState& s, int b, std::vector<int>& tiles, int tiles_x, int tiles_y,
                bool backwards) {
  std::array<std::uint16_t, kEnergyBins> scratch{};
  BlockData block;
  int moves = 0;
  auto tile_at = [&](int tx, int ty) {
    if (tx < 0 || ty < 0 || tx >= tiles_x || ty >= tiles_y) return -2;
    return tiles[ty * tiles_x + tx];
  };
  const int n = tiles_x * tiles_y;
  for (int step = 0; step < n; ++step) {
    const int t = backwards ? n - 1 - step : step;
    const int tx = t % tiles_x, ty = t / tiles_x;
    const int label = tiles[t];
    if (label < 0) continue;
    const std::array<int, 4> neighbours = {tile_at(tx - 1, ty), tile_at(tx + 1, ty),
                                           tile_at(tx, ty - 1), tile_at(tx, ty + 1)};
    bool boundary = false;
    for (int nl : neighbours) boundary |= (nl >= 0 && nl != label);
    if (!boundary) continue;
    const int u0 = tx * b, v0 = ty * b;
    const int u1 = std::min(u0 + b, s.width), v1 = std::min(v0 + b, s.height);
    const int pixels = (u1 - u0) * (v1 - v0);
    if (s.size[label] - pixels < pixels) continue;  // never empty a segment
    const std::array<int, 8> ring = {tile_at(tx - 1, ty - 1), tile_at(tx, ty - 1),
                                     tile_at(tx + 1, ty - 1), tile_at(tx + 1, ty),
                                     tile_at(tx + 1, ty + 1), tile_at(tx, ty + 1),
                                     tile_at(tx - 1, ty + 1), tile_at(tx - 1, ty)};
    if (!keeps_connected(ring, label)) continue;
    gather_block(s, u0, v0, u1, v1, scratch, block);
    const int best_label = best_neighbour_label(s, label, neighbours, block);
    if (best_label != label) {
      move_block(s, u0, v0, u1, v1, label, best_label);
      tiles[t] = best_label;
      ++moves;
    }
  }
  return moves;
}

/// One sweep of single boundary pixels; returns the number of moves.
int pixel_sweep(SuperpixelState& s, bool backwards) {
  const int w = s.width, h = s.height;
  const std::int32_t* lab = s.labels.data();
  auto at = [&](int u, int v) { return (u < 0 || v < 0 || u >= w || v >= h) ? -2 : lab[v * w + u]; };
  BlockData px;
  px.distinct_bins = 1;
  px.bin_counts[0] = 1;
  px.pixels = 1;
  int moves = 0;
  for (int row = 0; row < h; ++row) {
    const int v = backwards ? h - 1 - row : row;
    const bool interior_row = v > 0 && v + 1 < h;
    for (int col = 0; col < w; ++col) {
      const int u = backwards ? w - 1 - col : col;
      const int i = v * w + u;
      const int label = lab[i];
      // Fast rejection of interior pixels (the vast majority).
      if (interior_row && u > 0 && u + 1 < w && lab[i - 1] == label && lab[i + 1] == label &&
          lab[i - w] == label && lab[i + w] == label)
        continue;
      const std::array<int, 4> neighbours = {at(u - 1, v), at(u + 1, v), at(u, v - 1),
                                             at(u, v + 1)};
      bool boundary = false;
      for (int nl : neighbours) boundary |= (nl >= 0 && nl != label);
      if (!boundary || s.size[label] <= 1) continue;
      const std::array<int, 8> ring = {at(u - 1, v - 1), neighbours[2], at(u + 1, v - 1),
                                       neighbours[1],    at(u + 1, v + 1), neighbours[3],
                                       at(u - 1, v + 1), neighbours[0]};
      if (!keeps_connected(ring, label)) continue;
      px.bin_ids[0] = s.bins[i];
      px.centre_u = u;
      px.centre_v = v;
      const float d = s.disparity[i];
      px.has_disparity = !std::isnan(d);
      px.mean_disparity = px.has_disparity ? d : 0.0;
      const int best_label = best_neighbour_label(s, label, neighbours, px);
      if (best_label != label) {
        move_block(s, u, v, u + 1, v + 1, label, best_label);
        ++moves;
      }
    }
  }
  return moves;
}

}  // namespace

void hill_climb(SuperpixelState& s, int block_levels, int first_level, int iterations,
                int pixel_iterations, const Deadline& deadline) {
  for (int level = std::max(1, first_level); level <= block_levels; ++level) {
    const int b = block_size(s.cell_size_px, block_levels, level);  // ≈ ⌊s / l⌋, l = 2^level
    if (b < 2) break;
    const int tiles_x = (s.width + b - 1) / b, tiles_y = (s.height + b - 1) / b;
    std::vector<int> tiles = tile_labels(s, b, tiles_x, tiles_y);
    for (int it = 0; it < iterations; ++it) {
      if (deadline.passed()) return;
      if (block_sweep(s, b, tiles, tiles_x, tiles_y, it % 2 == 1) == 0) break;
    }
  }
  for (int it = 0; it < pixel_iterations; ++it) {
    if (deadline.passed()) return;
    if (pixel_sweep(s, it % 2 == 1) == 0) break;
  }
}

void enforce_connectivity(SuperpixelState& s) {
  const int w = s.width, h = s.height, n = w * h;
  std::vector<std::int32_t> component(n, -1);
  std::vector<std::int32_t> order;  // pixels grouped by component (BFS order)
  order.reserve(n);
  std::vector<std::int32_t> comp_start, comp_label;
  for (int seed = 0; seed < n; ++seed) {
    if (component[seed] >= 0) continue;
    const int c = static_cast<int>(comp_start.size());
    const int label = s.labels[seed];
    comp_start.push_back(static_cast<std::int32_t>(order.size()));
    comp_label.push_back(label);
    component[seed] = c;
    order.push_back(seed);
    for (std::size_t head = comp_start.back(); head < order.size(); ++head) {
      const int i = order[head];
      const int u = i % w, v = i / w;
      auto visit = [&](int j) {
        if (component[j] < 0 && s.labels[j] == label) {
          component[j] = c;
          order.push_back(j);
        }
      };
      if (u > 0) visit(i - 1);
      if (u + 1 < w) visit(i + 1);
      if (v > 0) visit(i - w);
      if (v + 1 < h) visit(i + w);
    }
  }
  const int n_comp = static_cast<int>(comp_start.size());
  comp_start.push_back(n);
  // Largest component of each label stays; the others join a neighbouring segment.
  std::vector<std::int32_t> keeper(s.num_segments, -1);
  for (int c = 0; c < n_comp; ++c) {
    const int l = comp_label[c];
    const int size = comp_start[c + 1] - comp_start[c];
    if (keeper[l] < 0 || size > comp_start[keeper[l] + 1] - comp_start[keeper[l]]) keeper[l] = c;
  }
  for (int c = 0; c < n_comp; ++c) {
    if (keeper[comp_label[c]] == c) continue;
    int target = -1;
    for (int k = comp_start[c]; k < comp_start[c + 1] && target < 0; ++k) {
      const int i = order[k];
      const int u = i % w, v = i / w;
      const int candidates[4] = {u > 0 ? i - 1 : -1, u + 1 < w ? i + 1 : -1,
                                 v > 0 ? i - w : -1, v + 1 < h ? i + w : -1};
      for (int j : candidates)
        if (j >= 0 && component[j] != c && keeper[s.labels[j]] == component[j]) {
          target = s.labels[j];
          break;
        }
    }
    if (target < 0) {  // only touches other orphans: take any different neighbour
      for (int k = comp_start[c]; k < comp_start[c + 1] && target < 0; ++k) {
        const int i = order[k];
        if (i % w > 0 && component[i - 1] != c) target = s.labels[i - 1];
        else if (i >= w && component[i - w] != c) target = s.labels[i - w];
      }
    }
    if (target < 0) continue;
    for (int k = comp_start[c]; k < comp_start[c + 1]; ++k) {
      s.labels[order[k]] = target;
      component[order[k]] = keeper[target];
    }
  }
  // Renumber without gaps, carrying planes along.
  std::vector<std::int32_t> remap(s.num_segments, -1);
  std::vector<DisparityPlane> planes;
  std::vector<std::uint8_t> has_plane;
  int next = 0;
  for (int i = 0; i < n; ++i) {
    const int l = s.labels[i];
    if (remap[l] < 0) {
      remap[l] = next++;
      planes.push_back(s.planes[l]);
      has_plane.push_back(s.has_plane[l]);
    }
    s.labels[i] = remap[l];
  }
  s.num_segments = next;
  s.planes = std::move(planes);
  s.has_plane = std::move(has_plane);
  recompute_statistics(s);
}

SegmentPixels group_pixels(const SuperpixelState& s) {
  SegmentPixels g;
  g.offsets.assign(s.num_segments + 1, 0);
  for (std::int32_t l : s.labels) ++g.offsets[l + 1];
  for (int k = 0; k < s.num_segments; ++k) g.offsets[k + 1] += g.offsets[k];
  g.pixels.resize(s.labels.size());
  std::vector<std::int32_t> cursor(g.offsets.begin(), g.offsets.end() - 1);
  for (std::size_t i = 0; i < s.labels.size(); ++i)
    g.pixels[cursor[s.labels[i]]++] = static_cast<std::int32_t>(i);
  return g;
}

}  // namespace planecell::extraction::detail
