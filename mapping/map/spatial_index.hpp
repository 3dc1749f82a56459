#pragma once
/// Spatial index of the global map: a hashed 3D grid of cell bounds. Answers "ids whose bounds
/// overlap this box" touching only the grid buckets the box covers, so per-frame work depends on
/// the neighbourhood of the new cells, not on the size of the map. The index keeps only the ids
/// in their buckets; the exact overlap test asks the owner for an id's box (the map derives it
/// from the cell's vertices), so the boxes are not stored twice.
#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "mapping/map/geometry.hpp"

namespace planecell::map {

class SpatialIndex {
 public:
  /// `bucket_m`: edge length of a grid bucket (m); must be > 0 (ConfigError otherwise).
  explicit SpatialIndex(double bucket_m = 2.0);

  /// Registers `id` in every bucket its box touches. Throws InputError when the box leaves the
  /// indexable cube |x|, |y|, |z| ≤ max_coordinate_m() (bucket coordinates are 21-bit keys).
  void insert(std::uint32_t id, const Aabb& box);
  /// Removes `id` (registered with the same box).
  void remove(std::uint32_t id, const Aabb& box);
  /// Ids registered in the buckets `box` touches: sorted, unique, a superset of the ids whose
  /// box overlaps `box`.
  std::vector<std::uint32_t> candidates(const Aabb& box) const;
  /// The same into `out` (cleared first), reusing its storage across queries.
  void candidates(const Aabb& box, std::vector<std::uint32_t>& out) const;
  /// Those of candidates(box) whose box, box_of(id) (the box `id` was registered with), overlaps
  /// `box`; sorted, unique.
  template <class BoxOf>
  std::vector<std::uint32_t> query(const Aabb& box, BoxOf&& box_of) const {
    std::vector<std::uint32_t> ids = candidates(box);
    std::erase_if(ids, [&](std::uint32_t id) { return !box_of(id).overlaps(box); });
    return ids;
  }

  /// The buckets a box touches: integer bucket coordinates lo … hi on each axis (inclusive),
  /// floor(coordinate / bucket_m) clamped to the key range; `empty` for an empty or non-finite
  /// box (no bucket). An id is among candidates(box) iff the range of the box it was registered
  /// with overlaps the query box's range.
  struct BucketRange {
    std::array<std::int64_t, 3> lo{}, hi{};
    bool empty = true;
    bool overlaps(const BucketRange& other) const {
      if (empty || other.empty) return false;
      for (int a = 0; a < 3; ++a)
        if (lo[a] > other.hi[a] || other.lo[a] > hi[a]) return false;
      return true;
    }
    bool operator==(const BucketRange&) const = default;
  };
  BucketRange bucket_range(const Aabb& box) const;

  std::size_t size() const { return size_; }
  /// Half-width of the indexable cube: bucket_m · (2²⁰ − 1) (2 m buckets: ±2097 km).
  double max_coordinate_m() const { return bucket_m_ * static_cast<double>((1 << 20) - 1); }
  void clear();
  /// Heap bytes of the buckets and their id vectors (requested sizes).
  std::size_t bytes() const;

 private:
  template <class F>
  void for_each_bucket(const Aabb& box, F&& f) const;

  double bucket_m_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> buckets_;
  std::size_t size_ = 0;  ///< ids registered
};

}  // namespace planecell::map
