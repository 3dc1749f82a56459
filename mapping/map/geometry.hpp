#pragma once
/// Geometry of planar polygons in 3D for the global map: plane bases, areas, distances, bounds.
/// (Boost.Geometry's 2D types stay in mapping/map/polygon2.hpp, out of this widely included header.)
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <limits>
#include <span>
#include <vector>

#include "core/plane.hpp"

namespace planecell::map {

/// Axis-aligned box in 3D (m). Empty when min > max.
struct Aabb {
  Eigen::Vector3d min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d max = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());

  bool empty() const { return (min.array() > max.array()).any(); }
  void extend(const Eigen::Vector3d& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  void extend(const Aabb& o) {
    min = min.cwiseMin(o.min);
    max = max.cwiseMax(o.max);
  }
  Aabb inflated(double margin_m) const {
    return {(min.array() - margin_m).matrix(), (max.array() + margin_m).matrix()};
  }
  bool overlaps(const Aabb& o) const {  // six scalar tests (inlined; called ~10⁵ times a frame)
    return min.x() <= o.max.x() && min.y() <= o.max.y() && min.z() <= o.max.z() && o.min.x() <= max.x() &&
           o.min.y() <= max.y() && o.min.z() <= max.z();
  }
  bool operator==(const Aabb&) const = default;
};

/// Bounds of a polygon's vertices.
Aabb bounds_of(std::span<const Eigen::Vector3f> vertices);

/// Orthonormal 2D frame on a plane: X = origin + s·u + t·v, with u × v = normal.
struct PlaneBasis {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d v = Eigen::Vector3d::UnitY();

  /// Orthogonal projection (s, t) = ((X − o)·u, (X − o)·v).
  Eigen::Vector2d to_2d(const Eigen::Vector3d& x) const {
    const Eigen::Vector3d d = x - origin;
    return {d.dot(u), d.dot(v)};
  }
  Eigen::Vector3d to_3d(const Eigen::Vector2d& st) const { return origin + st.x() * u + st.y() * v; }
  bool operator==(const PlaneBasis&) const = default;
};

/// Basis on `plane` with origin at the projection of `near_point` onto the plane.
PlaneBasis make_basis(const Plane3& plane, const Eigen::Vector3d& near_point);

/// Storage precision. The map rounds its planes, bases, areas and stored vertices where they
/// enter it, to what io::MapStore writes compactly (io/map_codec) and still reads back exactly:
/// reals to the nearest float (relative error ≤ 2⁻²⁴ ≈ 6·10⁻⁸: 0.06 mm at 1 km, 10⁻⁷ rad) and
/// vertex coordinates to a 1 mm grid (x ↦ float(round(1000 x) / 1000)), far below SGM's depth
/// noise and the 10 cm footprint bits. Values beyond ±10⁹ m are left as they are.
/// (The float goes through a volatile: built with GCC 12 at -O3 -mavx2 -mfma, one translation
/// unit returned x unrounded from a plain double→float→double cast, not at -O2 or without AVX2;
/// the store's codec test PlaneRoundTripsExactlyAndShortWhenFloat catches a regression.)
inline double to_float_precision(double x) {
  volatile float rounded = static_cast<float>(x);
  return static_cast<double>(rounded);
}
inline Eigen::Vector3d to_float_precision(const Eigen::Vector3d& v) {
  return {to_float_precision(v.x()), to_float_precision(v.y()), to_float_precision(v.z())};
}
inline Plane3 to_float_precision(const Plane3& p) {
  Plane3 out;
  out.normal = to_float_precision(p.normal);
  out.offset = to_float_precision(p.offset);
  return out;
}
inline PlaneBasis to_float_precision(const PlaneBasis& b) {
  return {to_float_precision(b.origin), to_float_precision(b.u), to_float_precision(b.v)};
}
/// A plane kept at storage precision: unit normal and offset as floats, 16 B instead of
/// Plane3's 32. Built from a Plane3 by to_float_precision (so lossless for a plane the map has
/// rounded), read back as a Plane3 of doubles.
class StoredPlane {
 public:
  StoredPlane() = default;
  StoredPlane(const Plane3& plane)  // NOLINT(google-explicit-constructor): a Plane3 stored
      : normal_(to_float_precision(plane.normal).cast<float>()),
        offset_(static_cast<float>(to_float_precision(plane.offset))) {}
  operator Plane3() const { return {normal(), offset()}; }  // NOLINT(google-explicit-constructor)
  Eigen::Vector3d normal() const { return normal_.cast<double>(); }
  double offset() const { return offset_; }
  /// n·X + e (m), in double.
  double signed_distance(const Eigen::Vector3d& point) const { return normal().dot(point) + offset(); }
  bool operator==(const StoredPlane&) const = default;

