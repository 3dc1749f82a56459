#pragma once
/// A map cell's polygon in compact form. The map snaps stored vertices to its 1 mm grid
/// (geometry.hpp, snap_to_mm), so a polygon is kept as integer millimetres: its first vertex as
/// three int32 and every other vertex as three int16 offsets from it (|offset| ≤ 32.767 m), 6 B a
/// vertex instead of 12. A polygon off the grid or wider than that keeps its floats. Lossless:
/// vertex i comes back as the float it was built from, bit for bit (x = float(k / 1000) for the
/// grid coordinate k mm).
#include <Eigen/Core>
#include <boost/container/small_vector.hpp>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <memory>
#include <span>
#include <vector>

#include "mapping/map/geometry.hpp"

namespace planecell::map {

class StoredPolygon {
 public:
  /// Reads the vertices in order, decoding each (a value, not a reference).
  class Iterator {
   public:
    using iterator_category = std::input_iterator_tag;
    using value_type = Eigen::Vector3f;
    using difference_type = std::ptrdiff_t;
    using pointer = void;
    using reference = Eigen::Vector3f;
    Iterator() = default;
    Iterator(const StoredPolygon* polygon, std::size_t i) : polygon_(polygon), i_(i) {}
    const Eigen::Vector3f operator*() const { return (*polygon_)[i_]; }
    Iterator& operator++() {
      ++i_;
      return *this;
    }
    Iterator operator++(int) {
      Iterator before = *this;
      ++i_;
      return before;
    }
    bool operator==(const Iterator& o) const { return i_ == o.i_; }

   private:
    const StoredPolygon* polygon_ = nullptr;
    std::size_t i_ = 0;
  };

  StoredPolygon() = default;
  explicit StoredPolygon(std::span<const Eigen::Vector3f> vertices);
  explicit StoredPolygon(const std::vector<Eigen::Vector3f>& vertices)
      : StoredPolygon(std::span<const Eigen::Vector3f>(vertices)) {}
  StoredPolygon(const StoredPolygon& o);
  StoredPolygon& operator=(const StoredPolygon& o);
  StoredPolygon(StoredPolygon&&) noexcept = default;
  StoredPolygon& operator=(StoredPolygon&&) noexcept = default;

  std::size_t size() const { return header() & kSizeMask; }
  bool empty() const { return !data_; }
  /// Vertex i (i < size()).
  const Eigen::Vector3f operator[](std::size_t i) const;
  const Eigen::Vector3f front() const { return (*this)[0]; }
  const Eigen::Vector3f back() const { return (*this)[size() - 1]; }
  Iterator begin() const { return {this, 0}; }
  Iterator end() const { return {this, size()}; }
  /// The vertices as floats.
  std::vector<Eigen::Vector3f> vertices() const;
  /// The same into `out` (a contiguous container: std::vector, VertexScratch), its storage reused.
  template <class Container>
  void vertices_into(Container& out) const {
    out.resize(size());
    decode(out.data());
  }
  /// bounds_of(vertices()), without decoding into a vector.
  Aabb bounds() const;
  /// True when kept in millimetres (6 B a vertex after the first).
  bool compact() const { return (header() & kCompactBit) != 0; }
  /// Heap bytes (requested size).
  std::size_t bytes() const { return empty() ? 0 : heap_bytes(size(), compact()); }
  bool operator==(const StoredPolygon& o) const;

 private:
  static constexpr std::uint32_t kCompactBit = 1u << 31;
  static constexpr std::uint32_t kSizeMask = kCompactBit - 1;
  /// The heap block: a u32 header (vertex count, kCompactBit when in millimetres), then the
  /// vertices: an int32 anchor and int16 offsets, or 3 floats a vertex.
  static std::size_t heap_bytes(std::size_t n, bool compact) {
    return sizeof(std::uint32_t) + (compact ? 3 * sizeof(std::int32_t) + 3 * (n - 1) * sizeof(std::int16_t)
                                            : 3 * n * sizeof(float));
  }
  std::uint32_t header() const {  // inline: size() and compact() read it on every decode
    if (!data_) return 0;
    std::uint32_t header = 0;
    std::memcpy(&header, data_.get(), sizeof header);
    return header;
  }
  const std::byte* payload() const { return data_.get() + sizeof(std::uint32_t); }
  /// Writes the size() vertices to out[0 … size() − 1].
  void decode(Eigen::Vector3f* out) const;
  std::unique_ptr<std::byte[]> data_;  ///< null for no vertices; the object is one pointer
};

/// `vertices` snapped to the map's 1 mm grid (snap_to_mm) and stored: the compact form unless a
/// coordinate lies beyond ±2000 km or the polygon is wider than 32.767 m.
inline StoredPolygon on_mm_grid(std::vector<Eigen::Vector3f> vertices) {
  snap_to_mm(vertices);
  return StoredPolygon(vertices);
}

/// Room for a decoded polygon without a heap allocation for up to 16 vertices (most cells).
using VertexScratch = boost::container::small_vector<Eigen::Vector3f, 16>;

/// A polygon's vertices as a span: float vertices as they are, a stored polygon decoded into
/// `scratch` (std::vector or VertexScratch; the span is valid while scratch is).
template <class Scratch>
std::span<const Eigen::Vector3f> as_span(std::span<const Eigen::Vector3f> vertices, Scratch& /*scratch*/) {
  return vertices;
}
template <class Scratch>
std::span<const Eigen::Vector3f> as_span(const StoredPolygon& polygon, Scratch& scratch) {
  polygon.vertices_into(scratch);
  return {scratch.data(), scratch.size()};
}

/// The geometry of geometry.hpp on stored polygons (decoded first).
inline Aabb bounds_of(const StoredPolygon& polygon) { return polygon.bounds(); }
inline double polygon_area_m2(const StoredPolygon& polygon) {
  VertexScratch scratch;
  return polygon_area_m2(as_span(polygon, scratch));
}
inline Eigen::Vector3d vertex_centroid(const StoredPolygon& polygon) {
  VertexScratch scratch;
  return vertex_centroid(as_span(polygon, scratch));
}
inline std::vector<Eigen::Vector2d> project_to_basis(const StoredPolygon& polygon, const PlaneBasis& basis) {
  VertexScratch scratch;
  return project_to_basis(as_span(polygon, scratch), basis);
}
inline double distance_to_polygon(const Eigen::Vector3d& point, const Plane3& plane,
                                  const StoredPolygon& polygon) {
  VertexScratch scratch;
  return distance_to_polygon(point, plane, as_span(polygon, scratch));
}
template <class A, class B>
  requires(std::same_as<A, StoredPolygon> || std::same_as<B, StoredPolygon>)
bool polygons_within_m(const Plane3& plane_a, const A& a, const Aabb& box_a, const Plane3& plane_b,
                       const B& b, const Aabb& box_b, double max_m) {
  // Boxes farther apart than max_m: so is every vertex from the other box (no decoding needed).
  const Eigen::Vector3d gap =
      (box_a.min - box_b.max).cwiseMax(box_b.min - box_a.max).cwiseMax(Eigen::Vector3d::Zero());
  if (gap.norm() > max_m) return false;
  VertexScratch scratch_a, scratch_b;
  return polygons_within_m(plane_a, as_span(a, scratch_a), box_a, plane_b, as_span(b, scratch_b),
                           box_b, max_m);
}

}  // namespace planecell::map
