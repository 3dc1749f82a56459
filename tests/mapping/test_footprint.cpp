/// Surface footprints as occupancy bits: areas, overlaps, tile seams and bad input, against
/// hand-counted bit centres.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <vector>

#include "core/error.hpp"
#include "mapping/map/footprint.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::map {
namespace {

using test::rectangle;

TEST(Footprint, SquareCoversTheBitsWhoseCentresLieInside) {
  Footprint f(0.1);
  // [0.01, 0.99]² holds the centres 0.05 … 0.95: 10 × 10 bits = 1 m².
  EXPECT_NEAR(f.add_polygon(rectangle(0.01, 0.01, 0.99, 0.99)), 1.0, 1e-9);
  EXPECT_NEAR(f.area_m2(), 1.0, 1e-9);
  EXPECT_TRUE(f.contains(0.55, 0.55));
  EXPECT_FALSE(f.contains(1.05, 0.55));
  EXPECT_EQ(f.covered_centres().size(), 100u);
  // Edges on the bit seams (s, t = 0 and 1 m): the outline runs along them and sets no bit beyond.
  Footprint g(0.1);
  EXPECT_NEAR(g.add_polygon(rectangle(0.0, 0.0, 1.0, 1.0)), 1.0, 1e-9);
  EXPECT_FALSE(g.contains(1.05, 0.55));
  EXPECT_FALSE(g.contains(0.55, -0.05));
}

TEST(Footprint, ReObservationAddsOnlyTheNewPart) {
  Footprint f(0.1);
  f.add_polygon(rectangle(0.01, 0.01, 0.99, 0.99));
  EXPECT_NEAR(f.add_polygon(rectangle(0.01, 0.01, 0.99, 0.99)), 0.0, 1e-12);
  // Shifted by half: 5 new columns of 10 bits.
  EXPECT_NEAR(f.add_polygon(rectangle(0.51, 0.01, 1.49, 0.99)), 0.5, 1e-9);
  EXPECT_NEAR(f.area_m2(), 1.5, 1e-9);
}

TEST(Footprint, RasteriseCountsTheNewAreaBeforeAddingIt) {
  Footprint f(0.1);
  f.add_polygon(rectangle(0.01, 0.01, 0.99, 0.99));  // 10 × 10 bits
  // Shifted by half a metre and across the 3.2 m tile seam at s = 3.2: columns 0.55 … 3.45, of
  // which 0.55 … 0.95 (5 columns) are set already: 25 new columns of 10 bits, 2.5 m².
  const FootprintRaster raster = f.rasterise(rectangle(0.51, 0.01, 3.49, 0.99));
  EXPECT_NEAR(f.new_area_m2(raster), 2.5, 1e-9);
  EXPECT_NEAR(f.area_m2(), 1.0, 1e-9);  // counting marks nothing
  EXPECT_FALSE(f.contains(3.45, 0.55));
  EXPECT_NEAR(f.add(raster), 2.5, 1e-9);
  EXPECT_NEAR(f.area_m2(), 3.5, 1e-9);
  EXPECT_TRUE(f.contains(3.45, 0.55));
  EXPECT_NEAR(f.new_area_m2(raster), 0.0, 1e-12);
  // A raster of nothing (degenerate ring) adds nothing.
  const std::vector<Eigen::Vector2d> line{{0.0, 0.0}, {1.0, 0.0}};
  EXPECT_TRUE(f.rasterise(line).empty());
  EXPECT_EQ(f.add(f.rasterise(line)), 0.0);
}

TEST(Footprint, CellsWithASeamBetweenThemLeaveNoCrack) {
  Footprint f(0.1);
  // Two halves of [0.01, 0.99]² with a 2 cm seam between them at s = 0.44 … 0.46, which holds
  // the centres s = 0.45 of column 4: their outlines set that column, so the whole square seen
  // again adds nothing (centres alone would count column 4, 0.1 m², as new).
  f.add_polygon(rectangle(0.01, 0.01, 0.44, 0.99));
  f.add_polygon(rectangle(0.46, 0.01, 0.99, 0.99));
  EXPECT_TRUE(f.contains(0.45, 0.55));
  EXPECT_NEAR(f.new_area_m2(f.rasterise(rectangle(0.01, 0.01, 0.99, 0.99))), 0.0, 1e-12);
  EXPECT_NEAR(f.area_m2(), 1.0, 1e-9);
}

TEST(Footprint, SquareAcrossTileSeamsAndNegativeCoordinates) {
  Footprint f(0.1);
  // [−3.29, 3.29]² holds centres −3.25 … 3.25: 66 × 66 bits across 3.2 m tiles on both axes.
  EXPECT_NEAR(f.add_polygon(rectangle(-3.29, -3.29, 3.29, 3.29)), 66 * 66 * 0.01, 1e-9);
  EXPECT_GE(f.tiles().size(), 4u);
  EXPECT_TRUE(f.contains(-3.2, -3.2));
  EXPECT_TRUE(f.contains(3.2, 0.0));
  EXPECT_FALSE(f.contains(-3.35, 0.0));
  EXPECT_EQ(f.covered_centres().size(), 66u * 66u);
}

TEST(Footprint, TriangleAreaWithinOneBitRowOfTheExactArea) {
  Footprint f(0.05);
  const std::vector<Eigen::Vector2d> tri{{0.0, 0.0}, {0.0, 4.0}, {4.0, 0.0}};
  const double area = f.add_polygon(tri);
  // Exact area 8 m²; the legs lie on bit edges (no error), and each bit the hypotenuse (5.66 m)
  // crosses may fall in or out: |error| ≤ 5.66 m / res · res² ≈ 0.283 m² plus the bits its
  // outline touches at their corners: allow 1.2 × that.
  EXPECT_NEAR(area, 8.0, 1.2 * 5.66 * 0.05);
}

TEST(Footprint, PointsAndRebuildFromTiles) {
  Footprint f(0.2);
  EXPECT_TRUE(f.add_point(1.01, -0.39));
  EXPECT_FALSE(f.add_point(1.19, -0.21));  // same 0.2 m bit [1.0, 1.2) × [−0.4, −0.2)
  EXPECT_TRUE(f.contains(1.1, -0.3));
  EXPECT_NEAR(f.area_m2(), 0.04, 1e-12);
  Footprint copy = Footprint::from_tiles(0.2, {f.tiles().begin(), f.tiles().end()});
  EXPECT_EQ(copy, f);
  EXPECT_NEAR(copy.area_m2(), 0.04, 1e-12);  // the rebuilt footprint counts its bits
  EXPECT_TRUE(copy.add_point(-5.0, 7.0));     // a second tile
  EXPECT_NEAR(copy.area_m2(), 0.08, 1e-12);
}

TEST(Footprint, BadInputIsRejectedOrIgnored) {
  EXPECT_THROW(Footprint(0.0), ConfigError);
  EXPECT_THROW(Footprint(-1.0), ConfigError);
  FootprintTile a, b;
  a.s = 1;
  b.s = 0;
  EXPECT_THROW(Footprint::from_tiles(0.1, {a, b}), StorageError);
  Footprint f(0.1);
  EXPECT_EQ(f.add_polygon(rectangle(0, 0, std::nan(""), 1)), 0.0);
  EXPECT_FALSE(f.add_point(std::numeric_limits<double>::infinity(), 0.0));
  EXPECT_TRUE(f.empty());
}

TEST(Footprint, RingsAndPointsBeyondTheRepresentableRangeCoverNothing) {
  Footprint f(0.1);
  const std::vector<Eigen::Vector2d> far = {{-1.2e31, 0}, {-1.2e31 + 1, 0}, {-1.2e31 + 1, 1}};
  EXPECT_EQ(f.add_polygon(far), 0.0);
  const std::vector<Eigen::Vector2d> beyond = {{1.1e8, 0}, {1.1e8 + 1, 0}, {1.1e8 + 1, 1}};  // 1.1·10⁹ bits
  EXPECT_EQ(f.add_polygon(beyond), 0.0);
  EXPECT_FALSE(f.add_point(1e300, 0));
  EXPECT_FALSE(f.contains(0, -1e300));
  EXPECT_TRUE(f.empty());
  // Just inside the range (10⁸ bits = 10 000 km): covered as usual (10 × 10 bit centres).
  const std::vector<Eigen::Vector2d> inside = {
      {1e7 + 0.01, 0.01}, {1e7 + 0.99, 0.01}, {1e7 + 0.99, 0.99}, {1e7 + 0.01, 0.99}};
  EXPECT_NEAR(f.add_polygon(inside), 1.0, 1e-9);
}

/// Whether grid bit (i, j) of a ring given in grid units (bit centres at the integers) belongs to
/// its raster, tested directly: its centre inside (even–odd crossings of the row to its right),
/// or an edge crossing its row within (i − ½ + ε, i + ½ − ε) or its column within
/// (j − ½ + ε, j + ½ − ε), ε = 10⁻³ (rows and columns crossed half-open at the edge's ends, as the
/// raster's rule states).
bool in_raster(std::span<const Eigen::Vector2d> ring, int i, int j) {
  bool inside = false;
  const auto crosses = [](double end_a, double end_b, double at) {
    return std::min(end_a, end_b) <= at && at < std::max(end_a, end_b);
  };
  for (std::size_t k = 0; k < ring.size(); ++k) {
    const Eigen::Vector2d& a = ring[k];
    const Eigen::Vector2d& b = ring[(k + 1) % ring.size()];
    if (crosses(a.y(), b.y(), j)) {
      const double u = a.x() + (j - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
      if (u > i) inside = !inside;
      if (i - 0.5 + 1e-3 < u && u < i + 0.5 - 1e-3) return true;
    }
    if (crosses(a.x(), b.x(), i)) {
      const double v = a.y() + (i - a.x()) * (b.y() - a.y()) / (b.x() - a.x());
      if (j - 0.5 + 1e-3 < v && v < j + 0.5 - 1e-3) return true;
    }
  }
  return inside;
}

TEST(Footprint, RasterHoldsExactlyTheBitsInsideOrOnTheOutline) {
  // A notched (non-convex) outline, a thin sliver across a tile seam, and seeded random star
  // polygons (self-touching shapes included): every bit of the surrounding grid is tested against
  // the polygon directly, and the footprint must hold exactly those bits.
  std::vector<std::vector<Eigen::Vector2d>> rings{
      {{0.03, 0.02}, {2.17, 0.04}, {2.21, 1.93}, {1.41, 1.96}, {1.12, 0.61}, {0.83, 1.88}, {0.02, 1.97}},
      {{3.01, -0.37}, {3.43, -0.32}, {3.36, 2.71}}};
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto uniform = [&] { return unit(rng); };
  for (int n = 0; n < 20; ++n) {
    std::vector<Eigen::Vector2d> star;
    const Eigen::Vector2d centre(-2.0 + 4.0 * uniform(), -2.0 + 4.0 * uniform());
    const int corners = 3 + n % 9;
    for (int c = 0; c < corners; ++c) {
      const double angle = 2.0 * M_PI * (c + 0.8 * uniform()) / corners, radius = 0.2 + 1.5 * uniform();
      star.push_back(centre + radius * Eigen::Vector2d(std::cos(angle), std::sin(angle)));
    }
    rings.push_back(star);
  }
  constexpr double res = 0.1;
  for (std::size_t r = 0; r < rings.size(); ++r) {
    Footprint f(res);
    const double area = f.add_polygon(rings[r]);
    std::vector<Eigen::Vector2d> grid_ring;  // u = s/res − ½, v = t/res − ½
    for (const auto& p : rings[r]) grid_ring.emplace_back(p.x() / res - 0.5, p.y() / res - 0.5);
    std::size_t expected = 0;
    for (int j = -50; j < 50; ++j)
      for (int i = -50; i < 50; ++i) {
        const bool in = in_raster(grid_ring, i, j);
        expected += in ? 1 : 0;
        EXPECT_EQ(f.contains((i + 0.5) * res, (j + 0.5) * res), in) << "ring " << r << " bit (" << i << ", " << j << ")";
      }
    EXPECT_NEAR(area, static_cast<double>(expected) * res * res, 1e-9) << "ring " << r;
  }
}

}  // namespace
}  // namespace planecell::map
