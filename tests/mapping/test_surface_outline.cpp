/// Surface outlines: the exact boundary of a footprint's bits (hand-built squares, an annulus, a
/// strip), simplification within the tolerance, the lift onto the surface's current plane, bad
/// input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/error.hpp"
#include "mapping/map/surface_outline.hpp"
#include "support/expect_error.hpp"
#include "support/planecell_fixtures.hpp"

namespace planecell::map {
namespace {

using test::rectangle;

/// A surface's plane and detail: the plane z = 0, the basis make_basis builds there from the
/// origin (u = x, v = y) and an empty 10 cm footprint.
struct FlatSurface {
  Plane3 plane;
  SurfaceDetail detail;
};

FlatSurface flat_surface() {
  FlatSurface s;
  s.plane.normal = Eigen::Vector3d::UnitZ();
  s.plane.offset = 0.0;
  s.detail.basis = make_basis(s.plane, Eigen::Vector3d::Zero());
  s.detail.footprint = Footprint(0.1);
  return s;
}

/// True when `ring` holds exactly the (x, y, 0) points `corners` (any order, within 1e-9 m).
bool ring_has_corners(const OutlineRing& ring, std::vector<Eigen::Vector2d> corners) {
  if (ring.vertices_m.size() != corners.size()) return false;
  for (const auto& v : ring.vertices_m) {
    if (std::abs(v.z()) > 1e-9) return false;
    const auto it = std::find_if(corners.begin(), corners.end(), [&](const Eigen::Vector2d& c) {
      return (v.head<2>() - c).norm() < 1e-9;
    });
    if (it == corners.end()) return false;
    corners.erase(it);
  }
  return true;
}

TEST(SurfaceOutline, ASquareIsOneRingThroughItsCorners) {
  FlatSurface s = flat_surface();
  ASSERT_NEAR(s.detail.basis.u.x(), 1.0, 1e-12);  // the basis this test's corners are written in
  ASSERT_NEAR(s.detail.basis.v.y(), 1.0, 1e-12);
  s.detail.footprint.add_polygon(rectangle(0.0, 0.0, 1.0, 1.0));  // 10 × 10 bits
  const auto outline = surface_outline(s.plane, s.detail, 0.0);
  ASSERT_EQ(outline.size(), 1u);
  EXPECT_FALSE(outline[0].hole);
  EXPECT_TRUE(ring_has_corners(outline[0], {{0, 0}, {1, 0}, {1, 1}, {0, 1}}));
  EXPECT_NEAR(polygon_area_m2(outline[0].vertices_m), 1.0, 1e-9);
}

TEST(SurfaceOutline, ARectangleAcrossTileSeamsAndNegativeCoordinatesKeepsItsFourCorners) {
  FlatSurface s = flat_surface();
  // 32 bits per tile: −1.6 … 1.6 m spans tiles −1 and 0 along s, −0.3 … 0.5 along t as well.
  s.detail.footprint.add_polygon(rectangle(-1.6, -0.3, 1.6, 0.5));
  const auto outline = surface_outline(s.plane, s.detail, 0.0);
  ASSERT_EQ(outline.size(), 1u);
  EXPECT_TRUE(ring_has_corners(outline[0], {{-1.6, -0.3}, {1.6, -0.3}, {1.6, 0.5}, {-1.6, 0.5}}));
  EXPECT_NEAR(polygon_area_m2(outline[0].vertices_m), 3.2 * 0.8, 1e-9);
}

TEST(SurfaceOutline, AnAnnulusIsAnOuterRingFollowedByItsHole) {
  FlatSurface s = flat_surface();
  // A 2 m square with a 1 m square hole in its middle, as four strips.
  s.detail.footprint.add_polygon(rectangle(0.0, 0.0, 2.0, 0.5));
  s.detail.footprint.add_polygon(rectangle(0.0, 1.5, 2.0, 2.0));
  s.detail.footprint.add_polygon(rectangle(0.0, 0.5, 0.5, 1.5));
  s.detail.footprint.add_polygon(rectangle(1.5, 0.5, 2.0, 1.5));
  ASSERT_NEAR(s.detail.footprint.area_m2(), 3.0, 1e-9);
  const auto outline = surface_outline(s.plane, s.detail, 0.0);
  ASSERT_EQ(outline.size(), 2u);
  EXPECT_FALSE(outline[0].hole);
  EXPECT_TRUE(ring_has_corners(outline[0], {{0, 0}, {2, 0}, {2, 2}, {0, 2}}));
  EXPECT_TRUE(outline[1].hole);
  EXPECT_TRUE(ring_has_corners(outline[1], {{0.5, 0.5}, {1.5, 0.5}, {1.5, 1.5}, {0.5, 1.5}}));
  EXPECT_NEAR(polygon_area_m2(outline[0].vertices_m) - polygon_area_m2(outline[1].vertices_m), 3.0,
              1e-9);
}

TEST(SurfaceOutline, SimplificationKeepsASubsetOfCornersWithinTheTolerance) {
  FlatSurface s = flat_surface();
  std::vector<Eigen::Vector2d> disc;  // radius 1 m, 64 sides
  for (int k = 0; k < 64; ++k) {
    const double a = 2.0 * std::numbers::pi * k / 64.0;
    disc.emplace_back(std::cos(a), std::sin(a));
  }
  s.detail.footprint.add_polygon(disc);
  const auto exact = surface_outline(s.plane, s.detail, 0.0);
  const auto simple = surface_outline(s.plane, s.detail, 0.1);
  ASSERT_EQ(exact.size(), 1u);
  ASSERT_EQ(simple.size(), 1u);
  // Unsimplified: the bits' staircase, enclosing exactly the covered bits. Every vertex is a bit
  // corner (a multiple of 0.1 m), every edge runs along s or t, and consecutive edges turn by 90°
  // (no collinear vertex is left).
  const auto& stairs = exact[0].vertices_m;
  EXPECT_NEAR(polygon_area_m2(stairs), s.detail.footprint.area_m2(), 1e-9);
  for (std::size_t k = 0; k < stairs.size(); ++k) {
    const Eigen::Vector3d& v = stairs[k];
    EXPECT_NEAR(v.x() * 10.0, std::round(v.x() * 10.0), 1e-6);
    EXPECT_NEAR(v.y() * 10.0, std::round(v.y() * 10.0), 1e-6);
    const Eigen::Vector3d in = v - stairs[(k + stairs.size() - 1) % stairs.size()];
    const Eigen::Vector3d out = stairs[(k + 1) % stairs.size()] - v;
    EXPECT_NEAR(std::abs(in.x() * in.y()), 0.0, 1e-12);  // along an axis
    EXPECT_NEAR(in.dot(out), 0.0, 1e-12);                // a 90° turn
  }
  // Douglas–Peucker keeps a subset of the corners, at most half of them here, and moves the
  // boundary by at most the tolerance: the area changes by at most perimeter × tolerance
  // (2π · 1 m · 0.1 m).
  EXPECT_LE(2 * simple[0].vertices_m.size(), stairs.size());
  for (const auto& v : simple[0].vertices_m)
    EXPECT_TRUE(std::any_of(exact[0].vertices_m.begin(), exact[0].vertices_m.end(),
                            [&](const Eigen::Vector3d& w) { return (v - w).norm() < 1e-9; }));
  EXPECT_NEAR(polygon_area_m2(simple[0].vertices_m), polygon_area_m2(exact[0].vertices_m),
              2.0 * std::numbers::pi * 0.1);
}

TEST(SurfaceOutline, AStripNarrowerThanTheToleranceKeepsItsCorners) {
  FlatSurface s = flat_surface();
  s.detail.footprint.add_polygon(rectangle(0.0, 0.0, 3.0, 0.1));  // one bit wide
  const auto outline = surface_outline(s.plane, s.detail, 0.5);
  ASSERT_EQ(outline.size(), 1u);
  EXPECT_TRUE(ring_has_corners(outline[0], {{0, 0}, {3, 0}, {3, 0.1}, {0, 0.1}}));
}

TEST(SurfaceOutline, RingsLieOnTheSurfacesCurrentPlane) {
  FlatSurface s = flat_surface();
  s.detail.footprint.add_polygon(rectangle(0.0, 0.0, 1.0, 1.0));
  // The plane moved up by 0.5 m since the basis was made: same corners, at z = 0.5.
  s.plane.offset = -0.5;
  auto outline = surface_outline(s.plane, s.detail, 0.0);
  ASSERT_EQ(outline.size(), 1u);
  for (const auto& v : outline[0].vertices_m) EXPECT_NEAR(v.z(), 0.5, 1e-12);
  EXPECT_NEAR(polygon_area_m2(outline[0].vertices_m), 1.0, 1e-9);
  // Turned by 60° about x (n = (0, sin 60°, cos 60°) through the origin): the footprint projects
  // onto it along n, enclosing cos 60° = 1/2 of its area.
  const double a = std::numbers::pi / 3.0;
  s.plane.normal = Eigen::Vector3d(0.0, std::sin(a), std::cos(a));
  s.plane.offset = 0.0;
  outline = surface_outline(s.plane, s.detail, 0.0);
  ASSERT_EQ(outline.size(), 1u);
  for (const auto& v : outline[0].vertices_m) EXPECT_NEAR(s.plane.signed_distance(v), 0.0, 1e-12);
  EXPECT_NEAR(polygon_area_m2(outline[0].vertices_m), 0.5, 1e-9);
}

TEST(SurfaceOutline, EmptyFootprintAndBadTolerance) {
  FlatSurface s = flat_surface();
  EXPECT_TRUE(surface_outline(s.plane, s.detail, 0.1).empty());
  s.detail.footprint.add_polygon(rectangle(0.0, 0.0, 1.0, 1.0));
  EXPECT_CONTAINS(test::input_error_of([&] { surface_outline(s.plane, s.detail, -0.1); }), "tolerance");
  EXPECT_CONTAINS(test::input_error_of([&] { surface_outline(s.plane, s.detail, std::nan("")); }), "tolerance");
}

}  // namespace
}  // namespace planecell::map
