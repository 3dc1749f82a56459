/// Block-level hill climbing in the SEEDS hierarchy (paper §4.5): boundary blocks of size
/// ⌊√(|I|/|S|)⌋/l move to a horizontal or vertical neighbour segment when c1 − c2 improves,
/// coarse to fine down to single pixels; segments are kept connected.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>

#include "mapping/planecell/superpixel_state.hpp"

namespace planecell::extraction::detail {
namespace {

/// The 8 neighbours of a pixel or tile, clockwise from the top-left: NW, N, NE, E, SE, S, SW, W.
/// A ring mask has bit k set when neighbour k carries the centre's label.
constexpr int kRingSize = 8;

/// True when removing the centre of a 3×3 neighbourhood from its segment keeps the segment's
/// pixels in that neighbourhood 4-connected, for the ring mask `mask`. Consecutive ring entries
/// are 4-adjacent, so the segment's neighbours form as many local components as there are
/// circular runs of set bits that contain an edge neighbour (N, E, S, W = odd bits); the centre
/// may leave when there is at most one such run.
constexpr bool ring_keeps_connected(unsigned mask) {
  if (mask == 0xFFu) return true;  // surrounded by its own segment (interior)
  int first_gap = 0;
  while (mask & (1u << first_gap)) ++first_gap;
  int runs_with_edge = 0;
  bool in_run = false, run_has_edge = false;
  for (int step = 1; step <= kRingSize; ++step) {
    const int k = (first_gap + step) % kRingSize;
    if (mask & (1u << k)) {
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

/// ring_keeps_connected for all 256 ring masks (a lookup replaces the run count in the sweeps).
constexpr std::array<bool, 256> kRingKeepsConnected = [] {
  std::array<bool, 256> table{};
  for (unsigned m = 0; m < 256; ++m) table[m] = ring_keeps_connected(m);
  return table;
}();

/// Ring mask of `label` over the 8 neighbour labels (ring order, see kRingSize).
inline unsigned ring_mask(const std::array<int, kRingSize>& ring, int label) {
  unsigned mask = 0;
  for (int k = 0; k < kRingSize; ++k) mask |= static_cast<unsigned>(ring[k] == label) << k;
  return mask;
}

/// The tiles of one block level: the label of every b×b tile when all its pixels share one,
/// else −1, on a grid padded by one tile of −2 (outside the image) on each side, so that the 8
/// neighbours of every tile are plain offsets. Each tile's colour histogram is gathered on first
/// use and kept: a tile's pixels never change, only the segment they belong to.
struct TileGrid {
  int b = 0;
  int tiles_x = 0, tiles_y = 0;
  int stride = 0;  ///< tiles_x + 2
  std::vector<int> label;
  int index(int tx, int ty) const { return (ty + 1) * stride + tx + 1; }

  std::vector<std::int32_t> histogram_first;  ///< per tile t = ty·tiles_x + tx; −1 = not yet
  std::vector<std::uint8_t> histogram_size;   ///< distinct bins of each gathered tile
  std::vector<std::uint8_t> bin_ids;          ///< all gathered histograms, one after another
  std::vector<std::uint16_t> bin_counts;
};

/// Label of the tile [u0,u1)×[v0,v1) when all its pixels share one, else −1.
int uniform_label(const SuperpixelState& s, int u0, int v0, int u1, int v1) {
  const int l = s.labels[s.index(u0, v0)];
  int differs = 0;  // no early exit within a row: the comparisons vectorise
  for (int v = v0; v < v1 && differs == 0; ++v) {
    const std::int32_t* row = s.labels.data() + static_cast<std::size_t>(v) * s.width;
    for (int u = u0; u < u1; ++u) differs |= row[u] ^ l;
  }
  return differs == 0 ? l : -1;
}

/// Labels of all tiles read from the pixels, one row of tiles at a time: a tile is uniform when
/// none of its rows changes label inside it and each row starts with the label of the tile's
/// top-left pixel. The label changes along a row are flagged branch-free (vectorised) first.
void read_tile_labels(const SuperpixelState& s, TileGrid& g) {
  const int w = s.width, b = g.b;
  std::vector<std::uint8_t> change(w + 8, 0);  ///< 1 where the label differs from the left one
  std::vector<int> first(g.tiles_x);
  std::vector<std::uint8_t> mixed(g.tiles_x);
  for (int ty = 0; ty < g.tiles_y; ++ty) {
    const int v0 = ty * b, v1 = std::min(v0 + b, s.height);
    const std::int32_t* top = s.labels.data() + static_cast<std::size_t>(v0) * w;
    for (int tx = 0; tx < g.tiles_x; ++tx) {
      first[tx] = top[tx * b];
      mixed[tx] = 0;
    }
    for (int v = v0; v < v1; ++v) {
      const std::int32_t* row = s.labels.data() + static_cast<std::size_t>(v) * w;
      for (int u = 1; u < w; ++u) change[u] = static_cast<std::uint8_t>(row[u] != row[u - 1]);
      for (int tx = 0; tx < g.tiles_x; ++tx) {
        const int u0 = tx * b, u1 = std::min(u0 + b, w);
        bool any = row[u0] != first[tx];
        for (int u = u0 + 1; u < u1; u += 8) {  // eight change flags per 64-bit word
          std::uint64_t eight;
          std::memcpy(&eight, change.data() + u, 8);
          const int valid = u1 - u;
          if (valid < 8) eight &= (std::uint64_t{1} << (8 * valid)) - 1;
          any |= eight != 0;
        }
        mixed[tx] |= static_cast<std::uint8_t>(any);
      }
    }
    for (int tx = 0; tx < g.tiles_x; ++tx) g.label[g.index(tx, ty)] = mixed[tx] ? -1 : first[tx];
  }
}

/// The tiles of size b. With the grid of the level above (tiles of 2b, which nest four tiles of
/// size b each, and which block moves keep uniform), a tile inside a uniform parent takes its
/// label and only the tiles of mixed parents are read pixel by pixel.
TileGrid make_tile_grid(const SuperpixelState& s, int b, const TileGrid* parent) {
  TileGrid g;
  g.b = b;
  g.tiles_x = (s.width + b - 1) / b;
  g.tiles_y = (s.height + b - 1) / b;
  g.stride = g.tiles_x + 2;
  g.label.assign(static_cast<std::size_t>(g.stride) * (g.tiles_y + 2), -2);
  g.histogram_first.assign(static_cast<std::size_t>(g.tiles_x) * g.tiles_y, -1);
  g.histogram_size.assign(static_cast<std::size_t>(g.tiles_x) * g.tiles_y, 0);
  if (parent == nullptr || parent->b != 2 * b) {
    read_tile_labels(s, g);
    return g;
  }
  for (int ty = 0; ty < g.tiles_y; ++ty) {
    const int v0 = ty * b, v1 = std::min(v0 + b, s.height);
    for (int tx = 0; tx < g.tiles_x; ++tx) {
      const int inherited = parent->label[parent->index(tx / 2, ty / 2)];
      const int u0 = tx * b, u1 = std::min(u0 + b, s.width);
      g.label[g.index(tx, ty)] = inherited >= 0 ? inherited : uniform_label(s, u0, v0, u1, v1);
    }
  }
  return g;
}

/// Block b = tile t = [u0,u1)×[v0,v1) of the grid: its histogram (gathered into the grid on
/// first use), size and centre, and its mean valid disparity d̄_b when the depth term is on.
BlockData gather_block(const SuperpixelState& s, TileGrid& g, int t, int u0, int v0, int u1, int v1,
                       std::array<std::uint16_t, kEnergyBins>& scratch) {
  if (g.histogram_first[t] < 0) {
    const std::size_t first = g.bin_ids.size();
    for (int v = v0; v < v1; ++v) {
      const std::uint8_t* row = s.bins.data() + static_cast<std::size_t>(v) * s.width;
      for (int u = u0; u < u1; ++u) {
        const std::uint8_t q = row[u];
        if (scratch[q]++ == 0) g.bin_ids.push_back(q);
      }
    }
    for (std::size_t k = first; k < g.bin_ids.size(); ++k) {
      g.bin_counts.push_back(scratch[g.bin_ids[k]]);
      scratch[g.bin_ids[k]] = 0;
    }
    g.histogram_first[t] = static_cast<std::int32_t>(first);
    g.histogram_size[t] = static_cast<std::uint8_t>(g.bin_ids.size() - first);
  }
  BlockData b;
  b.bin_ids = g.bin_ids.data() + g.histogram_first[t];
  b.bin_counts = g.bin_counts.data() + g.histogram_first[t];
  b.distinct_bins = g.histogram_size[t];
  b.pixels = (u1 - u0) * (v1 - v0);
  b.centre_u = 0.5 * (u0 + u1 - 1);
  b.centre_v = 0.5 * (v0 + v1 - 1);
  if (!s.weights.depth_enabled) return b;
  double sum = 0.0;
  int valid = 0;
  for (int v = v0; v < v1; ++v) {
    const float* row = s.disparity.data() + static_cast<std::size_t>(v) * s.width;
    for (int u = u0; u < u1; ++u)
      if (!std::isnan(row[u])) {
        sum += row[u];
        ++valid;
      }
  }
  b.has_disparity = valid > 0 && 2 * valid >= b.pixels;  // d̄_b when half the block is matched
  b.mean_disparity = valid > 0 ? sum / valid : 0.0;
  return b;
}

/// The label the block should carry: its own, or the distinct 4-neighbour label (W, E, N, S;
/// negative = none) whose block score (E's change when the block joins it, see block_score) is
/// strictly the highest. Ties keep the current label, so a move always increases E. Inlined
/// into each sweep so that the score is too.
template <class Score>
[[gnu::always_inline]] inline int best_neighbour_label(int label,
                                                       const std::array<int, 4>& neighbours,
                                                       Score&& score) {
  double best = score(label);
  int best_label = label;
  auto consider = [&](int candidate) {
    const double value = score(candidate);
    if (value > best + 1e-12) {
      best = value;
      best_label = candidate;
    }
  };
  const int w = neighbours[0], e = neighbours[1], n = neighbours[2], s = neighbours[3];
  if (w >= 0 && w != label) consider(w);
  if (e >= 0 && e != label && e != w) consider(e);
  if (n >= 0 && n != label && n != w && n != e) consider(n);
  if (s >= 0 && s != label && s != w && s != e && s != n) consider(s);
  return best_label;
}

/// One sweep of b×b blocks (b ≥ 2) over the tile grid; returns the number of moves.
int block_sweep(SuperpixelState& s, TileGrid& g, bool backwards) {
  std::array<std::uint16_t, kEnergyBins> scratch{};
  int moves = 0;
  const int b = g.b, stride = g.stride;
  const int n = g.tiles_x * g.tiles_y;
  for (int step = 0; step < n; ++step) {
    const int t = backwards ? n - 1 - step : step;
    const int tx = t % g.tiles_x, ty = t / g.tiles_x;
    const int p = g.index(tx, ty);
    const int* tile = g.label.data() + p;
    const int label = tile[0];
    if (label < 0) continue;
    const std::array<int, 4> neighbours = {tile[-1], tile[1], tile[-stride], tile[stride]};
    bool boundary = false;
    for (int nl : neighbours) boundary |= (nl >= 0 && nl != label);
    if (!boundary) continue;
    const int u0 = tx * b, v0 = ty * b;
    const int u1 = std::min(u0 + b, s.width), v1 = std::min(v0 + b, s.height);
    const int pixels = (u1 - u0) * (v1 - v0);
    if (s.size[label] - pixels < pixels) continue;  // never empty a segment
    const std::array<int, kRingSize> ring = {tile[-stride - 1], tile[-stride],    tile[-stride + 1],
                                             tile[1],           tile[stride + 1], tile[stride],
                                             tile[stride - 1],  tile[-1]};
    if (!kRingKeepsConnected[ring_mask(ring, label)]) continue;
    const BlockData block = gather_block(s, g, t, u0, v0, u1, v1, scratch);
    const int best_label = best_neighbour_label(
        label, neighbours, [&](int segment) { return block_score(s, segment, block); });
    if (best_label != label) {
      move_block(s, u0, v0, u1, v1, label, best_label);
      g.label[p] = best_label;
      ++moves;
    }
  }
  return moves;
}

/// Marks (1) the pixels of row v that may lie on a segment boundary (a 4-neighbour differs) or
/// on the image border; 0 elsewhere. Branch-free, so it vectorises.
void mark_boundary_candidates(const SuperpixelState& s, int v, std::uint8_t* mark) {
  const int w = s.width;
  if (v == 0 || v + 1 == s.height || w < 3) {
    std::memset(mark, 1, static_cast<std::size_t>(w));
    return;
  }
  const std::int32_t* row = s.labels.data() + static_cast<std::size_t>(v) * w;
  const std::int32_t* up = row - w;
  const std::int32_t* down = row + w;
  mark[0] = mark[w - 1] = 1;
  for (int u = 1; u + 1 < w; ++u) {
    const std::int32_t l = row[u];
    mark[u] = static_cast<std::uint8_t>(
        ((row[u - 1] ^ l) | (row[u + 1] ^ l) | (up[u] ^ l) | (down[u] ^ l)) != 0);
  }
}

/// Moves pixel (u, v) from `label` to the best of its 4-neighbour segments `neighbours` (W, E,
/// N, S; −2 outside the image) when that raises E (paper §4.5 at the pixel level: the block is
/// the pixel), provided it lies on a boundary, is not its segment's last pixel and leaving keeps
/// the segment locally connected (ring mask `mask`). Returns true when it moved.
[[gnu::always_inline]] inline bool try_move_pixel(SuperpixelState& s, int u, int v, int label,
                                                  const std::array<int, 4>& neighbours,
                                                  unsigned mask, bool boundary) {
  if (!boundary || s.size[label] <= 1 || !kRingKeepsConnected[mask]) return false;
  const int i = s.index(u, v);
  const int bin = s.bins[i];
  const float d = s.disparity[i];
  const int best_label = best_neighbour_label(
      label, neighbours, [&](int segment) { return pixel_score(s, segment, bin, u, v, d); });
  if (best_label == label) return false;
  move_pixel(s, u, v, label, best_label);
  return true;
}

/// Pixel (u, v) on the image border: neighbours outside the image are −2.
bool try_move_border_pixel(SuperpixelState& s, int u, int v) {
  const int w = s.width, h = s.height;
  const std::int32_t* lab = s.labels.data();
  auto at = [&](int x, int y) {
    return (x < 0 || y < 0 || x >= w || y >= h) ? -2 : lab[y * w + x];
  };
  const int label = lab[v * w + u];
  const std::array<int, 4> neighbours = {at(u - 1, v), at(u + 1, v), at(u, v - 1), at(u, v + 1)};
  const std::array<int, kRingSize> ring = {at(u - 1, v - 1), neighbours[2],    at(u + 1, v - 1),
                                           neighbours[1],    at(u + 1, v + 1), neighbours[3],
                                           at(u - 1, v + 1), neighbours[0]};
  bool boundary = false;
  for (int nl : neighbours) boundary |= (nl >= 0 && nl != label);
  return try_move_pixel(s, u, v, label, neighbours, ring_mask(ring, label), boundary);
}

/// Interior pixel (u, v): all 8 neighbours are inside the image, so it is a boundary pixel
/// exactly when one of the edge bits (N, E, S, W = odd bits) of its ring mask is clear.
bool try_move_interior_pixel(SuperpixelState& s, int u, int v) {
  const int w = s.width;
  const std::int32_t* c = s.labels.data() + s.index(u, v);
  const int label = c[0];
  const std::array<int, 4> neighbours = {c[-1], c[1], c[-w], c[w]};
  const unsigned mask =
      static_cast<unsigned>(c[-w - 1] == label) | static_cast<unsigned>(c[-w] == label) << 1 |
      static_cast<unsigned>(c[-w + 1] == label) << 2 | static_cast<unsigned>(c[1] == label) << 3 |
      static_cast<unsigned>(c[w + 1] == label) << 4 | static_cast<unsigned>(c[w] == label) << 5 |
      static_cast<unsigned>(c[w - 1] == label) << 6 | static_cast<unsigned>(c[-1] == label) << 7;
  constexpr unsigned kEdgeBits = 0xAAu;
  return try_move_pixel(s, u, v, label, neighbours, mask, (mask & kEdgeBits) != kEdgeBits);
}

/// One sweep of single boundary pixels in raster order (or reversed); returns the number of
/// moves. Each row's boundary candidates are marked before it is swept and visited eight marks
/// (one 64-bit word) at a time. A move changes only its own pixel, so within the row only the
/// next pixel in sweep order can have become a boundary pixel since: after a move it is
/// examined whether marked or not.
int pixel_sweep(SuperpixelState& s, bool backwards) {
  const int w = s.width, h = s.height;
  const int words = (w + 7) / 8;
  std::vector<std::uint8_t> mark(static_cast<std::size_t>(words) * 8, 0);  // zero past w
  int moves = 0;
  for (int row = 0; row < h; ++row) {
    const int v = backwards ? h - 1 - row : row;
    const bool border_row = v == 0 || v + 1 == h;
    mark_boundary_candidates(s, v, mark.data());
    auto evaluate = [&](int u) {
      const bool moved = border_row || u == 0 || u + 1 == w ? try_move_border_pixel(s, u, v)
                                                            : try_move_interior_pixel(s, u, v);
      moves += moved;
      return moved;
    };
    std::uint64_t carry = 0;  // the first (or last) pixel of the next word, after a move
    for (int step = 0; step < words; ++step) {
      const int base = 8 * (backwards ? words - 1 - step : step);
      std::uint64_t word;
      std::memcpy(&word, mark.data() + base, 8);  // byte k = mark of pixel base + k
      word |= carry;
      carry = 0;
      while (word != 0) {
        const int bit = backwards ? 63 - std::countl_zero(word) : std::countr_zero(word);
        word &= ~(std::uint64_t{1} << bit);
        const int k = bit / 8, u = base + k;
        if (!evaluate(u)) continue;
        if (!backwards && u + 1 < w) {
          if (k < 7)
            word |= std::uint64_t{1} << (bit + 8);
          else
            carry = 1;
        } else if (backwards && u > 0) {
          if (k > 0)
            word |= std::uint64_t{1} << (bit - 8);
          else
            carry = std::uint64_t{1} << 56;
        }
      }
    }
  }
  return moves;
}

}  // namespace

void hill_climb(SuperpixelState& s, int block_levels, int first_level, int iterations,
                int pixel_iterations, const Deadline& deadline) {
  first_level = std::max(1, first_level);
  TileGrid coarser;  // the grid of the previous (coarser) level
  for (int level = first_level; level <= block_levels; ++level) {
    const int b = block_size(s.cell_size_px, block_levels, level);  // ≈ ⌊s / l⌋, l = 2^level
    if (b < 2) break;
    TileGrid grid = make_tile_grid(s, b, level > first_level ? &coarser : nullptr);
    for (int it = 0; it < iterations; ++it) {
      if (deadline.passed()) return;
      if (block_sweep(s, grid, it % 2 == 1) == 0) break;
    }
    coarser = std::move(grid);
  }
  for (int it = 0; it < pixel_iterations; ++it) {
    if (deadline.passed()) return;
    if (pixel_sweep(s, it % 2 == 1) == 0) break;
  }
}

}  // namespace planecell::extraction::detail
