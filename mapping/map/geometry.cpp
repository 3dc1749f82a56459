#include "mapping/map/geometry.hpp"

#include "mapping/map/polygon2.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <boost/container/small_vector.hpp>

namespace planecell::map {

namespace bg = boost::geometry;

Aabb bounds_of(std::span<const Eigen::Vector3f> vertices) {
  Aabb box;
  for (const auto& v : vertices) box.extend(v.cast<double>());
  return box;
}

PlaneBasis make_basis(const Plane3& plane, const Eigen::Vector3d& near_point) {
  const Eigen::Vector3d n = plane.normal.normalized();
  // u: the world axis least aligned with n, made orthogonal to n.
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
  if (std::abs(n.x()) > std::abs(n.y()) && std::abs(n.x()) > std::abs(n.z()))
    axis = Eigen::Vector3d::UnitY();
  PlaneBasis basis;
  basis.u = (axis - axis.dot(n) * n).normalized();
  basis.v = n.cross(basis.u);
  basis.origin = near_point - plane.signed_distance(near_point) * n;
  return basis;
}

namespace {

template <class Vector>
double area_of(std::span<const Vector> vertices) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    const Eigen::Vector3d a = vertices[k].template cast<double>();
    const Eigen::Vector3d b = vertices[(k + 1) % vertices.size()].template cast<double>();
    sum += a.cross(b);
  }
  return 0.5 * sum.norm();
}

}  // namespace

double polygon_area_m2(std::span<const Eigen::Vector3f> vertices) { return area_of(vertices); }
double polygon_area_m2(std::span<const Eigen::Vector3d> vertices) { return area_of(vertices); }

Eigen::Vector3d vertex_centroid(std::span<const Eigen::Vector3f> vertices) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& v : vertices) sum += v.cast<double>();
  return vertices.empty() ? sum : Eigen::Vector3d(sum / static_cast<double>(vertices.size()));
}

std::vector<Eigen::Vector2d> project_to_basis(std::span<const Eigen::Vector3f> vertices, const PlaneBasis& basis) {
  std::vector<Eigen::Vector2d> out;
  out.reserve(vertices.size());
  for (const auto& v : vertices) out.push_back(basis.to_2d(v.cast<double>()));
  return out;
}

bool point_in_ring(std::span<const Eigen::Vector2d> ring, const Eigen::Vector2d& p) {
  bool in = false;
  for (std::size_t a = 0, b = ring.size() - 1; a < ring.size(); b = a++) {
    double x = 0.0;
    if (edge_crosses_row(ring[a], ring[b], p.y(), x) && p.x() < x) in = !in;
  }
  return in;
}

BoxedRing::BoxedRing(std::vector<Eigen::Vector2d> ring) : points(std::move(ring)) {
  for (const auto& p : points) box.extend(p);
}

Polygon2 to_polygon2(std::span<const Eigen::Vector3f> vertices, const PlaneBasis& basis) {
  Polygon2 poly;
  poly.outer().reserve(vertices.size() + 1);  // + the closing point bg::correct may add
  for (const auto& v : vertices) {
    const Eigen::Vector2d st = basis.to_2d(v.cast<double>());
    bg::append(poly.outer(), Point2(st.x(), st.y()));
  }
  bg::correct(poly);
  return poly;
}

double point_segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                              const Eigen::Vector3d& b) {
  return std::sqrt(point_segment_squared_distance(p, a, b));
}

namespace {

/// Distance from `point` to a polygon whose 2D outline in `basis` (a basis of its plane) is `poly`.
double distance_to_outline(const Eigen::Vector3d& point, const Plane3& plane, const PlaneBasis& basis,
                           const Polygon2& poly, std::span<const Eigen::Vector3f> vertices) {
  const Eigen::Vector2d st = basis.to_2d(point);
  if (bg::covered_by(Point2(st.x(), st.y()), poly)) return std::abs(plane.signed_distance(point));
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < vertices.size(); ++k)
    best = std::min(best, point_segment_distance(point, vertices[k].cast<double>(),
                                                 vertices[(k + 1) % vertices.size()].cast<double>()));
  return best;
}

}  // namespace

