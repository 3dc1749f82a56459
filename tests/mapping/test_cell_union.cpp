/// Cell union: hand-built squares on a plane united on a raster, their outline against the exact
/// union (area and corners within one raster bit plus the tolerance), what is left out (far or
/// lone polygons), holes filled or cut around, the lift onto the plane, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/error.hpp"
#include "mapping/map/cell_union.hpp"

namespace planecell::map {
namespace {

constexpr double kRes = 0.05;
constexpr double kTol = 0.05;

/// The plane z = 0 and the basis make_basis builds there from the origin (u = x, v = y).
struct Flat {
  Plane3 plane{Eigen::Vector3d::UnitZ(), 0.0};
  PlaneBasis basis = make_basis(plane, Eigen::Vector3d::Zero());
};

/// The square [x0, x1] × [y0, y1] at height z.
std::vector<Eigen::Vector3f> square(float x0, float y0, float x1, float y1, float z = 0.0f) {
  return {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
}

std::vector<CellUnion> unite(const std::vector<std::vector<Eigen::Vector3f>>& polygons, const Flat& flat = {},
                             double max_hole_m2 = 0.5) {
  std::vector<std::span<const Eigen::Vector3f>> spans(polygons.begin(), polygons.end());
  return unite_cells(spans, flat.basis, flat.plane, {kRes, kTol, max_hole_m2});
}

/// Even-odd test of (x, y) against the ring's xy projection.
bool inside(const std::vector<Eigen::Vector3f>& ring, double x, double y) {
  bool in = false;
  for (std::size_t a = 0, b = ring.size() - 1; a < ring.size(); b = a++)
    if ((ring[a].y() > y) != (ring[b].y() > y) &&
        x < ring[b].x() + (y - ring[b].y()) * (ring[a].x() - ring[b].x()) / (ring[a].y() - ring[b].y()))
      in = !in;
  return in;
}

/// Distance of (x, y) to the boundary of the rectangle [x0, x1] × [y0, y1].
double to_rectangle_boundary(const Eigen::Vector3f& p, double x0, double y0, double x1, double y1) {
  const double dx = std::max({x0 - p.x(), 0.0, p.x() - x1}), dy = std::max({y0 - p.y(), 0.0, p.y() - y1});
  if (dx > 0.0 || dy > 0.0) return std::hypot(dx, dy);
  return std::min({p.x() - x0, x1 - p.x(), p.y() - y0, y1 - p.y()});
}

TEST(CellUnion, TwoTouchingSquaresBecomeTheirRectangle) {
  const auto unions = unite({square(0, 0, 1, 1), square(1, 0, 2, 1)});
  ASSERT_EQ(unions.size(), 1u);
  EXPECT_EQ(unions[0].members, (std::vector<std::size_t>{0, 1}));
  // The rectangle [0, 2] × [0, 1]: its raster edges lie within one bit of the true edges, and
  // Douglas–Peucker moves them by at most the tolerance.
  for (const auto& v : unions[0].vertices_m) {
    EXPECT_LE(to_rectangle_boundary(v, 0, 0, 2, 1), kRes + kTol + 1e-6) << v.transpose();
    EXPECT_NEAR(v.z(), 0.0f, 1e-6f);
  }
  // Perimeter 6 m, each edge within one bit: area 2 m² ± 6 · 0.05.
  EXPECT_NEAR(polygon_area_m2(unions[0].vertices_m), 2.0, 6 * kRes);
  // A rectangle's staircase-free raster simplifies to its four corners.
  EXPECT_EQ(unions[0].vertices_m.size(), 4u);
}

TEST(CellUnion, ASliverGapNarrowerThanABitIsClosed) {
  // 2 cm apart: slightly different planes leave such gaps between neighbouring cells.
  const auto unions = unite({square(0, 0, 1, 1), square(1.02f, 0, 2, 1)});
  ASSERT_EQ(unions.size(), 1u);
  EXPECT_NEAR(polygon_area_m2(unions[0].vertices_m), 2.0, 6 * kRes);
}

TEST(CellUnion, FarPolygonsAndSinglesAreLeftOut) {
  // 0 and 2 touch; 1 is 4 m away, alone; 3 is a 1 cm sliver 2 m away, alone.
  const auto unions = unite({square(0, 0, 1, 1), square(5, 0, 6, 1), square(0, 1, 1, 2), square(3, 0, 3.01f, 1)});
  ASSERT_EQ(unions.size(), 1u);
  EXPECT_EQ(unions[0].members, (std::vector<std::size_t>{0, 2}));
  EXPECT_NEAR(polygon_area_m2(unions[0].vertices_m), 2.0, 6 * kRes);
}

TEST(CellUnion, ASmallHoleIsFilledALargeOneCutAround) {
  // Four strips around the 1 m² hole [1, 2]², a polygon cell cannot hold a hole.
  const std::vector<std::vector<Eigen::Vector3f>> frame = {square(0, 0, 3, 1), square(0, 2, 3, 3),
                                                           square(0, 1, 1, 2), square(2, 1, 3, 2)};
  // Holes up to 1.5 m² are filled: one 3 × 3 m union of all four.
  const auto filled = unite(frame, {}, 1.5);
  ASSERT_EQ(filled.size(), 1u);
  EXPECT_EQ(filled[0].members, (std::vector<std::size_t>{0, 1, 2, 3}));
  EXPECT_NEAR(polygon_area_m2(filled[0].vertices_m), 9.0, 12 * kRes);
  EXPECT_TRUE(inside(filled[0].vertices_m, 1.5, 1.5));
  // Up to 0.5 m²: the frame is cut into hole-free unions that cover it and leave the hole out.
  const auto cut = unite(frame, {}, 0.5);
  ASSERT_GE(cut.size(), 2u);
  double area = 0.0;
  std::vector<std::size_t> members;
  for (const auto& u : cut) {
    area += polygon_area_m2(u.vertices_m);
    members.insert(members.end(), u.members.begin(), u.members.end());
    EXPECT_FALSE(inside(u.vertices_m, 1.5, 1.5));
  }
  // Frame area 8 m², each outline half a bit inside its region's edge (perimeters ≤ 24 m).
  EXPECT_NEAR(area, 8.0, 24 * kRes);
  std::sort(members.begin(), members.end());
  members.erase(std::unique(members.begin(), members.end()), members.end());
  EXPECT_EQ(members, (std::vector<std::size_t>{0, 1, 2, 3}));
  for (double x = 0.25; x < 3.0; x += 0.5)
    for (double y = 0.25; y < 3.0; y += 0.5) {
      if (x > 1.0 && x < 2.0 && y > 1.0 && y < 2.0) continue;  // the hole
      const auto covering = std::count_if(cut.begin(), cut.end(), [&](const CellUnion& u) { return inside(u.vertices_m, x, y); });
      EXPECT_EQ(covering, 1) << x << ", " << y;
    }
}

TEST(CellUnion, OutlineIsLiftedOntoThePlane) {
  // Cells 3 cm above and below z = 0 (their own noisy planes) end on the plane z = 0; on the
  // plane z = 0.5 x (tilted 26.6°, basis from make_basis) the union's vertices satisfy it.
  for (const auto& [cells, plane] :
       {std::pair(std::vector{square(0, 0, 1, 1, 0.03f), square(1, 0, 2, 1, -0.03f)}, Plane3{Eigen::Vector3d::UnitZ(), 0.0}),
        std::pair(std::vector{square(0, 0, 1, 1), square(1, 0, 2, 1)},
                  Plane3{Eigen::Vector3d(-0.5, 0, 1).normalized(), 0.0})}) {
    const Flat on{plane, make_basis(plane, Eigen::Vector3d::Zero())};
    const auto unions = unite(cells, on);
    ASSERT_EQ(unions.size(), 1u);
    for (const auto& v : unions[0].vertices_m)
      EXPECT_NEAR(plane.signed_distance(v.cast<double>()), 0.0, 1e-5) << v.transpose();
  }
}

TEST(CellUnion, AnOutlineWithTooManyVerticesIsSimplifiedFurther) {
  // Two half discs of radius 2 m (200 vertices each) make a disc; at 5 cm its outline keeps
  // dozens of vertices, capped at 12 it is simplified with a doubled tolerance until it fits and
  // still encloses most of the disc: more than the square inscribed in it (2/π of its area).
  std::vector<std::vector<Eigen::Vector3f>> halves(2);
  for (int k = 0; k <= 200; ++k)
    for (int h = 0; h < 2; ++h) {
      const double a = std::numbers::pi * (h + k / 200.0);
      halves[h].emplace_back(static_cast<float>(2 * std::cos(a)), static_cast<float>(2 * std::sin(a)), 0.0f);
    }
  const Flat flat;
  std::vector<std::span<const Eigen::Vector3f>> spans(halves.begin(), halves.end());
  const auto fine = unite_cells(spans, flat.basis, flat.plane, {kRes, kTol, 0.5, 256});
  ASSERT_EQ(fine.size(), 1u);
  EXPECT_GT(fine[0].vertices_m.size(), 12u);
  const auto capped = unite_cells(spans, flat.basis, flat.plane, {kRes, kTol, 0.5, 12});
  ASSERT_EQ(capped.size(), 1u);
  EXPECT_LE(capped[0].vertices_m.size(), 12u);
  EXPECT_GE(capped[0].vertices_m.size(), 3u);
  EXPECT_GT(polygon_area_m2(capped[0].vertices_m), 0.6 * std::numbers::pi * 4.0);
  EXPECT_LT(polygon_area_m2(capped[0].vertices_m), std::numbers::pi * 4.0);
}

TEST(CellUnion, BadResolutionOrToleranceIsAnInputError) {
  const Flat flat;
  const std::vector<std::vector<Eigen::Vector3f>> cells = {square(0, 0, 1, 1), square(1, 0, 2, 1)};
  std::vector<std::span<const Eigen::Vector3f>> spans(cells.begin(), cells.end());
  EXPECT_THROW(unite_cells(spans, flat.basis, flat.plane, {0.0, kTol, 0.5}), InputError);
  EXPECT_THROW(unite_cells(spans, flat.basis, flat.plane, {kRes, -1.0, 0.5}), InputError);
  EXPECT_THROW(unite_cells(spans, flat.basis, flat.plane, {kRes, std::nan(""), 0.5}), InputError);
  EXPECT_THROW(unite_cells(spans, flat.basis, flat.plane, {kRes, kTol, -1.0}), InputError);
  EXPECT_THROW(unite_cells(spans, flat.basis, flat.plane, {kRes, kTol, 0.5, 2}), InputError);
}

}  // namespace
}  // namespace planecell::map