 private:
  Eigen::Vector3f normal_ = Eigen::Vector3f::UnitZ();
  float offset_ = 0.0f;
};

/// A cell's mean colour kept as three bytes (0..255 R G B), 3 B instead of 12: each channel
/// rounded to the nearest integer and clamped to 0..255 (NaN → 0), what an 8-bit image and every
/// export hold. Reads as floats.
class StoredColour {
 public:
  StoredColour() = default;
  StoredColour(const Eigen::Vector3f& rgb)  // NOLINT(google-explicit-constructor): a colour stored
      : rgb_{to_byte(rgb.x()), to_byte(rgb.y()), to_byte(rgb.z())} {}
  operator Eigen::Vector3f() const { return {(*this)[0], (*this)[1], (*this)[2]}; }  // NOLINT
  /// Channel c (0 R, 1 G, 2 B) as a float.
  float operator[](int c) const { return static_cast<float>(rgb_[static_cast<std::size_t>(c)]); }
  bool operator==(const StoredColour&) const = default;

 private:
  static std::uint8_t to_byte(float x) {
    return std::isnan(x) ? 0 : static_cast<std::uint8_t>(std::clamp(std::round(x), 0.0f, 255.0f));
  }
  std::array<std::uint8_t, 3> rgb_{};
};

/// An axis-aligned box kept as floats, 24 B instead of Aabb's 48. Built from an Aabb rounded
/// outwards (min down, max up to the next float), so it always contains the box it stores and
/// is exact for a box of float coordinates (the bounds of a map polygon's vertices).
class StoredBox {
 public:
  StoredBox() = default;
  StoredBox(const Aabb& box)  // NOLINT(google-explicit-constructor): an Aabb stored
      : min_(outward(box.min, -1.0)), max_(outward(box.max, +1.0)) {}
  operator Aabb() const { return {min(), max()}; }  // NOLINT(google-explicit-constructor)
  Eigen::Vector3d min() const { return min_.cast<double>(); }
  Eigen::Vector3d max() const { return max_.cast<double>(); }
  bool empty() const { return (min_.array() > max_.array()).any(); }
  void extend(const Aabb& other) {
    Aabb box = *this;
    box.extend(other);
    *this = box;
  }
  bool operator==(const StoredBox&) const = default;

