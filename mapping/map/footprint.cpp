#include "mapping/map/footprint.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <optional>

#include <boost/container/small_vector.hpp>

#include "core/error.hpp"

namespace planecell::map {
namespace {

/// (s, t) lies within ±2³⁰ bits of the basis origin: bit and tile indices fit their integers.
bool representable(double s, double t, double resolution_m) {
  return std::max(std::abs(s), std::abs(t)) / resolution_m <= static_cast<double>(1 << 30);
}

constexpr int N = FootprintTile::kSize;

std::int64_t floor_div(std::int64_t a, std::int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

bool tile_less(const FootprintTile& tile, std::pair<std::int32_t, std::int32_t> key) {
  return std::pair(tile.s, tile.t) < key;
}

/// Calls f(ti, tj, bj, bits) for each tile row a raster's spans fall in: tile (ti, tj), its row
/// bj, and the bits of that row the span sets (bit i = grid column 32·ti + i); spans in raster
/// order, each split at the tile seams it crosses.
template <class F>
void for_each_tile_row(const FootprintRaster& raster, F&& f) {
  for (const FootprintSpan& span : raster.spans) {
    const auto tj = static_cast<std::int32_t>(floor_div(span.j, N));
    const auto bj = static_cast<int>(span.j - static_cast<std::int64_t>(tj) * N);
    for (std::int64_t i = span.i_first; i <= span.i_last;) {
      const auto ti = static_cast<std::int32_t>(floor_div(i, N));
      const std::int64_t first_column = static_cast<std::int64_t>(ti) * N;
      const std::int64_t last = std::min<std::int64_t>(span.i_last, first_column + N - 1);
      const auto width = static_cast<int>(last - i + 1);  // 1 … 32 bits
      const std::uint32_t ones = width == N ? ~0u : (1u << width) - 1u;
      f(ti, tj, bj, ones << static_cast<int>(i - first_column));
      i = last + 1;
    }
  }
}

}  // namespace

Footprint::Footprint(double resolution_m) : resolution_m_(resolution_m) {
  if (!(resolution_m > 0.0 && resolution_m <= 10.0))
    throw ConfigError("footprint resolution must be in (0, 10] m, got " + std::to_string(resolution_m));
}

FootprintTile& Footprint::tile_at(std::int32_t s, std::int32_t t) {
  auto it = std::lower_bound(tiles_.begin(), tiles_.end(), std::pair(s, t), tile_less);
  if (it != tiles_.end() && it->s == s && it->t == t) return *it;
  FootprintTile fresh;
  fresh.s = s;
  fresh.t = t;
  // Grow by an eighth, not the vector's doubling: most surfaces hold a few tiles, and a doubled
  // vector left ~19 % of the footprints' bytes unused (100-frame street).
  if (tiles_.size() == tiles_.capacity()) {
    const auto at = it - tiles_.begin();
    tiles_.reserve(tiles_.size() + tiles_.size() / 8 + 1);
    it = tiles_.begin() + at;
  }
  return *tiles_.insert(it, fresh);
}

const FootprintTile* Footprint::find_tile(std::int32_t s, std::int32_t t) const {
  auto it = std::lower_bound(tiles_.begin(), tiles_.end(), std::pair(s, t), tile_less);
  return it != tiles_.end() && it->s == s && it->t == t ? &*it : nullptr;
}

double Footprint::add_polygon(std::span<const Eigen::Vector2d> ring) { return add(rasterise(ring)); }

FootprintRaster Footprint::rasterise(std::span<const Eigen::Vector2d> ring) const {
  // The scan's helper lambdas are always_inline: GCC's inlining budget is per translation unit,
  // and when other sources of the unity batch spent it they were called out of line (+20 % of
  // rasterise's instructions).
  FootprintRaster raster;
  if (ring.size() < 3) return raster;
  double lo_s = std::numeric_limits<double>::infinity(), lo_t = lo_s, hi_s = -lo_s, hi_t = -lo_s;
  for (const auto& p : ring) {
    if (!std::isfinite(p.x()) || !std::isfinite(p.y())) return raster;
    lo_s = std::min(lo_s, p.x()), hi_s = std::max(hi_s, p.x());
    lo_t = std::min(lo_t, p.y()), hi_t = std::max(hi_t, p.y());
  }
  const double inv = 1.0 / resolution_m_;
  // Bit indices (and the int32 tile indices derived from them) must stay representable: a ring
  // beyond ±2³⁰ bits of the basis origin (±107 000 km at 10 cm) is absurd and covers nothing
  // (fuzz_lcm crash-3e7010a1: a mirrored cell at 10³¹ m overflowed the conversion).
  constexpr double kMaxBits = static_cast<double>(1 << 30);
  if (std::max({std::abs(lo_s), std::abs(hi_s), std::abs(lo_t), std::abs(hi_t)}) * inv > kMaxBits)
    return raster;
  // Grid bits i cover [i·res, (i+1)·res); their centres (i + 0.5)·res must lie in the polygon's
  // bounding box: i ∈ [⌈lo/res − 0.5⌉, ⌊hi/res − 0.5⌋].
  const auto i0 = static_cast<std::int64_t>(std::ceil(lo_s * inv - 0.5));
  const auto j0 = static_cast<std::int64_t>(std::ceil(lo_t * inv - 0.5));
  const auto i1 = static_cast<std::int64_t>(std::floor(hi_s * inv - 0.5));
  const auto j1 = static_cast<std::int64_t>(std::floor(hi_t * inv - 0.5));
  const std::int64_t cols = i1 - i0 + 1, rows = j1 - j0 + 1;
  if (cols <= 0 || rows <= 0 || cols * rows > 4'000'000) return raster;  // degenerate or absurd
  // In grid units u = s/res − ½, v = t/res − ½ bit (i, j) has its centre at (i, j). Each edge
  // crosses the rows j with min(v_a, v_b) ≤ j < max(v_a, v_b) (half-open, so a vertex on a row
  // counts once) at u_j = u_a + (j − v_a)(u_b − u_a)/(v_b − v_a), and the columns i likewise at v_i.
  // Inside (even–odd, by parity): a row crossing flips the row's bits i ≥ ⌈u_j⌉, so a bit ends set
  // when an odd number of crossings lie at or left of its centre; a closed ring crosses each row an
  // even number of times, so the flips cancel past its last crossing. (That is the runs
  // ⌈u_0⌉ … ⌊u_1⌋ but for a crossing exactly on a centre, u_1 = i, which the outline sets.)
  // Outline: bit (⌊u_j + ½⌋, j) of each row crossing and (i, ⌊v_i + ½⌋) of each column crossing,
  // unless it lies on a seam. Both go into bitmaps of the cell's box widened by one bit (the
  // outline reaches half a bit beyond the centres' box), read out as each row's runs.
  const std::int64_t row_lo = j0 - 1, row_hi = j1 + 1, col_lo = i0 - 1, col_hi = i1 + 1;
  const auto words = static_cast<std::size_t>((col_hi - col_lo + 1 + 63) / 64);
  const auto cells = static_cast<std::size_t>(row_hi - row_lo + 1) * words;
  boost::container::small_vector<std::uint64_t, 256> bitmap(cells, 0u);  // the outline's bits
  boost::container::small_vector<std::uint64_t, 256> inside(cells, 0u);  // the centres inside
  const auto flip_from = [&](std::int64_t j, double u) __attribute__((always_inline)) {
    std::uint64_t* row = inside.data() + static_cast<std::size_t>(j - row_lo) * words;
    // Clamped into the bitmap, not skipped, so that the row's flips still cancel at its end.
    const double first = std::clamp(std::ceil(u), static_cast<double>(col_lo), static_cast<double>(col_hi + 1));
    const auto c0 = static_cast<std::size_t>(static_cast<std::int64_t>(first) - col_lo);
    if (c0 >= words * 64) return;
    row[c0 / 64] ^= ~std::uint64_t{0} << (c0 % 64);
    for (std::size_t w = c0 / 64 + 1; w < words; ++w) row[w] = ~row[w];
  };
  // The bit whose centre segment (k − ½ + ε, k + ½ − ε) holds x; none for x within ε of a seam:
  // ε = 10⁻³ bit (0.1 mm at 10 cm) exceeds the float rounding of the vertices up to ~2 km from
  // the origin, so an edge laid along a seam sets no bit beyond it.
  constexpr double kSeam = 1e-3;
  const auto nearest = [](double x) __attribute__((always_inline)) -> std::optional<std::int64_t> {
    const double k = std::floor(x + 0.5);
    if (x - (k - 0.5) < kSeam || (k + 0.5) - x < kSeam) return std::nullopt;
    return static_cast<std::int64_t>(k);
  };
  // Outline bits first … last of row j (within the widened box by construction; clamped so that
  // no rounding can write outside the bitmap).
  const auto add_piece = [&](std::int64_t j, std::int64_t first, std::int64_t last) __attribute__((always_inline)) {
    std::uint64_t* row = bitmap.data() + static_cast<std::size_t>(std::clamp(j, row_lo, row_hi) - row_lo) * words;
    const auto c0 = static_cast<std::size_t>(std::max(first, col_lo) - col_lo);
    const auto c1 = static_cast<std::size_t>(std::min(last, col_hi) - col_lo);
    for (std::size_t w = c0 / 64; w <= c1 / 64; ++w) {
      const std::size_t lo = w == c0 / 64 ? c0 % 64 : 0, hi = w == c1 / 64 ? c1 % 64 : 63;
      row[w] |= (~std::uint64_t{0} >> (63 - hi)) & (~std::uint64_t{0} << lo);
    }
  };
  for (std::size_t k = 0; k < ring.size(); ++k) {
    const Eigen::Vector2d& a = ring[k];
    const Eigen::Vector2d& b = ring[(k + 1) % ring.size()];
    const double ua = a.x() * inv - 0.5, va = a.y() * inv - 0.5;
    const double ub = b.x() * inv - 0.5, vb = b.y() * inv - 0.5;
    if (va != vb) {  // an edge along a row crosses no row: its ends' edges count the crossings
      const double du_dv = (ub - ua) / (vb - va);
      const auto first = static_cast<std::int64_t>(std::ceil(std::min(va, vb)));
      const auto last = static_cast<std::int64_t>(std::ceil(std::max(va, vb))) - 1;  // < max
      for (std::int64_t j = first; j <= last; ++j) {
        const double u = ua + (static_cast<double>(j) - va) * du_dv;
        if (j >= j0 && j <= j1) flip_from(j, u);
        if (const auto i = nearest(u)) add_piece(j, *i, *i);
      }
    }
    if (ua != ub) {  // consecutive columns rounding to one row: one piece
      const double dv_du = (vb - va) / (ub - ua);
      const auto first = static_cast<std::int64_t>(std::ceil(std::min(ua, ub)));
      const auto last = static_cast<std::int64_t>(std::ceil(std::max(ua, ub))) - 1;
      std::optional<std::int64_t> run_j;  // the row of the run of columns ending at i − 1
      std::int64_t run_first = 0;
      for (std::int64_t i = first; i <= last; ++i) {
        const auto j = nearest(va + (static_cast<double>(i) - ua) * dv_du);
        if (j == run_j) continue;
        if (run_j) add_piece(*run_j, run_first, i - 1);
        run_j = j, run_first = i;
      }
      if (run_j) add_piece(*run_j, run_first, last);
    }
  }
  // Each row's runs of set bits, in order (a run may continue across words; no bit beyond
  // col_hi is set, so a run still open after the last word ends at its last bit).
  auto& spans = raster.spans;
  spans.reserve(static_cast<std::size_t>(rows) + 2);  // one span a row for a convex cell
  const auto add_span = [&](std::int64_t j, std::int64_t first, std::int64_t last) __attribute__((always_inline)) {
    spans.push_back({static_cast<std::int32_t>(j), static_cast<std::int32_t>(col_lo + first),
                     static_cast<std::int32_t>(col_lo + last)});
  };
  for (std::int64_t j = row_lo; j <= row_hi; ++j) {
    std::uint64_t* row = bitmap.data() + static_cast<std::size_t>(j - row_lo) * words;
    const std::uint64_t* in = inside.data() + static_cast<std::size_t>(j - row_lo) * words;
    for (std::size_t w = 0; w < words; ++w) row[w] |= in[w];
    std::int64_t run_first = -1;  // bit index (from col_lo) of the open run's first bit
    for (std::size_t w = 0; w < words; ++w) {
      for (int at = 0; at < 64;) {
        const std::uint64_t from_at = ~std::uint64_t{0} << at;
        const std::uint64_t wanted = (run_first < 0 ? row[w] : ~row[w]) & from_at;  // a start or an end
        if (wanted == 0) break;
        at = std::countr_zero(wanted);
        const auto bit = static_cast<std::int64_t>(w * 64) + at;
        if (run_first < 0) {
          run_first = bit;
        } else {
          add_span(j, run_first, bit - 1);
          run_first = -1;
        }
      }
    }
    if (run_first >= 0) add_span(j, run_first, static_cast<std::int64_t>(words * 64) - 1);
  }
  return raster;
}

double Footprint::new_area_m2(const FootprintRaster& raster) const {
  std::size_t added = 0;
  // Consecutive spans mostly fall in the same tile: it is looked up again only when it changes.
  std::optional<std::pair<std::int32_t, std::int32_t>> key;
  const FootprintTile* tile = nullptr;  // find_tile(*key), null when absent
  for_each_tile_row(raster, [&](std::int32_t ti, std::int32_t tj, int bj, std::uint32_t bits) {
    if (key != std::pair(ti, tj)) key = {ti, tj}, tile = find_tile(ti, tj);
    added += static_cast<std::size_t>(std::popcount(bits & ~(tile ? tile->rows[bj] : 0u)));
  });
  return static_cast<double>(added) * resolution_m_ * resolution_m_;
}

double Footprint::add(const FootprintRaster& raster) {
  std::size_t added = 0;
  // As in new_area_m2; a tile inserted moves the others, but only the current one is held.
  std::optional<std::pair<std::int32_t, std::int32_t>> key;
  FootprintTile* tile = nullptr;
  for_each_tile_row(raster, [&](std::int32_t ti, std::int32_t tj, int bj, std::uint32_t bits) {
    if (key != std::pair(ti, tj)) key = {ti, tj}, tile = &tile_at(ti, tj);
    std::uint32_t& row = tile->rows[bj];
    added += static_cast<std::size_t>(std::popcount(bits & ~row));
    row |= bits;
  });
  bits_ += added;
  return static_cast<double>(added) * resolution_m_ * resolution_m_;
}

bool Footprint::add_point(double s, double t) {
  if (!std::isfinite(s) || !std::isfinite(t) || !representable(s, t, resolution_m_)) return false;
  const auto i = static_cast<std::int64_t>(std::floor(s / resolution_m_));
  const auto j = static_cast<std::int64_t>(std::floor(t / resolution_m_));
  const auto ti = static_cast<std::int32_t>(floor_div(i, N)), tj = static_cast<std::int32_t>(floor_div(j, N));
  std::uint32_t& row = tile_at(ti, tj).rows[j - static_cast<std::int64_t>(tj) * N];
  const std::uint32_t bit = 1u << static_cast<int>(i - static_cast<std::int64_t>(ti) * N);
  const bool was_clear = (row & bit) == 0;
  row |= bit;
  bits_ += was_clear ? 1 : 0;
  return was_clear;
}

bool Footprint::contains(double s, double t) const {
  if (!std::isfinite(s) || !std::isfinite(t) || !representable(s, t, resolution_m_)) return false;
  const auto i = static_cast<std::int64_t>(std::floor(s / resolution_m_));
  const auto j = static_cast<std::int64_t>(std::floor(t / resolution_m_));
  const auto ti = static_cast<std::int32_t>(floor_div(i, N)), tj = static_cast<std::int32_t>(floor_div(j, N));
  const FootprintTile* tile = find_tile(ti, tj);
  if (!tile) return false;
  return (tile->rows[j - static_cast<std::int64_t>(tj) * N] >> (i - static_cast<std::int64_t>(ti) * N)) & 1u;
}

std::vector<Eigen::Vector2d> Footprint::covered_centres() const {
  std::vector<Eigen::Vector2d> out;
  for (const auto& tile : tiles_)
    for (int j = 0; j < N; ++j)
      for (std::uint32_t row = tile.rows[j]; row != 0; row &= row - 1) {
        const int i = std::countr_zero(row);
        out.emplace_back((static_cast<double>(tile.s) * N + i + 0.5) * resolution_m_,
                         (static_cast<double>(tile.t) * N + j + 0.5) * resolution_m_);
      }
  return out;
}

Footprint Footprint::from_tiles(double resolution_m, std::vector<FootprintTile> tiles) {
  Footprint f(resolution_m);
  for (std::size_t k = 1; k < tiles.size(); ++k)
    if (!(std::pair(tiles[k - 1].s, tiles[k - 1].t) < std::pair(tiles[k].s, tiles[k].t)))
      throw StorageError("footprint tiles are not strictly sorted");
  f.tiles_ = std::move(tiles);
  for (const auto& tile : f.tiles_)
    for (std::uint32_t row : tile.rows) f.bits_ += static_cast<std::size_t>(std::popcount(row));
  return f;
}

}  // namespace planecell::map