double distance_to_polygon(const Eigen::Vector3d& point, const Plane3& plane,
                           std::span<const Eigen::Vector3f> vertices) {
  if (vertices.size() < 3) return std::numeric_limits<double>::infinity();
  const PlaneBasis basis = make_basis(plane, point);
  return distance_to_outline(point, plane, basis, to_polygon2(vertices, basis), vertices);
}

double polygon_gap_m(const Plane3& plane_a, std::span<const Eigen::Vector3f> a,
                     const Plane3& plane_b, std::span<const Eigen::Vector3f> b) {
  if (a.size() < 3 || b.size() < 3) return std::numeric_limits<double>::infinity();
  // One basis and outline per polygon (not per vertex): the inside test is basis-independent.
  const PlaneBasis basis_a = make_basis(plane_a, a[0].cast<double>());
  const PlaneBasis basis_b = make_basis(plane_b, b[0].cast<double>());
  const Polygon2 poly_a = to_polygon2(a, basis_a), poly_b = to_polygon2(b, basis_b);
  double best = std::numeric_limits<double>::infinity();
  for (const auto& v : a) best = std::min(best, distance_to_outline(v.cast<double>(), plane_b, basis_b, poly_b, b));
  for (const auto& v : b) best = std::min(best, distance_to_outline(v.cast<double>(), plane_a, basis_a, poly_a, a));
  return best;
}

bool polygons_within_m(const Plane3& plane_a, std::span<const Eigen::Vector3f> a, const Aabb& box_a,
                       const Plane3& plane_b, std::span<const Eigen::Vector3f> b, const Aabb& box_b,
                       double max_m) {
  if (a.size() < 3 || b.size() < 3) return false;
  /// Is some vertex of `from` within max_m of the polygon `to` (on `plane`, bounds `box`)?
  const double max_m2 = max_m * max_m;  // edge tests compare squared distances (no square root)
  auto any_vertex_within = [max_m, max_m2](std::span<const Eigen::Vector3f> from, const Plane3& plane,
                                   std::span<const Eigen::Vector3f> to, const Aabb& box) {
    // to's outline in a basis of its plane, built for the first vertex that needs it (on the stack
    // for the usual few vertices).
    std::optional<PlaneBasis> basis;
    boost::container::small_vector<Eigen::Vector2d, 16> outline;
    for (const auto& vf : from) {
      const Eigen::Vector3d v = vf.cast<double>();
      const Eigen::Vector3d outside =
          (box.min - v).cwiseMax(v - box.max).cwiseMax(Eigen::Vector3d::Zero());
      if (outside.squaredNorm() > max_m2 || std::abs(plane.signed_distance(v)) > max_m) continue;
      // The polygon's distance is min(edge distances), or |plane distance| (≤ max_m, checked above)
      // when v projects inside it: within max_m iff an edge is, or v projects inside. A projection
      // on the outline is within an edge's reach already, so the even-odd test decides the rest.
      for (std::size_t k = 0; k < to.size(); ++k)
        if (point_segment_squared_distance(v, to[k].cast<double>(), to[(k + 1) % to.size()].cast<double>()) <=
            max_m2)
          return true;
      if (!basis) {
        basis = make_basis(plane, to[0].cast<double>());
        for (const auto& w : to) outline.push_back(basis->to_2d(w.cast<double>()));
      }
      if (point_in_ring({outline.data(), outline.size()}, basis->to_2d(v))) return true;
    }
    return false;
  };
  return any_vertex_within(a, plane_b, b, box_b) || any_vertex_within(b, plane_a, a, box_a);
}

bool polygons_within_m(const Plane3& plane_a, std::span<const Eigen::Vector3f> a,
                       const Plane3& plane_b, std::span<const Eigen::Vector3f> b, double max_m) {
  return polygons_within_m(plane_a, a, bounds_of(a), plane_b, b, bounds_of(b), max_m);
}

}  // namespace planecell::map