 private:
  /// Each coordinate to the nearest float, moved one float further towards `direction` when
  /// rounding went the other way (±∞ stay).
  static Eigen::Vector3f outward(const Eigen::Vector3d& v, double direction) {
    Eigen::Vector3f out;
    for (int k = 0; k < 3; ++k) {
      float f = static_cast<float>(to_float_precision(v[k]));
      if ((static_cast<double>(f) - v[k]) * direction < 0.0)
        f = std::nextafter(f, direction > 0.0 ? std::numeric_limits<float>::infinity()
                                              : -std::numeric_limits<float>::infinity());
      out[k] = f;
    }
    return out;
  }
  Eigen::Vector3f min_ = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  Eigen::Vector3f max_ = Eigen::Vector3f::Constant(-std::numeric_limits<float>::infinity());
};

/// The coordinate k mm on the grid: float(k / 1000) m (io/map_codec decodes with it).
inline float from_mm(std::int64_t k) { return static_cast<float>(static_cast<double>(k) / 1000.0); }
inline float snap_to_mm(float x) {
  return std::abs(x) < 1e9f ? from_mm(std::llround(static_cast<double>(x) * 1000.0)) : x;
}
inline void snap_to_mm(std::vector<Eigen::Vector3f>& vertices) {
  for (auto& v : vertices) v = v.unaryExpr([](float x) { return snap_to_mm(x); });
}

/// Polygon area (m²) by Newell's vector area: A = ½ |Σ_k v_k × v_{k+1}|.
double polygon_area_m2(std::span<const Eigen::Vector3f> vertices);
double polygon_area_m2(std::span<const Eigen::Vector3d> vertices);

/// Mean of the vertices (m).
Eigen::Vector3d vertex_centroid(std::span<const Eigen::Vector3f> vertices);

/// The vertices projected orthogonally into `basis`: (s, t) = basis.to_2d(v), same order.
std::vector<Eigen::Vector2d> project_to_basis(std::span<const Eigen::Vector3f> vertices, const PlaneBasis& basis);

/// Where the ring edge u–w crosses the horizontal line at height y, when it counts for the
/// even-odd rule (exactly one of its ends lies above y): x = (w_x − u_x)(y − u_y)/(w_y − u_y) + u_x.
/// A point (x_p, y) is inside a ring iff an odd number of its edges cross right of it (x_p < x).
inline bool edge_crosses_row(const Eigen::Vector2d& u, const Eigen::Vector2d& w, double y, double& x) {
  if ((u.y() > y) == (w.y() > y)) return false;
  x = (w.x() - u.x()) * (y - u.y()) / (w.y() - u.y()) + u.x();
  return true;
}

/// Even-odd rule: is `p` inside the ring (either orientation, closing vertex optional)?
bool point_in_ring(std::span<const Eigen::Vector2d> ring, const Eigen::Vector2d& p);

/// A ring with its bounding box: contains(p) = point_in_ring(points, p), the crossing test run only
/// for points inside the box (a ring lies inside its box, so the answer is the same).
struct BoxedRing {
  std::vector<Eigen::Vector2d> points;
  Eigen::AlignedBox2d box;
  explicit BoxedRing(std::vector<Eigen::Vector2d> ring);
  bool contains(const Eigen::Vector2d& p) const {
    return points.size() >= 3 && box.contains(p) && point_in_ring(points, p);
  }
};

/// Distance (m) of `point` to the planar polygon `vertices` lying on `plane`:
///   the paper's point-to-plane distance |n·p + e| when p's projection onto the plane falls inside
///   the polygon; otherwise the distance to the nearest point of the polygon's boundary edges.
double distance_to_polygon(const Eigen::Vector3d& point, const Plane3& plane,
                           std::span<const Eigen::Vector3f> vertices);

/// Smallest gap (m) between two planar polygons, approximated by the vertex-to-polygon distances
/// both ways: min(min_k dist(a_k, B), min_k dist(b_k, A)). 0 when a vertex of one lies on the other.
double polygon_gap_m(const Plane3& plane_a, std::span<const Eigen::Vector3f> a,
                     const Plane3& plane_b, std::span<const Eigen::Vector3f> b);

/// polygon_gap_m(a, b) ≤ max_m, decided without computing the whole minimum: a vertex v is
/// skipped when a lower bound of its distance to the other polygon already exceeds max_m (its
/// distance to that polygon's bounding box, or to its plane, |n·v + e|), and the test stops at the
/// first vertex within max_m.
bool polygons_within_m(const Plane3& plane_a, std::span<const Eigen::Vector3f> a,
                       const Plane3& plane_b, std::span<const Eigen::Vector3f> b, double max_m);
/// The same with the polygons' bounds given (box_a = bounds_of(a), box_b = bounds_of(b)).
bool polygons_within_m(const Plane3& plane_a, std::span<const Eigen::Vector3f> a, const Aabb& box_a,
                       const Plane3& plane_b, std::span<const Eigen::Vector3f> b, const Aabb& box_b,
                       double max_m);

/// Squared distance (m²) of a point to the segment [a, b]: |a + t·(b − a) − p|² with
/// t = clamp((p − a)·(b − a) / |b − a|², 0, 1) (t = 0 for a point segment). Inline: the hot
/// loops of polygons_within_m compare it with max_m² instead of taking square roots.
inline double point_segment_squared_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                             const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).squaredNorm();
}

/// Distance (m) of a point to the segment [a, b]: √point_segment_squared_distance.
double point_segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                              const Eigen::Vector3d& b);

}  // namespace planecell::map
