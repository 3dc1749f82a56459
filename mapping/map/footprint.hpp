#pragma once
/// The footprint of a surface: which parts of its plane have been observed, as a sparse set of
/// square tiles of occupancy bits in the surface's 2D basis. Fusing a cell rasterises its polygon
/// (the bits its inside and outline hold, as row spans) and counts the bits it newly sets, so the
/// per-cell cost is bounded by the cell's own size, not by the surface's history, and a surface's
/// memory grows with the area it covers (res² per bit), not with the number of observations.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "mapping/map/geometry.hpp"

namespace planecell::map {

/// A 32 × 32 block of footprint bits; bit (i, j) covers
/// [(32·s + i)·res, (32·s + i + 1)·res) × [(32·t + j)·res, (32·t + j + 1)·res) of the basis.
struct FootprintTile {
  static constexpr int kSize = 32;
  std::int32_t s = 0;
  std::int32_t t = 0;
  std::array<std::uint32_t, kSize> rows{};  ///< rows[j] bit i
  bool operator==(const FootprintTile&) const = default;
};

/// Bits i_first … i_last (inclusive) of grid row j: bit (i, j) covers
/// [i·res, (i + 1)·res) × [j·res, (j + 1)·res) of the basis.
struct FootprintSpan {
  std::int32_t j = 0;
  std::int32_t i_first = 0;
  std::int32_t i_last = 0;
};

/// A polygon rasterised on a footprint's grid (Footprint::rasterise): the grid bits whose centres
/// c = ((i + ½)·res, (j + ½)·res) lie inside the polygon (even–odd rule) or on its outline,
/// i.e. an edge crosses one of the two segments of one bit's length through c, along the row or
/// along the column (the bits a line drawing of the outline sets: cells that touch leave no crack
/// of unset bits between their rasters, where a later view across their seam would count new
/// area). A crossing within 10⁻³ bit of the seam of two bits (float rounding) sets neither, so a
/// polygon whose edges run along bit seams holds just the bits inside it. Disjoint spans sorted by
/// (j, i_first); none cover nothing (a degenerate, non-finite or absurdly large polygon).
struct FootprintRaster {
  std::vector<FootprintSpan> spans;
  bool empty() const { return spans.empty(); }
};

class Footprint {
 public:
  /// A 0.1 m footprint (not explicit, so aggregates holding a Footprint value-initialise).
  Footprint() : Footprint(0.1) {}
  /// Throws ConfigError unless resolution_m is in (0, 10].
  explicit Footprint(double resolution_m);

  /// Marks the bits of the polygon `ring` (FootprintRaster: inside or on its outline; basis
  /// coordinates (s, t) in m, either orientation, closing vertex optional). Returns the area
  /// newly covered: (bits set now that were clear before) · res² (m²).
  double add_polygon(std::span<const Eigen::Vector2d> ring);
  /// The same in two steps, so that the area a polygon would add is known before the footprint
  /// changes: rasterise (the bits of add_polygon, nothing marked), new_area_m2 (the area add
  /// would return now) and add (marks them; returns the area newly covered).
  FootprintRaster rasterise(std::span<const Eigen::Vector2d> ring) const;
  double new_area_m2(const FootprintRaster& raster) const;
  double add(const FootprintRaster& raster);
  /// Marks the bit containing (s, t); returns true if it was clear.
  bool add_point(double s, double t);

  /// Covered area: set bits · res² (m²), from a running count of the set bits (a long surface's
  /// footprint, the road's, spans the whole drive: no walk over its tiles).
  double area_m2() const { return static_cast<double>(bits_) * resolution_m_ * resolution_m_; }
  /// True when the bit containing (s, t) is set.
  bool contains(double s, double t) const;
  /// Centres (s, t) of every set bit, in tile order.
  std::vector<Eigen::Vector2d> covered_centres() const;

  double resolution_m() const { return resolution_m_; }
  std::span<const FootprintTile> tiles() const { return tiles_; }
  bool empty() const { return tiles_.empty(); }
  /// Heap bytes (tile vector capacity).
  std::size_t bytes() const { return tiles_.capacity() * sizeof(FootprintTile); }
  /// Rebuilds from stored tiles (io::MapStore); throws StorageError when they are not strictly
  /// sorted by (s, t).
  static Footprint from_tiles(double resolution_m, std::vector<FootprintTile> tiles);
  bool operator==(const Footprint&) const = default;

 private:
  FootprintTile& tile_at(std::int32_t s, std::int32_t t);
  const FootprintTile* find_tile(std::int32_t s, std::int32_t t) const;

  double resolution_m_ = 0.1;
  std::vector<FootprintTile> tiles_;  ///< sorted by (s, t)
  std::size_t bits_ = 0;              ///< set bits in tiles_
};

}  // namespace planecell::map
