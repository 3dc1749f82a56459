#include "mapping/map/footprint.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "core/error.hpp"

namespace planecell::map {
namespace {

/// (s, t) lies within ±2³⁰ bits of the basis origin: bit and tile indices fit their integers.
bool representable(double s, double t, double resolution_m) {
  return std::max(std::abs(s), std::abs(t)) / resolution_m <= static_cast<double>(1 << 30);
}

constexpr int kFootprintShift = 8;  // fillPoly fixed-point bits
constexpr int N = FootprintTile::kSize;

std::int64_t floor_div(std::int64_t a, std::int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

bool tile_less(const FootprintTile& tile, std::pair<std::int32_t, std::int32_t> key) {
  return std::pair(tile.s, tile.t) < key;
}

/// Calls f(ti, tj, bj, bits) for each tile row a raster's set pixels fall in: tile (ti, tj), its
/// row bj, and the bits of that row the raster sets (bit i = grid column 32·ti + i). A row of the
/// mask visits each tile it crosses once, from the first set pixel in it.
template <class F>
void for_each_tile_row(const FootprintRaster& raster, F&& f) {
  for (int r = 0; r < raster.mask.rows; ++r) {
    const auto* m = raster.mask.ptr<std::uint8_t>(r);
    const std::int64_t j = raster.j0 + r;
    const auto tj = static_cast<std::int32_t>(floor_div(j, N));
    const auto bj = static_cast<int>(j - static_cast<std::int64_t>(tj) * N);
    for (std::int64_t c = 0; c < raster.mask.cols;) {
      if (!m[c]) {
        ++c;
        continue;
      }
      const auto ti = static_cast<std::int32_t>(floor_div(raster.i0 + c, N));
      const std::int64_t first_column = static_cast<std::int64_t>(ti) * N;
      std::uint32_t bits = 0;
      for (; c < raster.mask.cols && raster.i0 + c < first_column + N; ++c)
        if (m[c]) bits |= 1u << static_cast<int>(raster.i0 + c - first_column);
      f(ti, tj, bj, bits);
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
  // bounding box: i ∈ [⌈lo/res − 0.5⌉, ⌊hi/res − 0.5⌋] (fillPoly itself also takes edge pixels).
  const auto i0 = static_cast<std::int64_t>(std::ceil(lo_s * inv - 0.5));
  const auto j0 = static_cast<std::int64_t>(std::ceil(lo_t * inv - 0.5));
  const auto i1 = static_cast<std::int64_t>(std::floor(hi_s * inv - 0.5));
  const auto j1 = static_cast<std::int64_t>(std::floor(hi_t * inv - 0.5));
  const std::int64_t cols = i1 - i0 + 1, rows = j1 - j0 + 1;
  if (cols <= 0 || rows <= 0 || cols * rows > 4'000'000) return raster;  // degenerate or absurd
  raster.i0 = i0, raster.j0 = j0;
  raster.mask = cv::Mat::zeros(static_cast<int>(rows), static_cast<int>(cols), CV_8U);
  std::vector<cv::Point> points;
  points.reserve(ring.size());
  const double scale = static_cast<double>(1 << kFootprintShift);
  for (const auto& p : ring)
    points.emplace_back(static_cast<int>(std::lround((p.x() * inv - 0.5 - static_cast<double>(i0)) * scale)),
                        static_cast<int>(std::lround((p.y() * inv - 0.5 - static_cast<double>(j0)) * scale)));
  cv::fillPoly(raster.mask, std::vector<std::vector<cv::Point>>{points}, cv::Scalar(1), cv::LINE_8,
               kFootprintShift);
  return raster;
}

double Footprint::new_area_m2(const FootprintRaster& raster) const {
  std::size_t added = 0;
  for_each_tile_row(raster, [&](std::int32_t ti, std::int32_t tj, int bj, std::uint32_t bits) {
    const FootprintTile* tile = find_tile(ti, tj);
    added += static_cast<std::size_t>(std::popcount(bits & ~(tile ? tile->rows[bj] : 0u)));
  });
  return static_cast<double>(added) * resolution_m_ * resolution_m_;
}

double Footprint::add(const FootprintRaster& raster) {
  std::size_t added = 0;
  for_each_tile_row(raster, [&](std::int32_t ti, std::int32_t tj, int bj, std::uint32_t bits) {
    std::uint32_t& row = tile_at(ti, tj).rows[bj];
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
