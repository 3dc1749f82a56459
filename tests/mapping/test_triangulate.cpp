/// Ear-clipping triangulation of planecell polygons (map::triangulate_polygon), against
/// hand-computed areas: convex, L-shaped, comb-shaped (whose vertex centroid lies outside, where
/// a fan fails), tilted in 3D and clockwise.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "mapping/map/geometry.hpp"
#include "mapping/map/triangulate.hpp"

namespace planecell::map {
namespace {

using Ring = std::vector<Eigen::Vector3f>;

/// Counter-clockwise ring in the z = 0 plane from (x, y) pairs.
Ring flat(std::initializer_list<std::pair<float, float>> xy) {
  Ring ring;
  for (const auto& [x, y] : xy) ring.emplace_back(x, y, 0.0f);
  return ring;
}

Eigen::Vector3d normal_of(const Ring& r, const std::array<int, 3>& t) {
  return (r[t[1]] - r[t[0]]).cast<double>().cross((r[t[2]] - r[t[0]]).cast<double>());
}

/// Checks the triangulation of `ring`: n − 2 triangles of its own vertices, each facing the
/// polygon's normal (no fold-over), areas summing to `area_m2`, and every centroid passing
/// `inside` (a hand-written membership test of the shape).
template <class Inside>
void expect_tiles(const Ring& ring, double area_m2, Inside&& inside) {
  const auto triangles = triangulate_polygon(ring);
  ASSERT_EQ(triangles.size(), ring.size() - 2);
  Eigen::Vector3d polygon_normal = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < ring.size(); ++k)
    polygon_normal += ring[k].cast<double>().cross(ring[(k + 1) % ring.size()].cast<double>());
  double sum = 0.0;
  for (const auto& t : triangles) {
    for (int i : t) ASSERT_TRUE(i >= 0 && i < static_cast<int>(ring.size()));
    const Eigen::Vector3d n = normal_of(ring, t);
    EXPECT_GT(n.dot(polygon_normal), 0.0) << "triangle " << t[0] << " " << t[1] << " " << t[2];
    sum += 0.5 * n.norm();
    const Eigen::Vector3f centroid = (ring[t[0]] + ring[t[1]] + ring[t[2]]) / 3.0f;
    EXPECT_TRUE(inside(centroid)) << centroid.transpose();
  }
  EXPECT_NEAR(sum, area_m2, 1e-5);
  EXPECT_NEAR(polygon_area_m2(ring), area_m2, 1e-5);
}

TEST(TriangulatePolygon, ConvexSquareGivesTwoTriangles) {
  expect_tiles(flat({{0, 0}, {2, 0}, {2, 2}, {0, 2}}), 4.0, [](const Eigen::Vector3f& c) {
    return c.x() > 0 && c.x() < 2 && c.y() > 0 && c.y() < 2;
  });
}

TEST(TriangulatePolygon, LShapeIsTiledExactly) {
  // 2 × 2 square without its top-right 1 × 1 quarter: area 3.
  const auto in_l = [](const Eigen::Vector3f& c) {
    return c.x() > 0 && c.x() < 2 && c.y() > 0 && c.y() < 2 && !(c.x() > 1 && c.y() > 1);
  };
  expect_tiles(flat({{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}}), 3.0, in_l);
}

TEST(TriangulatePolygon, CombWhoseCentroidIsOutside) {
  // A "U": 3 wide, 3 tall, a 1 × 2.5 slot from the top in the middle (area 9 − 2.5 = 6.5). The
  // vertex centroid (1.5, 1.625) lies in the slot, so a fan around it would cover the slot.
  const Ring u = flat({{0, 0}, {3, 0}, {3, 3}, {2, 3}, {2, 0.5f}, {1, 0.5f}, {1, 3}, {0, 3}});
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  for (const auto& v : u) centroid += v / 8.0f;
  ASSERT_TRUE(centroid.x() > 1 && centroid.x() < 2 && centroid.y() > 0.5f);
  expect_tiles(u, 6.5, [](const Eigen::Vector3f& c) {
    return c.x() > 0 && c.x() < 3 && c.y() > 0 && c.y() < 3 &&
           !(c.x() > 1 && c.x() < 2 && c.y() > 0.5f);
  });
}

TEST(TriangulatePolygon, TiltedClockwiseRingIsTiledToo) {
  // The L shape reversed (clockwise) and rotated 40° about (1, 1, 1)/√3, then moved 100 m away.
  Ring l = flat({{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}});
  std::reverse(l.begin(), l.end());
  const Eigen::Matrix3f r =
      Eigen::AngleAxisf(0.698f, Eigen::Vector3f(1, 1, 1).normalized()).toRotationMatrix();
  const Eigen::Vector3f shift(100, -40, 7);
  Ring tilted;
  for (const auto& v : l) tilted.push_back(r * v + shift);
  expect_tiles(tilted, 3.0, [&](const Eigen::Vector3f& c) {
    const Eigen::Vector3f back = r.transpose() * (c - shift);
    return std::abs(back.z()) < 1e-4f && back.x() > 0 && back.x() < 2 && back.y() > 0 &&
           back.y() < 2 && !(back.x() > 1 && back.y() > 1);
  });
}

TEST(TriangulatePolygon, CollinearVerticesAndTinyRings) {
  // A 2 × 1 rectangle with an extra vertex mid-way along each long edge: 6 vertices, 4 triangles.
  expect_tiles(
      flat({{0, 0}, {1, 0}, {2, 0}, {2, 1}, {1, 1}, {0, 1}}), 2.0,
      [](const Eigen::Vector3f& c) { return c.x() > 0 && c.x() < 2 && c.y() > 0 && c.y() < 1; });
  EXPECT_TRUE(triangulate_polygon(flat({{0, 0}, {1, 0}})).empty());
  EXPECT_EQ(triangulate_polygon(flat({{0, 0}, {1, 0}, {0, 1}})).size(), 1u);
}

/// A self-touching ring (a bow tie from a bad simplification) still yields n − 2 triangles of its
/// own vertices instead of looping or reading out of range.
TEST(TriangulatePolygon, NonSimpleRingStillGivesNMinusTwoTriangles) {
  const Ring bow = flat({{0, 0}, {2, 2}, {2, 0}, {0, 2}, {-1, 1}});
  const auto triangles = triangulate_polygon(bow);
  ASSERT_EQ(triangles.size(), bow.size() - 2);
  for (const auto& t : triangles)
    for (int i : t) EXPECT_TRUE(i >= 0 && i < static_cast<int>(bow.size()));
}

}  // namespace
}  // namespace planecell::map
