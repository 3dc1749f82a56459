#include "mapping/map/triangulate.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <numeric>

namespace planecell::map {
namespace {

/// Twice the signed area of (a, b, c): > 0 for a counter-clockwise turn.
double turn(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
}

/// True when p lies inside or on the counter-clockwise triangle (a, b, c).
bool in_triangle(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                 const Eigen::Vector2d& c) {
  return turn(a, b, p) >= 0.0 && turn(b, c, p) >= 0.0 && turn(c, a, p) >= 0.0;
}

}  // namespace

std::vector<std::array<int, 3>> triangulate_polygon(std::span<const Eigen::Vector3f> vertices) {
  const int n = static_cast<int>(vertices.size());
  std::vector<std::array<int, 3>> triangles;
  if (n < 3) return triangles;
  triangles.reserve(static_cast<std::size_t>(n - 2));
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k)
    normal += vertices[k].cast<double>().cross(vertices[(k + 1) % n].cast<double>());
  // Drop the dominant axis; order the other two so that the polygon turns counter-clockwise.
  int drop = 0;
  normal.cwiseAbs().maxCoeff(&drop);
  int a = (drop + 1) % 3, b = (drop + 2) % 3;
  if (normal(drop) < 0.0) std::swap(a, b);
  std::vector<Eigen::Vector2d> p(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) p[k] = {vertices[k](a), vertices[k](b)};

  std::vector<int> ring(static_cast<std::size_t>(n));
  std::iota(ring.begin(), ring.end(), 0);
  while (ring.size() > 3) {
    const int m = static_cast<int>(ring.size());
    int clip = -1, most_convex = 0;
    double best_turn = -std::numeric_limits<double>::infinity();
    for (int i = 0; i < m && clip < 0; ++i) {
      const int prev = ring[(i + m - 1) % m], cur = ring[i], next = ring[(i + 1) % m];
      const double t = turn(p[prev], p[cur], p[next]);
      if (t > best_turn) best_turn = t, most_convex = i;
      if (t <= 0.0) continue;  // reflex or straight: not an ear
      bool empty = true;
      for (int j = 0; j < m && empty; ++j) {
        const int other = ring[j];
        if (other == prev || other == cur || other == next) continue;
        if (p[other] == p[prev] || p[other] == p[cur] || p[other] == p[next])
          continue;  // a repeated vertex
        empty = !in_triangle(p[other], p[prev], p[cur], p[next]);
      }
      if (empty) clip = i;
    }
    if (clip < 0) clip = most_convex;  // not simple: no ear left
    triangles.push_back({ring[(clip + m - 1) % m], ring[clip], ring[(clip + 1) % m]});
    ring.erase(ring.begin() + clip);
  }
  triangles.push_back({ring[0], ring[1], ring[2]});
  return triangles;
}

}  // namespace planecell::map
